"""``track --plate-from RUN``: a learnt plate whose cover is a previous run's tracked body."""

import shutil

import numpy as np
import pytest

from voxelmocap.cli import main
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.io.humaneva import Dataset
from voxelmocap.io.results import read_result
from voxelmocap.run.plan import VOXEL_SWEEP_EVERY

SMALL = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 60})


@pytest.fixture(scope="module")
def no_plate(walk_dataset, tmp_path_factory):
    """The rendered walk without ``Background/``, and a first run of it (one pass: the plate
    learnt by carving, the start from the ground truth)."""
    root = tmp_path_factory.mktemp("noplate")
    data = root / "data"
    shutil.copytree(walk_dataset, data, ignore=shutil.ignore_patterns("Background"))
    run = root / "first"
    (root / "one.toml").write_text("[measurement.silhouette]\nplate_passes = 1\n")
    assert main(["track", str(data), "--subject", "S1", "--sequence", "Walking_1", "--layers",
                 "2", "--particles", "60", "--no-progress", "--out", str(run), "--config",
                 str(root / "one.toml")]) == 0
    return data, run


def test_a_carving_run_counts_as_done_for_its_request(no_plate):
    """The one-pass carving run records its pass's config (the periodic sweep's default
    silhouette weight dropped and its period that of a sweep of the voxels alone,
    ``run.plan.carving_config``); ``--all`` counts it as done for the config it was asked to
    track with, and not for another."""
    from voxelmocap.config import config_from_toml, config_to_toml
    from voxelmocap.run.batch import result_is_done

    _, run = no_plate
    path = run / "S1" / "Walking_1.h5"
    recorded = config_from_toml(str(read_result(path).attrs["config"]))
    assert recorded.filter.limb_sweep_silhouette == 0.0
    assert recorded.filter.limb_sweep_every == VOXEL_SWEEP_EVERY
    default = TrackConfig().filter
    asked = with_overrides(recorded, **{"filter.limb_sweep_silhouette": default.limb_sweep_silhouette,
                                        "filter.limb_sweep_every": default.limb_sweep_every})
    assert result_is_done(path, config_to_toml(asked), 0)
    other = with_overrides(asked, **{"filter.limb_sweep_gain": 3.0})
    assert not result_is_done(path, config_to_toml(other), 0)


def test_the_plate_from_the_true_body_is_the_empty_scene(walk_dataset, no_plate):
    """The body fitted to the ground truth as the cover: the plate is the renderer's empty scene
    (its background videos, removed from the tracked copy) wherever the walk uncovered it."""
    from voxelmocap.body.fit import fit_to_landmarks
    from voxelmocap.pose.body_cover import TrackedBody
    from voxelmocap.pose.starts import ground_truth_landmarks
    from voxelmocap.run.bodies import body_model_for
    from voxelmocap.run.measurement import MeasurementRunner

    data, _ = no_plate
    seq = Dataset(data).sequence("S1", "Walking_1")
    gt = seq.ground_truth()
    model, _ = body_model_for(seq, gt)
    frames = np.asarray(seq.frame_numbers)
    states = np.stack([fit_to_landmarks(model, ground_truth_landmarks(gt, int(f)))
                       for f in frames])
    said = []
    runner = MeasurementRunner(seq, SMALL, log=said.append,
                               plate_body=TrackedBody(model, frames, states, "the truth"))
    assert any("the person where the body of the truth was" in s for s in said)
    carved = MeasurementRunner(seq, SMALL)          # the plate learnt by carving, for scale
    empty = Dataset(walk_dataset).sequence("S1", "Walking_1")
    for cam in seq.camera_names:
        truth = np.median(np.stack(empty.background_sets(cam)[0]), axis=0)
        truth = truth[..., None] if truth.ndim == 2 else truth         # BW1 is grey

        def wrong(plate, truth=truth):
            return ((np.abs(plate.plate - truth).max(axis=2) > 20) & plate.known).mean()

        plate = runner.backgrounds[cam]
        assert plate.known.mean() > 0.9, (cam, plate.known.mean())  # 8 walk frames uncover most
        # 0.2–0.35 % wrong (the cast shadow is not covered) against 0.8–1.5 % by carving
        assert wrong(plate) < 0.005 and wrong(plate) < 0.5 * wrong(carved.backgrounds[cam]), cam


def test_pixels_the_body_left_free_too_rarely_are_unknown(no_plate):
    """``plate_body_min_seen``: a pixel the body's cover left free in fewer than that share of
    the sampled frames (counted here from the covers themselves) is unknown; the others keep
    what the plate's other rules (samples that spread: unknown) said without the share."""
    import cv2

    from voxelmocap.pose.body_cover import TrackedBody, plate_covers_of
    from voxelmocap.run.bodies import tracked_body
    from voxelmocap.run.measurement import MeasurementRunner

    data, run = no_plate
    seq = Dataset(data).sequence("S1", "Walking_1")
    body = tracked_body(run, seq)
    known = {}
    for share in (0.0, 0.5):
        config = with_overrides(SMALL, **{"measurement.silhouette.plate_body_min_seen": share})
        runner = MeasurementRunner(seq, config, plate_body=TrackedBody(
            body.model, body.frames, body.states, "the run"))
        covers = plate_covers_of(seq.rig, body.model, body.states,
                                 config.measurement.silhouette.plate_body_margin)
        need = max(1, round(share * len(body.frames)))
        for cam in seq.rig:
            plate = runner.backgrounds[cam.name]
            h, w = plate.known.shape
            free = sum(~cv2.resize(c.astype(np.uint8), (w, h),
                                   interpolation=cv2.INTER_NEAREST).astype(bool)
                       for c in covers[cam.name])
            assert not (plate.known & (free < need)).any(), (share, cam.name)
            known[share, cam.name] = (plate.known, free >= need)
    for cam in seq.camera_names:
        (without, _), (with_share, enough) = known[0.0, cam], known[0.5, cam]
        assert (with_share != (without & enough)).mean() < 0.01, cam   # the noise floor moves
        assert (without & ~enough).mean() > 0.005, cam                 # the share mattered


def test_tracked_body_reads_the_run_of_this_sequence(no_plate):
    from voxelmocap.run.bodies import tracked_body

    data, run = no_plate
    seq = Dataset(data).sequence("S1", "Walking_1")
    body = tracked_body(run, seq)
    path = run / "S1" / "Walking_1.h5"
    assert body.source == str(path.resolve())
    result = read_result(path)
    assert np.array_equal(body.frames, result.frames)
    assert np.allclose(body.states, result.state)
    assert tracked_body(path, seq).source == body.source      # the file itself


def test_track_with_plate_from_records_it_and_resume_checks_it(no_plate, tmp_path, capsys):
    data, run = no_plate
    out = tmp_path / "second"
    # a carving pass drops the sweep's default silhouette weight and period
    # (run.plan.carving_config): values chosen in the config stand in both, so the two runs
    # below differ in the plate only
    toml = tmp_path / "sweep.toml"
    toml.write_text("[filter]\nlimb_sweep_silhouette = 5.0\nlimb_sweep_every = 7\n")
    args = ["track", str(data), "--subject", "S1", "--sequence", "Walking_1", "--layers", "2",
            "--particles", "60", "--frames", "1:3", "--no-progress", "--out", str(out),
            "--config", str(toml)]
    assert main(args + ["--plate-from", str(run)]) == 0
    result = read_result(out / "S1" / "Walking_1.h5")
    assert result.attrs["plate_from"] == str((run / "S1" / "Walking_1.h5").resolve())
    assert len(result) == 3
    # the silhouette cue joins the voxel cue, the gate stays, and the log says so
    assert "silhouette = 10.0" in result.attrs["config"]
    assert "limb_sweep_max_hull = 2.0" in result.attrs["config"]
    assert "note: a plate from a tracked body: cues voxel=1,silhouette=10" in capsys.readouterr().out
    # the same result tracked again (same cues) with the plate learnt by carving is another run
    assert main(args + ["--cues", "voxel,silhouette=10", "--resume"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot resume: its plate_from differs" in err[0], err


def test_tracked_body_refuses_another_sequence_and_too_few_frames(no_plate, tmp_path):
    import h5py

    from voxelmocap.errors import InputError
    from voxelmocap.run.bodies import tracked_body

    data, run = no_plate
    seq = Dataset(data).sequence("S1", "Walking_1")
    other = tmp_path / "other.h5"
    shutil.copy(run / "S1" / "Walking_1.h5", other)
    with h5py.File(other, "r+") as f:
        f.attrs["action"] = "Jog"
    with pytest.raises(InputError, match="a result of action 'Jog'"):
        tracked_body(other, seq)
    few = tmp_path / "few.h5"
    shutil.copy(run / "S1" / "Walking_1.h5", few)
    with h5py.File(few, "r+") as f:
        f["observed"][1:] = 0
    with pytest.raises(InputError, match=r"1 frame.* with the person tracked"):
        tracked_body(few, seq)


def test_tracked_body_measured_on_the_ground_truth_is_that_body(no_plate, tmp_path):
    """Without a body file the first run measured its body on the ground truth (and recorded no
    dimensions): the cover is drawn with that body, not the average adult."""
    from voxelmocap.run.bodies import body_model_for, tracked_body

    data, run = no_plate
    bare = tmp_path / "bare"
    shutil.copytree(data, bare, ignore=shutil.ignore_patterns("*_body.toml"))
    seq = Dataset(bare).sequence("S1", "Walking_1")
    gt = seq.ground_truth()
    model, source = body_model_for(seq, gt)
    assert "ground truth" in source
    body = tracked_body(run, seq, gt)
    assert body.model.dimensions == model.dimensions
    assert body.model.dimensions != body_model_for(seq, None)[0].dimensions


@pytest.mark.parametrize(("case", "message"), [
    ("missing", "no result of S1/Walking_1 here"),
    ("with_backgrounds", "--plate-from: no plate is learnt for this sequence"),
    ("all", "--plate-from: not with --all"),
    ("masks", "--plate-from: not with --masks"),
])
def test_plate_from_bad_input_is_one_line(walk_dataset, no_plate, tmp_path, capsys, case,
                                          message):
    data, run = no_plate
    source = walk_dataset if case == "with_backgrounds" else data
    args = ["track", str(source), "--frames", "1:1", "--no-progress", "--out",
            str(tmp_path / "run"), "--plate-from", str(tmp_path if case == "missing" else run)]
    if case == "all":
        args += ["--all"]
    else:
        args += ["--subject", "S1", "--sequence", "Walking_1"]
    if case == "masks":
        masks = tmp_path / "masks"
        masks.mkdir()
        args += ["--masks", str(masks)]
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert "Traceback" not in "\n".join(err)
    assert not (tmp_path / "run" / "S1" / "Walking_1.h5").exists()


@pytest.fixture(scope="module")
def long_walk(tmp_path_factory):
    """A 12-frame walk at 6 Hz (2 s: the person uncovers the floor) without ``Background/``,
    and its run (three passes, the default)."""
    from voxelmocap.synth import generate

    root = tmp_path_factory.mktemp("long")
    data = generate(root / "data", motion="walk", frames=12, fps=6,
                    cameras=["C1", "C2", "C3", "BW1"], progress=False, background_frames=2,
                    seed=5)
    shutil.rmtree(data / "Background")
    assert main(_args(data, "--out", str(root / "run"))) == 0
    return data, root / "run"


def _args(data, *extra):
    return ["track", str(data), "--subject", "S1", "--sequence", "Walking_1", "--layers", "2",
            "--particles", "60", "--frames", "1:10", "--no-progress", *extra]


def test_the_passes_are_a_run_and_a_plate_from_run(long_walk, tmp_path):
    """Without background videos ``track`` runs a first pass (plate learnt by carving) and a
    second whose plate comes from the first pass's body: what ``track`` and ``track
    --plate-from`` typed by hand give (same seed), the same states. The third learns its plate
    from the second's body."""
    data, run = long_walk
    one = tmp_path / "one.toml"
    one.write_text("[measurement.silhouette]\nplate_passes = 1\n")
    assert main(_args(data, "--out", str(tmp_path / "a"), "--config", str(one))) == 0
    assert not (tmp_path / "a" / "S1" / "pass1").exists()
    assert read_result(tmp_path / "a" / "S1" / "Walking_1.h5").attrs["plate_from"] == ""
    assert main(_args(data, "--out", str(tmp_path / "b"), "--config", str(one),
                      "--plate-from", str(tmp_path / "a"))) == 0
    by_hand = read_result(tmp_path / "b" / "S1" / "Walking_1.h5")
    passes = read_result(run / "S1" / "Walking_1.h5")
    second = read_result(run / "S1" / "pass2" / "Walking_1.h5")
    first = read_result(run / "S1" / "pass1" / "Walking_1.h5")
    assert np.array_equal(first.state, read_result(tmp_path / "a" / "S1" /
                                                   "Walking_1.h5").state)
    assert np.array_equal(second.state, by_hand.state)
    assert passes.observed.all() and len(passes) == 10           # the person in every frame
    assert second.attrs["plate_from"] == str((run / "S1" / "pass1" / "Walking_1.h5").resolve())
    assert passes.attrs["plate_from"] == str((run / "S1" / "pass2" / "Walking_1.h5").resolve())
    assert "silhouette = 10.0" in passes.attrs["config"]
    assert "silhouette = 10.0" in second.attrs["config"]
    assert first.attrs["plate_from"] == "" and "silhouette = 10.0" not in first.attrs["config"]
    # with ground truth every pass starts from it (exact), the third too
    assert all(r.attrs["init_method"].startswith("the ground truth of frame 1")
               for r in (first, second, passes))
    # --all counts the result of several passes as done (it records the final pass's config)
    from voxelmocap.config import config_to_toml
    from voxelmocap.run.batch import result_is_done

    config = config_to_toml(SMALL)
    path = run / "S1" / "Walking_1.h5"
    assert result_is_done(path, config, 0)
    assert not result_is_done(path, config, 1)
    assert not result_is_done(path, config, 0, cues_given=True)     # voxel alone was chosen


def test_passes_resume_and_refuse_like_one_run(long_walk, tmp_path, capsys):
    """``--resume`` re-reads finished passes (nothing tracked again) and resumes the one that
    was interrupted; an existing final result is refused before any pass runs."""
    import os

    data, _ = long_walk
    out = tmp_path / "run"        # its own run: a result records its previous pass's path
    args = _args(data, "--out", str(out))
    assert main(args) == 0
    first = out / "S1" / "pass1" / "Walking_1.h5"
    second = out / "S1" / "pass2" / "Walking_1.h5"
    final = out / "S1" / "Walking_1.h5"
    stamps = [os.stat(p).st_mtime_ns for p in (first, second, final)]
    states = read_result(final).state
    capsys.readouterr()
    assert main(args + ["--resume"]) == 0                        # all complete: read only
    assert capsys.readouterr().out.count("already complete") == 3
    assert [os.stat(p).st_mtime_ns for p in (first, second, final)] == stamps
    final.unlink()                               # the final pass interrupted before a frame
    assert main(args + ["--resume"]) == 0
    assert [os.stat(p).st_mtime_ns for p in (first, second)] == stamps[:2]
    assert np.array_equal(read_result(final).state, states)
    first.unlink()
    capsys.readouterr()
    assert main(args) == 2                       # exists: refused before the first pass
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "result exists" in err[0] and str(final) in err[0], err
    assert not first.exists()


def test_a_final_result_another_run_writes_is_refused_before_the_passes(long_walk, tmp_path,
                                                                         capsys):
    """With ``--overwrite`` too: a final result held by a running writer (its exclusive flock,
    here taken by this test) is refused at once, pass 1 left as it was."""
    import fcntl
    import os

    data, run = long_walk
    out = tmp_path / "run"
    shutil.copytree(run, out)
    first, final = out / "S1" / "pass1" / "Walking_1.h5", out / "S1" / "Walking_1.h5"
    stamp = os.stat(first).st_mtime_ns
    fd = os.open(final, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        capsys.readouterr()
        assert main(_args(data, "--out", str(out), "--overwrite")) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "another track run is writing" in err[0], err
        assert str(final) in err[0]
    finally:
        os.close(fd)
    assert os.stat(first).st_mtime_ns == stamp


@pytest.fixture(scope="module")
def no_answer_run(long_walk, link_without_answer, tmp_path_factory):
    """``long_walk``'s data without ``Mocap_Data`` (no ground truth, no body file: a user's
    case), its run at the defaults (three passes), and ``(phrase, mean)`` of every
    ``BodyTracker.start`` of that run (the mean its first particles were drawn around)."""
    from voxelmocap.pose.tracker import BodyTracker

    root = tmp_path_factory.mktemp("noanswer")
    data = link_without_answer(long_walk[0], root / "data")
    means = []
    start = BodyTracker.start

    def spy(self, phrase, mean):
        means.append((phrase, np.array(mean, float)))
        return start(self, phrase, mean)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(BodyTracker, "start", spy)
        assert main(_args(data, "--out", str(root / "run"))) == 0
    return data, root / "run", means


def test_the_third_pass_starts_where_the_second_did(no_answer_run):
    """Pass 3 tracks with the body pass 2 fitted and draws its first particles around pass 2's
    pose at the first frame, its arms searched again (no search from the voxels); passes 1 and 2
    find their own starts from the voxels and fit their own bodies."""
    import json

    _, out, means = no_answer_run
    second_path = (out / "S1" / "pass2" / "Walking_1.h5").resolve()
    second = read_result(second_path)
    final = read_result(out / "S1" / "Walking_1.h5")
    continued = [(p, m) for p, m in means if p.startswith("the pose of")]
    assert len(continued) == 1                   # pass 3's start (re-starts may follow)
    phrase, mean = continued[0]
    assert phrase.startswith(f"the pose of {second_path} at frame 1; arms searched over their "
                             "ranges (")
    assert final.attrs["init_method"] == phrase
    # pass 2's pose, the arms searched again on this pass's first frame (CONTINUED_SEARCH)
    from voxelmocap.pose.limb_search import LIMBS

    arms = np.r_[LIMBS["l_arm"][0], LIMBS["r_arm"][0]]
    rest = np.setdiff1d(np.arange(len(mean)), arms)
    np.testing.assert_array_equal(mean[rest], second.state[0][rest])
    # pass 2 fitted its body on its own start (no body file): pass 3 tracked with that body
    assert "lengths fitted" in second.attrs["body_model"]
    assert final.attrs["body_model"] == f"the body of {second_path}"
    assert json.loads(final.attrs["body_dimensions"]) == json.loads(
        second.attrs["body_dimensions"])
    first = read_result(out / "S1" / "pass1" / "Walking_1.h5")
    for r in (first, second):
        assert "the voxels of frame" in r.attrs["init_method"]


def test_a_searched_start_also_tries_the_previous_pass_pose(no_answer_run):
    """Pass 2 searches its start from the voxels and tracks pass 1's pose at the first frame as
    one more start, its four limbs searched again (``[init] previous_pass_hypothesis``): the
    trunk exactly pass 1's; pass 1, which has no pass before it, has no such start."""
    from voxelmocap.pose.limb_search import LIMBS

    _, out, means = no_answer_run
    first_path = (out / "S1" / "pass1" / "Walking_1.h5").resolve()
    first = read_result(first_path)
    second = read_result(out / "S1" / "pass2" / "Walking_1.h5")
    assert f"and the pose of {first_path} at frame 1" in second.attrs["init_method"]
    assert "the pose of" not in first.attrs["init_method"]
    limbs = np.concatenate([LIMBS[name][0] for name in ("l_arm", "r_arm", "l_leg", "r_leg")])
    trunk = np.setdiff1d(np.arange(first.state.shape[1]), limbs)
    starts = [m for p, m in means if p == "multi-start"]
    same = [m for m in starts if np.array_equal(m[trunk], first.state[0][trunk])]
    assert len(same) == 1, len(same)
    # the start's own: pass 1's first frame is drawn from the multi-start it kept, not equal
    # to any of its starts
    assert not any(np.array_equal(m, first.state[0]) for m in starts)


def test_a_continued_pass_resumes_where_it_was_interrupted(no_answer_run, tmp_path,
                                                          interrupt_at_third_frame, capsys):
    """The third pass interrupted after two frames and resumed (``--resume``): passes 1 and 2
    are read, not tracked again, and the final states equal the uninterrupted run's."""
    data, out, _ = no_answer_run
    final = out / "S1" / "Walking_1.h5"
    kept = tmp_path / "final.h5"
    shutil.copy2(final, kept)                    # the module's run is restored at the end
    try:
        final.unlink()
        # what _args sets: the same config, so that the command line resumes this run
        small = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 60})
        interrupt_at_third_frame(data, out, config=small, frames="1:10", progress=False,
                                 resume=True)
        assert len(read_result(final)) == 2      # two frames written before the interruption
        capsys.readouterr()
        assert main(_args(data, "--out", str(out), "--resume")) == 0
        assert capsys.readouterr().out.count("already complete") == 2     # passes 1 and 2
        resumed, whole = read_result(final), read_result(kept)
        np.testing.assert_array_equal(resumed.state, whole.state)
        assert resumed.attrs["init_method"] == whole.attrs["init_method"]
        assert resumed.attrs["body_dimensions"] == whole.attrs["body_dimensions"]
    finally:
        shutil.copy2(kept, final)


def test_a_last_pass_after_a_failed_one_repeats_it(no_answer_run, tmp_path, monkeypatch):
    """Pass 2 saw the person too rarely: the last pass tracks as pass 2 did (plate from pass
    1's body, start searched from the voxels), not continuing pass 1."""
    data, _, _ = no_answer_run
    out = tmp_path / "run"
    _saw_too_few(monkeypatch, lambda run: run.folder == "pass2")
    assert main(_args(data, "--out", str(out))) == 0
    second = read_result(out / "S1" / "pass2" / "Walking_1.h5")
    final = read_result(out / "S1" / "Walking_1.h5")
    assert final.attrs["plate_from"] == str((out / "S1" / "pass1" / "Walking_1.h5").resolve())
    assert final.attrs["init_method"] == second.attrs["init_method"]
    assert "the voxels of frame" in final.attrs["init_method"]
    np.testing.assert_array_equal(final.state, second.state)


def test_each_pass_starts_by_returning_freed_memory(long_walk, tmp_path, monkeypatch):
    """The run hands the allocator's free memory back before each pass (also one read back on
    ``--resume``), so that the pass before's and this pass's plate learning do not add up:
    three passes, three calls."""
    from voxelmocap.run import memory

    data, run = long_walk
    out = tmp_path / "run"
    shutil.copytree(run, out)
    shutil.rmtree(out / "S1" / "pass2")          # pass 1 read back, passes 2 and 3 tracked
    (out / "S1" / "Walking_1.h5").unlink()
    calls = []
    monkeypatch.setattr(memory, "release_freed_memory", lambda: calls.append(1) or True)
    assert main(_args(data, "--out", str(out), "--resume")) == 0
    assert len(calls) == 3


def test_a_pass_that_lost_the_person_ends_the_passes(long_walk, tmp_path, capsys, monkeypatch):
    """Pass 2's plate, learnt around pass 1's body, finds the person in fewer frames than pass
    1's did (under LOST_SHARE of them, counts faked as in ``_saw_too_few``): the last pass
    repeats pass 1 (its plate by carving, no plate from a body), and says why."""
    from voxelmocap.run import frame_loop
    from voxelmocap.run.plan import LOST_SHARE, MIN_BODY_FRAMES

    data, run = long_walk
    out = tmp_path / "run"
    shutil.copytree(run, out)
    # pass 1 kept (read again); pass 2 records where pass 1 was, so it is tracked again
    shutil.rmtree(out / "S1" / "pass2")
    (out / "S1" / "Walking_1.h5").unlink()
    counts = {"pass1": 2 * MIN_BODY_FRAMES, "pass2": MIN_BODY_FRAMES}
    assert counts["pass2"] < LOST_SHARE * counts["pass1"]
    real = frame_loop.PassRun.run

    def run_(self, *args, **kwargs):
        outcome = real(self, *args, **kwargs)
        outcome.frames_with_person = counts.get(self.folder, outcome.frames_with_person)
        return outcome

    monkeypatch.setattr(frame_loop.PassRun, "run", run_)
    assert main(_args(data, "--out", str(out), "--resume")) == 0
    assert "pass 2 saw the person in 10 frame(s), pass 1 in 20" in capsys.readouterr().out
    first = read_result(out / "S1" / "pass1" / "Walking_1.h5")
    final = read_result(out / "S1" / "Walking_1.h5")
    assert final.attrs["plate_from"] == "" and final.attrs["config"] == first.attrs["config"]
    np.testing.assert_array_equal(final.state, first.state)


def _saw_too_few(monkeypatch, which):
    """Make the passes ``which(run)`` selects report 3 frames with the person (as if the person
    had been out of view): the run's rule for a pass that gives no body then applies."""
    from voxelmocap.run import frame_loop

    real = frame_loop.PassRun.run

    def run(self, *args, **kwargs):
        outcome = real(self, *args, **kwargs)
        if which(self):
            outcome.frames_with_person = 3
        return outcome

    monkeypatch.setattr(frame_loop.PassRun, "run", run)


def test_a_pass_that_saw_the_person_too_rarely_is_repeated(long_walk, tmp_path, capsys,
                                                          monkeypatch):
    """A first pass with the person in fewer than MIN_BODY_FRAMES frames gives no plate from
    its body: the last pass tracks as the first did, and says why."""
    data, run = long_walk
    out = tmp_path / "run"
    shutil.copytree(run, out)
    (out / "S1" / "Walking_1.h5").unlink()       # pass 1 kept (read again), the last re-run
    _saw_too_few(monkeypatch, lambda run: True)
    assert main(_args(data, "--out", str(out), "--resume")) == 0
    assert "saw the person in 3 frame(s)" in capsys.readouterr().out
    final = read_result(out / "S1" / "Walking_1.h5")
    first = read_result(out / "S1" / "pass1" / "Walking_1.h5")
    assert final.attrs["plate_from"] == "" and final.attrs["config"] == first.attrs["config"]
    assert np.array_equal(final.state, first.state)


def test_short_runs_take_one_pass(no_plate, tmp_path):
    """Fewer frames than MIN_BODY_FRAMES: one pass, the plate by carving."""
    data, _ = no_plate
    out = tmp_path / "run"
    assert main(["track", str(data), "--subject", "S1", "--sequence", "Walking_1", "--layers",
                 "2", "--particles", "60", "--frames", "1:4", "--no-progress", "--out",
                 str(out)]) == 0
    assert not (out / "S1" / "pass1").exists()
    assert read_result(out / "S1" / "Walking_1.h5").attrs["plate_from"] == ""


def test_dump_measures_with_the_plate_from_a_run(no_plate, tmp_path):
    """``dump --plate-from``: the silhouettes a final pass measured (the plate from the body),
    the run recorded in the dump; a pass folder holding the result directly is accepted."""
    from voxelmocap.io.voxels import VoxelDump
    from voxelmocap.pose.body_cover import TrackedBody
    from voxelmocap.run.bodies import tracked_body
    from voxelmocap.run.measurement import MeasurementRunner

    data, run = no_plate
    folder = tmp_path / "pass1"
    folder.mkdir()
    shutil.copy(run / "S1" / "Walking_1.h5", folder / "Walking_1.h5")
    out = tmp_path / "vox.h5"
    assert main(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--frames",
                 "2:3", "--masks", "--no-progress", "--out", str(out), "--plate-from",
                 str(folder)]) == 0
    seq = Dataset(data).sequence("S1", "Walking_1")
    body = tracked_body(folder, seq)
    assert body.source == str((folder / "Walking_1.h5").resolve())
    runner = MeasurementRunner(seq, TrackConfig(), plate_body=TrackedBody(
        body.model, body.frames, body.states, body.source))
    carved = MeasurementRunner(seq, TrackConfig())
    dump = VoxelDump(out)
    assert dump.attrs["plate_from"] == body.source
    for number, images in seq.frames([2, 3]):
        stored = dump.masks(int(number))
        mine = runner.measure(images, frame=number).masks
        theirs = carved.measure(images, frame=number).masks
        assert all(np.array_equal(a, b) for a, b in zip(stored, mine, strict=True))
        assert not all(np.array_equal(a, b) for a, b in zip(stored, theirs, strict=True))
