"""Tracking a Pose2Sim / anipose / EasyMocap project gives what tracking the HumanEva layout gives.

The projects are written from the rendered walk (``tests/project_fixture.py``). Without ground
truth and body file on both sides (the HumanEva copy loses its Mocap_Data), both runs size the body
from the voxels and start from them, so equal pixels and equal cameras must give equal results:

* lossless PNG image folders against the HumanEva layout itself;
* mp4 (lossy) against the HumanEva layout that ``voxelmocap import`` writes from the same mp4
  frames (lossless FFV1), and loosely against the original (the carved volume).
"""

import shutil

import numpy as np
import pytest
from project_fixture import make_project

from voxelmocap.cli import main
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.io.humaneva import Dataset
from voxelmocap.io.importer import import_sequence
from voxelmocap.io.project import Project
from voxelmocap.io.results import read_result
from voxelmocap.run.measurement import MeasurementRunner
from voxelmocap.run.pipeline import track_sequence

SMALL = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 60})
CAMERAS = ["C1", "C2", "C3"]
QUIET = {"config": SMALL, "frames": "1:3", "seed": 1, "progress": False, "log": lambda *_: None}


@pytest.fixture(scope="module")
def walk_no_answer(walk_dataset, tmp_path_factory):
    """The rendered walk without ground truth and body file."""
    root = tmp_path_factory.mktemp("noanswer") / "data"
    shutil.copytree(walk_dataset, root)
    shutil.rmtree(root / "S1" / "Mocap_Data")
    return root


@pytest.fixture(scope="module")
def humaneva_run(walk_no_answer, tmp_path_factory):
    out = tmp_path_factory.mktemp("he_run")
    outcome = track_sequence(walk_no_answer, "S1", "Walking_1", out, cameras=CAMERAS, **QUIET)
    return read_result(outcome.result_path)


def _same(a, b):
    np.testing.assert_array_equal(a.frames, b.frames)
    np.testing.assert_allclose(a.state, b.state, atol=1e-9)
    np.testing.assert_allclose(a.landmarks, b.landmarks, atol=1e-9)


def test_lossless_pose2sim_project_tracks_as_the_humaneva_layout(walk_no_answer, humaneva_run,
                                                                 tmp_path):
    seq = Dataset(walk_no_answer).sequence("S1", "Walking_1")
    root, _ = make_project(seq, tmp_path / "Demo", "pose2sim", CAMERAS, video="png")
    outcome = track_sequence(root, None, None, tmp_path / "run", **QUIET)
    assert outcome.result_path == tmp_path / "run" / "Demo" / "Demo.h5"
    result = read_result(outcome.result_path)
    _same(result, humaneva_run)
    assert result.attrs["cameras"] == "cam01,cam02,cam03"


@pytest.mark.parametrize("layout", ["anipose", "easymocap"])
def test_mp4_project_tracks_as_its_import(walk_no_answer, humaneva_run, tmp_path, layout):
    seq = Dataset(walk_no_answer).sequence("S1", "Walking_1")
    root, names = make_project(seq, tmp_path / "proj", layout, CAMERAS, video="mp4")
    # the command line, as a user runs it
    assert main(["track", str(root), "--out", str(tmp_path / "run"), "--frames", "1:3",
                 "--layers", "2", "--particles", "60", "--seed", "1", "--no-progress"]) == 0
    trial = "walk" if layout == "anipose" else "proj"
    result = read_result(tmp_path / "run" / trial / f"{trial}.h5")
    imported = import_sequence(Project(root).sequence(), tmp_path / "he", progress=False,
                               log=lambda *_: None)
    assert imported.cameras == {n: n for n in names.values()}
    again = track_sequence(tmp_path / "he", imported.subject, imported.sequence,
                           tmp_path / "run_he", **QUIET)
    _same(result, read_result(again.result_path))
    # against the original (lossless) frames: mp4 moves silhouette edges by a pixel here and
    # there; the carved volume stays the same person (the particle filter at 60 particles is too
    # chaotic to compare its estimates across different pixels)
    original = Dataset(walk_no_answer).sequence("S1", "Walking_1", cameras=CAMERAS)
    project = Project(root).sequence()
    a = MeasurementRunner(original, SMALL, log=None)
    b = MeasurementRunner(project, SMALL, log=None)
    for frame in (1, 8):
        va = np.asarray(a.measure(original.read_frame(frame)).occupancy, dtype=bool)
        vb = np.asarray(b.measure(project.read_frame(frame)).occupancy, dtype=bool)
        assert (va & vb).sum() / (va | vb).sum() > 0.85
