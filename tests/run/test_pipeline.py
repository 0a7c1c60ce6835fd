"""End-to-end tracking on a rendered sequence, resume, and the track command's bad input."""

import numpy as np
import pytest

from voxelmocap.cli import main
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.errors import InputError
from voxelmocap.io.reports import evaluate_files
from voxelmocap.io.results import read_result
from voxelmocap.run.pipeline import track_sequence

SMALL = with_overrides(TrackConfig(), **{"filter.layers": 3, "filter.particles": 150})


def test_tracks_a_rendered_walk_within_stated_error(walk_dataset, tmp_path):
    outcome = track_sequence(walk_dataset, "S1", "Walking_1", tmp_path / "run", config=SMALL,
                             seed=1, progress=False, log=lambda *_: None)
    assert outcome.init_method.startswith("the ground truth of frame 1")
    result = read_result(outcome.result_path)
    assert result.attrs["complete"]
    np.testing.assert_array_equal(result.frames, np.arange(1, 9))
    assert result.state.shape == (8, 27) and result.part_scores.shape == (8, 10, 4)
    # one ESS per annealing layer: the hierarchical search's trunk and limb layers
    from voxelmocap.pose.hierarchy import body_partitions
    assert result.ess.shape == (8, sum(p.layers for p in body_partitions(SMALL.filter)))
    (seq,) = evaluate_files(tmp_path / "run", walk_dataset)
    # The renderer's body is not the tracker's cones, and 4 cameras carve a fat visual hull:
    # the bound is loose on purpose but far below what a lost track gives (> 300 mm).
    assert seq.scores.mu_mm < 110.0
    assert seq.scores.mmta_pct > 60.0
    assert outcome.xml_path.exists() and outcome.bvh_path.exists()


@pytest.mark.parametrize("method", ["gaussian", "mog2"])
def test_resume_equals_an_uninterrupted_run(walk_dataset, tmp_path, interrupt_at_third_frame,
                                           method):
    config = with_overrides(SMALL, **{"measurement.silhouette": {"method": method}})
    if method == "mog2":  # the adaptive model must be replayed on resume
        config = with_overrides(config, **{"filter.layers": 1, "filter.particles": 40})
    full = track_sequence(walk_dataset, "S1", "Walking_1", tmp_path / "full", config=config,
                          frames="1:5", seed=7, progress=False, log=lambda *_: None)
    interrupt_at_third_frame(walk_dataset, tmp_path / "part", config=config, frames="1:5",
                             seed=7, progress=False, log=lambda *_: None)
    partial = read_result(tmp_path / "part" / "S1" / "Walking_1.h5")
    assert len(partial) == 2 and not partial.attrs["complete"]
    with pytest.raises(InputError, match="use --resume"):
        track_sequence(walk_dataset, "S1", "Walking_1", tmp_path / "part", config=config,
                       frames="1:5", seed=7, progress=False, log=lambda *_: None)
    with pytest.raises(InputError, match="its seed differs"):
        track_sequence(walk_dataset, "S1", "Walking_1", tmp_path / "part", config=config,
                       frames="1:5", seed=8, resume=True, progress=False, log=lambda *_: None)
    resumed = track_sequence(walk_dataset, "S1", "Walking_1", tmp_path / "part", config=config,
                             frames="1:5", seed=7, resume=True, progress=False,
                             log=lambda *_: None)
    assert resumed.resumed_from == 2
    a, b = read_result(full.result_path), read_result(resumed.result_path)
    np.testing.assert_array_equal(a.frames, b.frames)
    np.testing.assert_array_equal(a.state, b.state)
    np.testing.assert_array_equal(a.map_state, b.map_state)
    np.testing.assert_array_equal(a.ess, b.ess)


@pytest.fixture(scope="module")
def finished_run(walk_dataset, tmp_path_factory):
    """A finished one-frame run (1 layer × 20 particles), for the resume-mismatch case."""
    run = tmp_path_factory.mktemp("finished")
    assert main(["track", str(walk_dataset), "--subject", "S1", "--sequence", "Walking_1",
                 "--frames", "1:1", "--layers", "1", "--particles", "20", "--no-progress",
                 "--out", str(run)]) == 0
    return run


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--sequence", "Jog_1"], "unknown sequence"),
        (["--cameras", "C1,C9"], "unknown camera 'C9' (S1/Walking_1 has C1"),
        (["--frames", "5:99"], "outside the available frames"),
        (["--config", "{bad}"], "unknown key 'filter.particle'"),
        (["--config", "{missing}"], "missing.toml: file not found"),
        (["--config", "{risk}"], "unknown camera 'C9'"),
        (["--resume", "--config", "{cfg}", "--out", "{finished}"],
         "cannot resume: its config differs"),
    ],
)
def test_track_bad_input_is_one_line(walk_dataset, finished_run, tmp_path, capsys, extra,
                                     message):
    bad = tmp_path / "bad.toml"
    bad.write_text("[filter]\nparticle = 3\n")
    cfg = tmp_path / "cfg.toml"
    cfg.write_text("[filter]\nparticles = 30\nlayers = 1\n")
    capsys.readouterr()
    args = ["track", str(walk_dataset), "--subject", "S1", "--sequence", "Walking_1",
            "--frames", "1:1", "--no-progress", "--out", str(tmp_path / "run")]
    risk = tmp_path / "risk.toml"
    risk.write_text("[measurement.silhouette]\ncamera_risk = { C9 = 10.0 }\n")
    subs = {"{risk}": str(risk), "{bad}": str(bad), "{cfg}": str(cfg), "{finished}": str(finished_run),
            "{missing}": str(tmp_path / "missing.toml")}
    extra = [subs.get(e, e) for e in extra]
    # later options win in argparse, so a case's own --out replaces the one above
    assert main(args + extra) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "run" / "S1" / "Walking_1.h5").exists()  # nothing half-written


# 8 frames of a slow walk are too few for MOG2 to separate the person from the room (on a 60-frame
# walk the fallback tracks at μ ≈ 160 mm); this checks the mechanism, not the masks.
@pytest.mark.filterwarnings("ignore::voxelmocap.measure.carving.EmptySilhouetteWarning")
def test_without_background_videos_learns_the_plate_or_uses_mog2(walk_dataset, tmp_path):
    import shutil

    data = tmp_path / "data"
    shutil.copytree(walk_dataset, data, ignore=shutil.ignore_patterns("Background"))
    messages = []
    outcome = track_sequence(data, "S1", "Walking_1", tmp_path / "run", frames="1:2",
                             config=with_overrides(SMALL, **{"filter.layers": 1,
                                                             "filter.particles": 20}),
                             progress=False, log=messages.append)
    assert any("background plate learnt from" in m for m in messages)
    assert len(read_result(outcome.result_path)) == 2
    # MOG2 learnt from the sequence, when asked for
    messages = []
    track_sequence(data, "S1", "Walking_1", tmp_path / "run2", frames="1:2",
                   config=with_overrides(SMALL, **{"filter.layers": 1, "filter.particles": 20,
                                                   "measurement.silhouette.method": "mog2"}),
                   progress=False, log=messages.append)
    assert any("using MOG2" in m for m in messages)


def test_frame_rate_comes_from_the_data(tmp_path, monkeypatch):
    """A 30 fps sequence: the BVH plays at 30 fps, the result file says 30 (not 60) and the
    tracker's noise is scaled to 30 Hz."""
    from voxelmocap.io.bvh import read_bvh
    from voxelmocap.run import frame_loop
    from voxelmocap.synth import generate

    rates = []

    class Recording(frame_loop.BodyTracker):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            rates.append(self.frame_rate)

    monkeypatch.setattr(frame_loop, "BodyTracker", Recording)
    data = generate(tmp_path / "data", motion="walk", frames=2, cameras=["C1", "C2", "BW1"],
                    fps=30.0, progress=False, background_frames=10, seed=1)
    outcome = track_sequence(data, "S1", "Walking_1", tmp_path / "run",
                             config=with_overrides(SMALL, **{"filter.layers": 1,
                                                             "filter.particles": 20}),
                             progress=False, log=lambda *_: None)
    assert "Frame Time: 0.03333333" in outcome.bvh_path.read_text()
    assert read_bvh(outcome.bvh_path).fps == pytest.approx(30.0)
    assert read_result(outcome.result_path).attrs["frame_rate"] == 30.0
    assert rates and set(rates) == {30.0}
    # an explicit rate wins; an impossible one is refused before anything is written
    again = track_sequence(data, "S1", "Walking_1", tmp_path / "run25", frames="1:1", fps=25.0,
                           config=with_overrides(SMALL, **{"filter.layers": 1,
                                                           "filter.particles": 20}),
                           progress=False, log=lambda *_: None)
    assert read_bvh(again.bvh_path).fps == pytest.approx(25.0)
    with pytest.raises(InputError, match="frame rate"):
        track_sequence(data, "S1", "Walking_1", tmp_path / "run0", fps=0.0, progress=False,
                       log=lambda *_: None)
    assert not (tmp_path / "run0").exists()


def test_a_working_size_measures_shrunk_images_through_the_whole_run(walk_dataset, tmp_path):
    """``[measurement] max_image_side``: the run says which cameras it shrinks and tracks on
    them; the same frames measured as filmed carve nearly the same person (the dump test in
    tests/io/test_working_size.py compares the carvings)."""
    lines = []
    config = with_overrides(SMALL, **{"measurement.max_image_side": 320, "filter.layers": 1,
                                      "filter.particles": 40})
    outcome = track_sequence(walk_dataset, "S1", "Walking_1", tmp_path / "run", frames="1:2",
                             config=config, progress=False, log=lines.append)
    assert any("images measured at most 320 px a side" in line and "640x480 → 320x240" in line
               for line in lines)
    result = read_result(outcome.result_path)
    assert result.attrs["complete"] and len(result.frames) == 2


def test_frame_rate_of_image_folders_is_humaneva_i(tmp_path):
    from humaneva_fixture import make_tiny_dataset

    from voxelmocap.io.humaneva import Dataset

    root = make_tiny_dataset(tmp_path / "data", image_folder_camera="C1")
    assert Dataset(root).sequence("S1", "Walking_1", cameras=["C1"]).frame_rate == 60.0
    assert Dataset(root).sequence("S1", "Walking_1").frame_rate == 60.0  # the AVIs' metadata


def test_killed_track_runs_resume_bit_identically(walk_dataset, tmp_path):
    """`track` killed (SIGKILL) at seeded random moments: the file always reads and holds a
    prefix of the uninterrupted run's frames; --resume then finishes bit-identically, leaving
    only the outputs (result, XML, BVH, the default TRC and CSV) in the folder.

    Every run is the command in a process of its own, as a user runs it: the command pins
    NumPy's and OpenBLAS's CPU paths as it starts (``voxelmocap.cpu_paths``), which this test
    process, NumPy loaded, cannot; on a CPU whose own paths round otherwise (an AVX-512 FP16
    Xeon) a run in here is another run."""
    import os
    import signal
    import subprocess
    import sys
    import time

    args = ["--frames", "1:6", "--layers", "2", "--particles", "30", "--seed", "4",
            "--no-progress"]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))

    def track(out, *more):
        return [sys.executable, "-m", "voxelmocap.cli", "track", str(walk_dataset), "--subject",
                "S1", "--sequence", "Walking_1", "--out", str(out), *args, *more]

    assert subprocess.run(track(tmp_path / "full"), env=env, capture_output=True).returncode == 0
    full = read_result(tmp_path / "full" / "S1" / "Walking_1.h5")
    rng = np.random.default_rng(15)
    for k in range(3):
        run = tmp_path / f"killed{k}"
        path = run / "S1" / "Walking_1.h5"
        proc = subprocess.Popen(track(run), env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        wait_for = int(rng.integers(0, 6))  # committed frames to wait for, then a bit more
        while proc.poll() is None and (len(read_result(path)) if path.exists() else 0) < wait_for:
            time.sleep(0.005)
        time.sleep(rng.uniform(0.0, 0.3))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        if path.exists():  # (not when killed before its first frame)
            partial = read_result(path)
            np.testing.assert_array_equal(partial.state, full.state[:len(partial)])
        resumed_run = subprocess.run(track(run, "--resume"), env=env, capture_output=True)
        assert resumed_run.returncode == 0, resumed_run.stderr[-2000:]
        resumed = read_result(path)
        for name in ("frames", "state", "map_state", "landmarks", "log_likelihood", "ess",
                     "landmark_spread", "confidence", "observed"):
            np.testing.assert_array_equal(getattr(resumed, name), getattr(full, name))
        assert resumed.attrs["complete"]
        assert sorted(p.name for p in path.parent.iterdir()) == \
            ["Walking_1.bvh", "Walking_1.csv", "Walking_1.h5", "Walking_1.trc", "Walking_1.xml"]


def test_a_second_track_on_the_same_result_is_refused(walk_dataset, tmp_path, capsys):
    """While one run writes RUN/S1/Walking_1.h5, another (even with --overwrite) is refused."""
    import fcntl
    import os
    import signal
    import subprocess
    import sys
    import time

    run = tmp_path / "run"
    path = run / "S1" / "Walking_1.h5"
    args = ["track", str(walk_dataset), "--subject", "S1", "--sequence", "Walking_1",
            "--out", str(run), "--layers", "3", "--particles", "300", "--no-progress"]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    first = subprocess.Popen([sys.executable, "-m", "voxelmocap.cli", *args], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        # until its first frame is committed (it holds the file's lock from the file's creation)
        while not (path.exists() and len(read_result(path)) >= 1):
            assert first.poll() is None, "the first run ended before the test could race it"
            time.sleep(0.005)
        # Paused, the first run keeps the file's lock for as long as the test needs: on a fast
        # machine it would otherwise finish its 8 frames before the second run looks. It must not
        # be paused inside the folder lock (held for milliseconds around the rename).
        while True:
            first.send_signal(signal.SIGSTOP)
            folder = os.open(run / "S1", os.O_RDONLY)
            try:
                fcntl.flock(folder, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                first.send_signal(signal.SIGCONT)
                time.sleep(0.001)
            finally:
                os.close(folder)
        assert first.poll() is None, "the first run ended before the test could race it"
        capsys.readouterr()
        assert main(args + ["--overwrite"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "another track run is writing this result" in err[0], err
    finally:
        first.send_signal(signal.SIGKILL)
        first.wait()
    assert len(read_result(path)) >= 1  # the first run's frames are intact


def test_first_frame_compilation_is_announced(walk_dataset, tmp_path, monkeypatch):
    import types

    from voxelmocap.run import frame_loop, outputs
    from voxelmocap.score import _raster_kernels

    messages = []
    monkeypatch.setattr(frame_loop, "kernels_cached", lambda: False)
    track_sequence(walk_dataset, "S1", "Walking_1", tmp_path / "run", frames="1:1",
                   config=with_overrides(SMALL, **{"filter.layers": 1, "filter.particles": 20}),
                   progress=False, log=messages.append)
    compiling = [i for i, m in enumerate(messages) if m.startswith("compiling the likelihood")]
    initialised = [i for i, m in enumerate(messages) if m.startswith("initialised from")]
    assert len(compiling) == 1 and compiling[0] < initialised[0]  # once, before the first frame
    monkeypatch.undo()
    # the check itself: compiled here or cached on disk beside the module → quiet; neither →
    # announce (numba names its index <module>.<function>-<line>.<python>.nbi)
    monkeypatch.setattr(_raster_kernels, "__file__", str(tmp_path / "_raster_kernels.py"))
    import numba

    monkeypatch.setattr(numba.config, "CACHE_DIR", "")
    monkeypatch.setattr(_raster_kernels, "part_counts", types.SimpleNamespace(signatures=[]))
    assert not outputs.kernels_cached()
    index = tmp_path / "__pycache__" / "_raster_kernels.part_counts-483.py311.nbi"
    index.parent.mkdir()
    index.write_bytes(b"")
    assert outputs.kernels_cached()
    index.unlink()
    monkeypatch.setattr(_raster_kernels, "part_counts",
                        types.SimpleNamespace(signatures=["(float64[:],)"]))
    assert outputs.kernels_cached()
    monkeypatch.setattr(_raster_kernels, "part_counts", object())  # numba changed: stay quiet
    assert outputs.kernels_cached()


def test_tracks_without_ground_truth_or_body_file(walk_dataset, walk_without_answer, tmp_path,
                                                  interrupted_then_resumed):
    from voxelmocap.io.body_file import read_body_file

    config = with_overrides(SMALL, **{"init.multistart_frames": 3})
    kwargs = dict(config=config, frames="1:6", seed=2, progress=False, log=lambda *_: None)
    full = track_sequence(walk_without_answer, "S1", "Walking_1", tmp_path / "full", **kwargs)
    assert "extremities fit" in full.init_method or "standing pose" in full.init_method
    assert "the likeliest of" in full.init_method
    result = read_result(full.result_path)
    truth = read_body_file(walk_dataset / "S1" / "Mocap_Data" / "S1_body.toml").height
    # The voxels' height is the rendered person's (voxel-quantised, 20 mm; shoes, hair).
    assert abs(result.attrs["body_height_mm"] - truth) < 0.05 * truth
    assert "scaled to" in result.attrs["body_model"]
    # Accuracy without the answer is measured by scripts/bench_no_answer.py (100-frame clips,
    # 7 cameras, 6 × 600): 4 cameras, 3 × 150 particles and 3 frames of multi-start are too
    # few to tell a turned start from the right one here.
    (seq,) = evaluate_files(tmp_path / "full", walk_dataset)
    assert seq.scores.frames == 6
    # Interrupted after two frames (inside the writing of the kept start's first three frames)
    # and resumed: each frame was written with its checkpoint, the body measured is reused.
    resumed = interrupted_then_resumed(walk_without_answer, tmp_path / "part", **kwargs)
    assert resumed.resumed_from == 2
    b = read_result(resumed.result_path)
    np.testing.assert_array_equal(result.state, b.state)
    assert b.attrs["body_height_mm"] == result.attrs["body_height_mm"]


def test_multistart_in_a_run(walk_without_answer, tmp_path):
    """The starts tracked side by side (the choice itself: tests/pose/test_starts.py): the
    buffered first frames are written, then tracking goes on."""
    config = with_overrides(SMALL, **{"init.multistart_frames": 3})
    kwargs = dict(config=config, frames="1:6", seed=2, progress=False, log=lambda *_: None)
    out = track_sequence(walk_without_answer, "S1", "Walking_1", tmp_path / "run", **kwargs)
    assert "likeliest of" in out.init_method
    result = read_result(out.result_path)
    np.testing.assert_array_equal(result.frames, np.arange(1, 7))
    assert result.checkpoint is not None and result.attrs["complete"]
