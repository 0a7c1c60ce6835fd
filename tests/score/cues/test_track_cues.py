"""``voxelmocap track --cues``: monocular and stereo runs on the tiny data set; the result records
the cues."""

import pytest

from voxelmocap.cli import main
from voxelmocap.config import config_from_toml
from voxelmocap.io.results import read_result


@pytest.mark.parametrize("cameras, cues, weights", [
    ("C1", "edges,roi=0.5", {"edges": 1.0, "roi": 0.5}),
    ("C1,C2", "voxel,roi,edges=0.1", {"voxel": 1.0, "roi": 1.0, "edges": 0.1}),
])
def test_track_with_cues_records_them(tiny_dataset, tmp_path, cameras, cues, weights):
    out = tmp_path / "run"
    argv = ["track", str(tiny_dataset), "--subject", "S1", "--sequence", "Walking_1", "--out",
            str(out), "--no-progress", "--cameras", cameras, "--cues", cues, "--layers", "2",
            "--particles", "20", "--frames", "1:2"]
    assert main(argv) == 0
    result = read_result(out / "S1" / "Walking_1.h5")
    config = config_from_toml(result.attrs["config"])
    assert config.cues.weights == weights
    assert len(result.frames) == 2
    # a resumed run with the same cues is accepted (the stored config matches)
    assert main(argv + ["--resume"]) == 0
