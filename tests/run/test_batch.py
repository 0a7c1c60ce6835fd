"""``track DATASET --all``: every sequence as Dask tasks, finished ones skipped, failures reported."""

import re
import shutil

import numpy as np
import pytest

from voxelmocap.cli import main
from voxelmocap.config import TrackConfig, config_to_toml, with_overrides
from voxelmocap.io.results import read_result
from voxelmocap.run.batch import BatchItem, dataset_items, result_is_done
from voxelmocap.run.pipeline import track_sequence
from voxelmocap.run.tasks import run_tasks

#: Three short sequences of two subjects (3 frames, 3 cameras each).
SEQUENCES = (("S1", "walk", 1, "Walking_1"), ("S1", "jog", 1, "Jog_1"),
             ("S2", "walk", 2, "Walking_2"))
SETTINGS = ["--frames", "1:3", "--layers", "1", "--particles", "20", "--voxel-size", "40",
            "--no-progress"]


@pytest.fixture(scope="module")
def three(tmp_path_factory):
    from voxelmocap.synth import generate

    root = tmp_path_factory.mktemp("three")
    for subject, motion, trial, _ in SEQUENCES:
        generate(root, motion=motion, subject=subject, trial=trial, frames=3,
                 cameras=["C1", "C2", "BW1"], progress=False, background_frames=10, seed=trial)
    return root


def _config():
    return with_overrides(TrackConfig(), **{"filter.layers": 1, "filter.particles": 20,
                                            "measurement.voxel_size": 40.0})


def test_dataset_items_lists_every_sequence_with_videos(three):
    assert dataset_items(three) == [BatchItem("S1", "Jog_1"), BatchItem("S1", "Walking_1"),
                                    BatchItem("S2", "Walking_2")]


def test_all_on_a_local_dask_cluster_then_skipped(three, tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["track", str(three), "--all", "--out", str(run), "--workers", "2",
                 *SETTINGS]) == 0
    out = capsys.readouterr().out
    assert "summary: 3 done, 0 skipped, 0 failed" in out
    config_toml = config_to_toml(_config())
    for subject, _, _, name in SEQUENCES:
        path = run / subject / f"{name}.h5"
        batch = read_result(path)
        assert batch.attrs["complete"] and len(batch) == 3
        assert result_is_done(path, config_toml, 0)
        assert (run / subject / f"{name}.bvh").exists()
        # the task ran the same tracking as a direct call: bit-identical states
        alone = track_sequence(three, subject, name, tmp_path / "alone", config=_config(),
                               frames="1:3", seed=0, progress=False)
        np.testing.assert_array_equal(batch.state, read_result(alone.result_path).state)
    log = (run / "voxelmocap.log").read_text()
    assert "[S2/Walking_2] S2/Walking_2: 3 frames" in log  # written by the worker process
    # each sequence's line gives its whole wall time and rate, not only its last pass's loop
    assert re.search(r"S2/Walking_2: 3 frames in (\d+ min )?[0-9.]+ s \([0-9.]+ frames/s for the whole "
                     r"sequence; its last pass's frame loop [0-9.]+ frames/s\) → ", out)

    stamps = {p: p.stat().st_mtime_ns for p in run.rglob("*.h5")}
    assert main(["track", str(three), "--all", "--out", str(run), "--workers", "2",
                 *SETTINGS]) == 0
    out = capsys.readouterr().out
    assert "3 sequences, 3 already done, 0 to track" in out
    assert "summary: 0 done, 3 skipped, 0 failed" in out
    assert {p: p.stat().st_mtime_ns for p in run.rglob("*.h5")} == stamps
    # other settings do not count as done: the sequence is refused with the reason, not redone
    assert not result_is_done(run / "S1" / "Walking_1.h5", config_to_toml(TrackConfig()), 0)
    assert not result_is_done(run / "S1" / "Walking_1.h5", config_toml, 1)


def test_a_broken_sequence_is_reported_and_the_others_done(three, tmp_path, capsys):
    data = tmp_path / "data"
    shutil.copytree(three, data)
    ofs = data / "S1" / "Sync_Data" / "Jog_1_(C2).ofs"
    ofs.write_text("not a sync file\n")
    run = tmp_path / "run"
    assert main(["track", str(data), "--all", "--out", str(run), "--workers", "2",
                 *SETTINGS]) == 1
    out = capsys.readouterr().out
    assert "summary: 2 done, 0 skipped, 1 failed" in out
    failed = [line for line in out.splitlines() if line.startswith("  failed:")]
    assert len(failed) == 1 and failed[0].startswith(f"  failed:  S1/Jog_1: {ofs}: ")
    assert read_result(run / "S1" / "Walking_1.h5").attrs["complete"]
    assert read_result(run / "S2" / "Walking_2.h5").attrs["complete"]
    assert not (run / "S1" / "Jog_1.h5").exists()
    # in this process (no --workers): the same outcome, the done ones skipped
    assert main(["track", str(data), "--all", "--out", str(run), *SETTINGS]) == 1
    assert "summary: 0 done, 2 skipped, 1 failed" in capsys.readouterr().out


def test_all_refuses_single_sequence_options(three, tmp_path, capsys):
    for extra, message in ((["--all", "--subject", "S1"], "--subject: not with --all"),
                           (["--workers", "2", "--subject", "S1", "--sequence", "Walking_1"],
                            "--workers: only with --all"),
                           ([], "needs --subject and --sequence")):
        assert main(["track", str(three), "--out", str(tmp_path / "r"), *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "r").exists()


def _fails(x):
    raise ValueError(f"bad {x}")


def test_run_tasks_keeps_going_or_stops():
    outcomes = run_tasks([("a", pow, (2, 5)), ("b", _fails, (3,)), ("c", pow, (3, 2))],
                         local=True, progress=False)
    assert [(o.key, o.ok, o.value, o.error) for o in outcomes] == [
        ("a", True, 32, None), ("b", False, None, "ValueError: bad 3"), ("c", True, 9, None)]
    with pytest.raises(ValueError, match="bad 3"):
        run_tasks([("b", _fails, (3,))], local=True, progress=False, stop_on_error=True)
