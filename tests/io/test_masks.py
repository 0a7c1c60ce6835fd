"""Person masks given with a recording (``track --masks``) replace the background subtraction.

The reference is the subtraction itself: the masks a project's background videos give, written as
mask folders, must carve and track exactly as the subtraction does (same grid, same carving rule),
and the reader must return the very pixels written (PNG) or nearly (mp4, lossy).
"""

import shutil

import cv2
import numpy as np
import pytest
from project_fixture import make_project, write_frames

from voxelmocap.cli import main
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.errors import InputError
from voxelmocap.io.humaneva import Dataset
from voxelmocap.io.masks import PersonMasks
from voxelmocap.io.project import Project
from voxelmocap.io.results import read_result
from voxelmocap.measure.stage import MeasurementStage
from voxelmocap.run.measurement import MeasurementRunner
from voxelmocap.run.pipeline import track_sequence

CAMERAS = ["C1", "C2", "C3"]
# the stage a project with background videos gets, so that given masks must reproduce it
SAME_STAGE = with_overrides(TrackConfig(), **{
    "filter.layers": 2, "filter.particles": 60, "measurement.grid_placement": "rig",
    "measurement.person_only": False, "measurement.carve_holes": 0})


@pytest.fixture(scope="module")
def project(walk_dataset, tmp_path_factory):
    """A Pose2Sim project (lossless PNG frames, background videos) of the rendered walk, and the
    subtraction's masks of all its frames per camera."""
    return _project_and_masks(walk_dataset, tmp_path_factory.mktemp("p") / "Demo", CAMERAS)


def _project_and_masks(walk_dataset, root, cameras):
    """A Pose2Sim project of the walk's ``cameras`` at ``root``, its sequence, the runner with
    its background videos and the subtraction's masks of every frame per camera."""
    seq = Dataset(walk_dataset).sequence("S1", "Walking_1")
    root, _ = make_project(seq, root, "pose2sim", cameras, video="png")
    pseq = Project(root).sequence()
    runner = MeasurementRunner(pseq, SAME_STAGE)
    masks = {c: [] for c in pseq.camera_names}
    for _, images in pseq.frames():
        for c, m in zip(pseq.camera_names, runner.masks(images), strict=True):
            masks[c].append(m)
    return root, pseq, runner, masks


def _write(folder, masks, video="png", names=None):
    for cam, frames in masks.items():
        write_frames(folder / (names or {}).get(cam, cam),
                     [m.astype(np.uint8) * 255 for m in frames], 60.0, video)
    return folder


def test_png_masks_are_read_exactly_in_any_order(project, tmp_path):
    _, seq, _, masks = project
    given = PersonMasks(_write(tmp_path / "masks", masks), seq)
    for frame in (1, 2, 4, 3, 1):           # forward, a jump ahead, back
        for cam, m in zip(seq.camera_names, given.of(frame), strict=True):
            np.testing.assert_array_equal(m, masks[cam][frame - 1])
    assert [f for f, _ in given.read([2, 3])] == [2, 3]


def test_masks_of_a_sequence_measured_at_a_working_size_are_shrunk_with_it(project, tmp_path):
    from voxelmocap.io.working_size import at_most_side

    _, seq, _, masks = project
    small = at_most_side(seq, 320)
    given = PersonMasks(_write(tmp_path / "masks", masks), small)   # the videos' size: accepted
    for cam, m in zip(seq.camera_names, given.of(3), strict=True):
        share = cv2.resize(masks[cam][2].astype(np.float32), small.rig[cam].size,
                           interpolation=cv2.INTER_AREA)
        assert m.shape == (240, 320) and m.dtype == bool
        np.testing.assert_array_equal(m, share > 0.5)


def test_mp4_masks_named_like_the_videos(project, tmp_path):
    _, seq, _, masks = project
    names = {c: seq.video_path(c).name for c in seq.camera_names}   # the PNG folders' names
    given = PersonMasks(_write(tmp_path / "masks", masks, "mp4", names), seq)
    for cam, m in zip(seq.camera_names, given.of(2), strict=True):
        truth = masks[cam][1]
        assert given.paths[cam].suffix == ".mp4"
        # lossy: only pixels on the outline may flip
        assert np.count_nonzero(m != truth) <= 0.02 * max(np.count_nonzero(truth), 1)


def test_given_masks_carve_as_the_subtraction(project, tmp_path):
    _, seq, runner, masks = project
    given = PersonMasks(_write(tmp_path / "masks", masks), seq)
    with_masks = MeasurementRunner(seq, SAME_STAGE, person_masks=given)
    assert with_masks.grid.shape == runner.grid.shape
    assert with_masks.backgrounds is None and with_masks.known is None
    for frame, images in seq.frames([1, 3]):
        a, b = runner.measure(images, frame=frame), with_masks.measure(images, frame=frame)
        assert a.occupancy.any()
        np.testing.assert_array_equal(a.occupancy, b.occupancy)
        np.testing.assert_array_equal(np.asarray(a.masks), np.asarray(b.masks))
    # a stage without backgrounds cannot segment: it says so
    bare = MeasurementStage(seq.rig, runner.grid, None)
    with pytest.raises(InputError, match="no background model"):
        bare.measure(dict(next(seq.frames([1]))[1]))


def test_given_masks_place_the_grid_around_the_person(walk_dataset, tmp_path):
    # four cameras: with given masks the grid goes around the person (fewer: the rig's box)
    _, seq, runner, masks = _project_and_masks(walk_dataset, tmp_path / "Four",
                                               [*CAMERAS, "BW1"])
    given = PersonMasks(_write(tmp_path / "masks", masks), seq)
    placed = MeasurementRunner(seq, TrackConfig(), person_masks=given, log=lambda *_: None)
    assert np.prod(placed.grid.shape) < 0.5 * np.prod(runner.grid.shape)
    assert placed.holes == 1 and placed.person_only
    # the same person as carved on the rig's whole floor box from the same masks and rule
    whole = MeasurementStage(seq.rig, runner.grid, None, person_only=True, holes=1,
                             hole_reach=placed.hole_reach)
    for frame, images in seq.frames([2, 7]):
        a = placed.measure(images, frame=frame).occupancy
        b = whole.measure(images, masks=[m[frame - 1] for m in masks.values()]).occupancy
        centre = [g.centre_of(np.argwhere(o).mean(axis=0))
                  for g, o in ((placed.grid, a), (runner.grid, b))]
        assert np.linalg.norm(centre[0] - centre[1]) < runner.grid.voxel_size
        assert abs(int(a.sum()) - int(b.sum())) <= 0.05 * b.sum()


def test_track_with_the_subtraction_s_masks_tracks_as_without(project, tmp_path):
    root, _, _, masks = project
    folder = _write(tmp_path / "masks", masks)
    from voxelmocap.run.plan import masks_defaults

    # the cues and gate that masks select, given to both runs (the masks then change nothing)
    config = masks_defaults(SAME_STAGE, cues_given=False)[0]
    quiet = {"config": config, "frames": "1:3", "seed": 1, "progress": False,
             "log": lambda *_: None}
    plain = read_result(track_sequence(root, None, None, tmp_path / "a", **quiet).result_path)
    outcome = track_sequence(root, None, None, tmp_path / "b", masks=folder, **quiet)
    given = read_result(outcome.result_path)
    np.testing.assert_allclose(given.state, plain.state, atol=1e-9)
    np.testing.assert_allclose(given.landmarks, plain.landmarks, atol=1e-9)
    assert given.attrs["person_masks"] == str(folder.resolve())
    # resuming with other masks (or none) is refused, naming the result
    with pytest.raises(InputError, match="person_masks differs"):
        track_sequence(root, None, None, tmp_path / "b", resume=True, **quiet)


@pytest.mark.parametrize("damage, message", [
    ("missing", "masks folder not found"),
    ("camera", "no masks for camera cam02"),
    ("short", "2 mask frames, the camera's video needs 8"),
    ("size", "masks are 50x40, camera cam01's video is"),
])
def test_bad_masks_name_the_file(project, tmp_path, capsys, damage, message):
    root, seq, _, masks = project
    folder = tmp_path / "masks"
    if damage != "missing":
        _write(folder, masks)
    if damage == "camera":
        shutil.rmtree(folder / "cam02")
    elif damage == "short":
        for f in sorted((folder / "cam03").iterdir())[2:]:
            f.unlink()
        message = message.replace("needs 8", f"needs {seq.n_frames}")
    elif damage == "size":
        for f in (folder / "cam01").iterdir():
            cv2.imwrite(str(f), np.zeros((40, 50), np.uint8))
    with pytest.raises(InputError, match=message):
        PersonMasks(folder, seq)
    # the command line: one line naming the file, exit 2
    code = main(["track", str(root), "--out", str(tmp_path / "run"), "--masks", str(folder),
                 "--no-progress"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and message.split(",")[0] in err[0] and "Traceback" not in err[0]


def test_masks_defaults_choose_the_silhouette_cue_and_open_the_gate():
    from voxelmocap.run.plan import MASKS_CUES, MASKS_MAX_HULL, masks_defaults

    config, message = masks_defaults(TrackConfig(), cues_given=False)
    assert config.cues.weights == MASKS_CUES
    assert config.filter.limb_sweep_max_hull == MASKS_MAX_HULL
    assert "silhouette=10" in message and "limb_sweep_max_hull" in message
    # --cues given, or a config that chose the gate: left as chosen
    config, message = masks_defaults(TrackConfig(), cues_given=True)
    assert config.cues.weights == TrackConfig().cues.weights and "cues voxel" not in message
    chosen = with_overrides(TrackConfig(), **{"filter.limb_sweep_max_hull": 3.0})
    config, message = masks_defaults(chosen, cues_given=True)
    assert config == chosen and message is None


def test_track_command_with_masks_records_them_and_the_cues(project, tmp_path):
    root, _, _, masks = project
    folder = _write(tmp_path / "masks", masks)
    assert main(["track", str(root), "--out", str(tmp_path / "run"), "--masks", str(folder),
                 "--frames", "1:2", "--layers", "2", "--particles", "60", "--no-progress"]) == 0
    result = read_result(tmp_path / "run" / "Demo" / "Demo.h5")
    assert result.attrs["person_masks"] == str(folder.resolve())
    assert "silhouette = 10" in result.attrs["config"]
    assert "note: given person masks: cues voxel=1,silhouette=10" in (
        tmp_path / "run" / "voxelmocap.log").read_text()


def test_masks_follow_each_camera_s_video_frames_on_the_humaneva_layout(walk_dataset, tmp_path):
    # the HumanEva layout's cameras start at different video frames (.ofs): mask k goes with
    # video frame k. Mask k here has its first k rows set, so each read names its video frame.
    seq = Dataset(walk_dataset).sequence("S1", "Walking_1")
    cams = list(seq.camera_names)
    assert len({seq.starts[c] for c in cams}) > 1      # the case worth testing
    for cam in cams:
        w, h = seq.rig[cam].size
        n = seq.starts[cam] + seq.n_frames - 1
        images = [np.where(np.arange(h)[:, None] < k, 255, 0).astype(np.uint8)
                  .repeat(w, axis=1) for k in range(1, n + 1)]
        write_frames(tmp_path / "masks" / cam, images, 60.0, "png")
    given = PersonMasks(tmp_path / "masks", seq)
    for frame in (1, 3, 4, seq.n_frames, 2):           # gaps forward, then back
        for cam, m in zip(cams, given.of(frame), strict=True):
            assert m[:, 0].sum() == seq.starts[cam] + frame - 1
    with pytest.raises(InputError, match="outside"):
        given.of(seq.n_frames + 1)
    # a numbered folder with a gap is refused when opened, not in the middle of a run
    sorted((tmp_path / "masks" / cams[0]).iterdir())[3].unlink()
    with pytest.raises(InputError, match="no image file with counter 3"):  # (0-based names)
        PersonMasks(tmp_path / "masks", seq)
