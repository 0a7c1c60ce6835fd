"""The bad inputs a newcomer met (issue: "every bad input gets one clear line"), as data.

Each case prepares a tiny HumanEva-layout data set (``tests/humaneva_fixture.py``), breaks one
thing, and runs one command. ``tests/test_bad_inputs.py`` checks every case: exit code 2, one
line on stderr naming the file (or option) and the problem, no traceback, nothing new left
behind. ``scripts/bad_inputs_table.py`` runs the same cases and prints the Markdown table of
``docs/bad_inputs.md`` with the messages as they are.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Case:
    name: str  #: what is wrong, as a user would say it
    setup: Callable[[Path, Path], list[str]]  #: (data set, scratch folder) → argv
    expect: tuple[str, ...]  #: substrings of the one-line message ("{data}", "{tmp}" expanded)


def _track(data, tmp, *extra):
    return ["track", str(data), "--subject", "S1", "--sequence", "Walking_1", "--out",
            str(tmp / "run"), "--no-progress", *extra]


def _not_utf8(path: Path) -> None:
    path.write_bytes(b'[filter]\nlayers = 3\n# caf\xe9\n')


def _config_not_utf8(command):
    def setup(data, tmp):
        _not_utf8(tmp / "cfg.toml")
        if command == "track":
            return _track(data, tmp, "--config", str(tmp / "cfg.toml"))
        if command == "dump":
            return ["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--out",
                    str(tmp / "vox.h5"), "--config", str(tmp / "cfg.toml"), "--no-progress"]
        return ["sweep", str(data), "--out", str(tmp / "sweep"), "--config", str(tmp / "cfg.toml")]
    return setup


def _sizes_not_utf8(data, tmp):
    (data / "S1" / "Calibration_Data" / "sizes.toml").write_bytes(b"C1 = [640, 480] # \xff\n")
    return ["info", str(data)]


def _body_not_utf8(data, tmp):
    (data / "S1" / "Mocap_Data" / "S1_body.toml").write_bytes(b"[subject]\nname = \"\xe9\"\n")
    return _track(data, tmp)


def _missing_ofs_camera(data, tmp):
    (data / "S1" / "Sync_Data" / "Walking_1_(C2).ofs").unlink()
    return _track(data, tmp, "--cameras", "C1,C2")


def _negative_start(data, tmp):
    (data / "S1" / "Sync_Data" / "Walking_1_(C1).ofs").write_text("-5\n1\n2\n")
    return ["info", str(data)]


def _unknown_camera(data, tmp):
    return _track(data, tmp, "--cameras", "C1,C9")


def _huge_voxels(data, tmp):
    (tmp / "cfg.toml").write_text("[measurement]\nvoxel_size = 1e9\n")
    return _track(data, tmp, "--config", str(tmp / "cfg.toml"))


def _bad_recovery_share(data, tmp):
    (tmp / "cfg.toml").write_text("[recovery]\nmin_volume_share = -0.5\n")
    return _track(data, tmp, "--config", str(tmp / "cfg.toml"))


def _negative_frames(data, tmp):
    return _track(data, tmp, "--frames", "-5:3")


def _dump_out_is_folder(data, tmp):
    (tmp / "existing").mkdir()
    return ["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--out",
            str(tmp / "existing"), "--no-progress"]


def _view_out_unwritable(data, tmp):
    (tmp / "file").write_text("x")
    (tmp / "vox.h5").write_bytes(b"")  # replaced below by a real dump in the test's setup
    return ["view", str(tmp / "vox.h5"), "--frame", "1", "--out", str(tmp / "file" / "views")]


def _synth_unwritable(data, tmp):
    (tmp / "file").write_text("x")
    return ["synth", str(tmp / "file" / "data"), "--frames", "3", "--no-progress"]


def _overlay_gif(data, tmp):
    return ["overlay", str(tmp / "run"), "--dataset", str(data), "--out", str(tmp / "x.gif")]


def _overlay_fps_zero(data, tmp):
    return ["overlay", str(tmp / "run"), "--dataset", str(data), "--out", str(tmp / "x.mp4"),
            "--fps", "0"]


def _gt_huge_coordinate(data, tmp):
    from voxelmocap.io.body_pose_xml import read_body_pose_xml, write_body_pose_xml

    gt_path = data / "S1" / "Mocap_Data" / "Walking_1.xml"
    gt = read_body_pose_xml(gt_path)
    write_body_pose_xml(tmp / "run" / "S1" / "Walking_1.xml", gt.frames[:3], gt.endpoints[:3])
    text = gt_path.read_text()
    i = text.index("<X>") + 3
    gt_path.write_text(text[:i] + "1e308" + text[text.index("</X>", i):])
    return ["evaluate", str(tmp / "run"), "--dataset", str(data)]


def _evaluate_json_unwritable(data, tmp):
    from voxelmocap.io.body_pose_xml import read_body_pose_xml, write_body_pose_xml

    gt = read_body_pose_xml(data / "S1" / "Mocap_Data" / "Walking_1.xml")
    write_body_pose_xml(tmp / "run" / "S1" / "Walking_1.xml", gt.frames[:3],
                        gt.endpoints[:3] + np.array([10.0, 0.0, 0.0]))
    (tmp / "file").write_text("x")
    return ["evaluate", str(tmp / "run"), "--dataset", str(data), "--json",
            str(tmp / "file" / "r.json")]


def _rerun_not_rrd(data, tmp):
    return _track(data, tmp, "--rerun", str(tmp / "x.txt"))


def _all_zero_workers(data, tmp):
    return ["track", str(data), "--all", "--workers", "0", "--out", str(tmp / "run"),
            "--no-progress"]


def _result(tmp, observed=None) -> Path:
    """A small finished tracking result (3 frames at 60 Hz) in ``tmp/run/S1/Walking_1.h5``."""
    from voxelmocap.io.results import TrackResult, write_result

    rng = np.random.default_rng(0)
    n = 3
    path = tmp / "run" / "S1" / "Walking_1.h5"
    write_result(path, TrackResult(
        frames=np.arange(1, n + 1), state=rng.normal(size=(n, 27)),
        landmarks=rng.normal(size=(n, 15, 3)) * 500, endpoints=rng.normal(size=(n, 20, 3)),
        part_scores=rng.random((n, 10, 4)), ess=rng.random((n, 2)), betas=rng.random((n, 2)),
        seconds=rng.random(n), log_likelihood=rng.normal(size=n),
        map_state=rng.normal(size=(n, 27)), state_names=[f"s{i}" for i in range(27)],
        part_names=[f"p{i}" for i in range(10)], attrs={"frame_rate": 60.0, "complete": True},
        observed=observed))
    return path


def _reference(tmp, rate=60.0, names=("Head", "Pelvis")) -> Path:
    from voxelmocap.io.trc import write_trc

    return write_trc(tmp / "ref.trc", np.zeros((3, len(names), 3)), list(names),
                     frame_rate=rate)


def _mapping(tmp, text='[landmarks]\nhead = "Head"\n') -> Path:
    path = tmp / "map.toml"
    path.write_text(text)
    return path


def _export(*extra, result=True):
    def setup(data, tmp):
        path = _result(tmp) if result else tmp / "run" / "S1" / "Walking_1.h5"
        return ["export", str(path), *extra]
    return setup


def _export_nobody_seen(data, tmp):
    return ["export", str(_result(tmp, observed=np.zeros(3, bool))), "--opensim"]


def _export_not_hdf5(data, tmp):
    path = tmp / "run" / "S1" / "Walking_1.h5"
    path.parent.mkdir(parents=True)
    path.write_text("not HDF5")
    return ["export", str(path)]


def _evaluate_reference(make_reference=_reference, make_mapping=_mapping, mapping=True):
    def setup(data, tmp):
        argv = ["evaluate", str(_result(tmp)), "--reference", str(make_reference(tmp))]
        return argv + (["--mapping", str(make_mapping(tmp))] if mapping else [])
    return setup


def _malformed_trc(tmp) -> Path:
    path = _reference(tmp)
    lines = path.read_text().splitlines()
    lines[6] = lines[6].replace("0.000000", "abc", 1)
    path.write_text("\n".join(lines) + "\n")
    return path


def _not_a_trc(tmp) -> Path:
    path = tmp / "ref.trc"
    path.write_text("Frame#,Time\n1,0\n")
    return path

# ---------------------------------------------------------------------- projects (issue 12)


def _project(data, tmp) -> Path:
    """A Pose2Sim project from the tiny data set: calibration/Calib.toml (m), videos/<CAM>.avi."""
    import shutil

    from voxelmocap.io.calibration import read_rig, write_calibration_toml

    root = tmp / "proj"
    (root / "calibration").mkdir(parents=True)
    write_calibration_toml(read_rig(data / "S1" / "Calibration_Data"),
                           root / "calibration" / "Calib.toml", translation_scale=1000.0)
    (root / "videos").mkdir()
    for cam in ("C1", "C2", "BW1"):
        shutil.copy(data / "S1" / "Image_Data" / f"Walking_1_({cam}).avi",
                    root / "videos" / f"{cam}.avi")
    return root


def _track_project(root, tmp, *extra):
    return ["track", str(root), "--out", str(tmp / "run"), "--no-progress", *extra]


def _project_bad_frame_range(data, tmp):
    root = _project(data, tmp)
    (root / "Config.toml").write_text("[project]\nframe_range = [5]\n")
    return _track_project(root, tmp)


def _freemocap_without_calibration(data, tmp):
    import shutil

    root = tmp / "recording"
    (root / "synchronized_videos").mkdir(parents=True)
    for k, cam in enumerate(("C1", "C2", "BW1")):
        shutil.copy(data / "S1" / "Image_Data" / f"Walking_1_({cam}).avi",
                    root / "synchronized_videos" / f"Camera_{k:03d}_synchronized.avi")
    return ["track", str(root), "--out", str(tmp / "run"), "--no-progress"]


def _all_trials_excluded(data, tmp):
    root = _project(data, tmp)
    (root / "Config.toml").write_text("[project]\nexclude_from_batch = ['proj']\n")
    return ["track", str(root), "--all", "--out", str(tmp / "run"), "--no-progress"]


def _project_camera_without_video(data, tmp):
    root = _project(data, tmp)
    (root / "videos" / "BW1.avi").unlink()
    return _track_project(root, tmp)


def _plate_from_not_hdf5(data, tmp):
    (tmp / "x.h5").write_text("not a result\n")
    return _track(data, tmp, "--plate-from", str(tmp / "x.h5"))


def _masks(data, tmp, *, cameras=("C1", "C2", "BW1"), frames=None, size=None):
    """The project and a masks folder of black PNGs per camera (``frames`` each, default as many
    as the video has, at ``size``, default the video's)."""
    import cv2

    root = _project(data, tmp)
    for cam in cameras:
        cap = cv2.VideoCapture(str(root / "videos" / f"{cam}.avi"))
        n, w, h = (int(cap.get(k)) for k in (cv2.CAP_PROP_FRAME_COUNT, cv2.CAP_PROP_FRAME_WIDTH,
                                             cv2.CAP_PROP_FRAME_HEIGHT))
        cap.release()
        folder = tmp / "masks" / cam
        folder.mkdir(parents=True)
        w, h = size or (w, h)
        for k in range(frames or n):
            cv2.imwrite(str(folder / f"{k + 1:06d}.png"), np.zeros((h, w), np.uint8))
    return [*_track_project(root, tmp), "--masks", str(tmp / "masks")]


def _project_video_without_camera(data, tmp):
    import shutil

    root = _project(data, tmp)
    shutil.copy(root / "videos" / "C1.avi", root / "videos" / "C9.avi")
    return _track_project(root, tmp)


def _project_unreadable_video(data, tmp):
    root = _project(data, tmp)
    (root / "videos" / "C2.avi").write_bytes(b"not a video at all")
    return ["info", str(root)]


def _project_size_mismatch(data, tmp):
    import cv2

    root = _project(data, tmp)
    writer = cv2.VideoWriter(str(root / "videos" / "C2.avi"), cv2.VideoWriter_fourcc(*"MJPG"),
                             60.0, (600, 480))
    for _ in range(3):
        writer.write(np.zeros((480, 600, 3), np.uint8))
    writer.release()
    return ["info", str(root)]


def _project_unknown_calibration(data, tmp):
    root = _project(data, tmp)
    (root / "calibration" / "Calib.toml").rename(root / "calibration" / "calib.json")
    return _track_project(root, tmp)


def _project_calibration_option_unknown(data, tmp):
    root = _project(data, tmp)
    (tmp / "calib.xml").write_text("<calibration/>")
    return _track_project(root, tmp, "--calibration", str(tmp / "calib.xml"))


def _qca_viewrotation(data, tmp):
    root = _project(data, tmp)
    (root / "calibration" / "Calib.toml").unlink()
    (root / "calibration" / "Calib.qca.txt").write_text(
        '<calibration><cameras><camera serial="C1" model="none" viewrotation="90">'
        '<fov_video left="0" top="0" right="639" bottom="479"/></camera></cameras></calibration>')
    return ["info", str(root)]


def _easymocap_broken_extri(data, tmp):
    import shutil

    from voxelmocap.io.calibration import read_rig
    from voxelmocap.io.easymocap import write_easymocap

    root = tmp / "emc"
    (root / "videos").mkdir(parents=True)
    write_easymocap(read_rig(data / "S1" / "Calibration_Data"), root)
    for cam in ("C1", "C2", "BW1"):
        shutil.copy(data / "S1" / "Image_Data" / f"Walking_1_({cam}).avi",
                    root / "videos" / f"{cam}.avi")
    extri = root / "extri.yml"
    extri.write_text(extri.read_text().replace("T_C2", "Translation_C2"))
    return _track_project(root, tmp)


def _project_two_trials(data, tmp):
    import shutil

    root = _project(data, tmp)
    shutil.move(str(root / "videos"), str(root / "Trial_1" / "videos"))
    shutil.copytree(root / "Trial_1", root / "Trial_2")
    return _track_project(root, tmp)


def _humaneva_without_subject(data, tmp):
    return ["track", str(data), "--out", str(tmp / "run"), "--no-progress"]


def _not_a_layout(data, tmp):
    (tmp / "empty").mkdir()
    return ["info", str(tmp / "empty")]


def _import_humaneva(data, tmp):
    return ["import", str(data), "--out", str(tmp / "he"), "--no-progress"]

def _voxel_cue_one_camera(data, tmp):
    return _track(data, tmp, "--cameras", "C1", "--cues", "voxel,edges")


def _unknown_cue(data, tmp):
    return _track(data, tmp, "--cues", "voxel,edgse")


def _cue_weight_zero(data, tmp):
    (tmp / "cfg.toml").write_text("[cues]\nweights = {voxel = 1.0, roi = 0.0}\n")
    return _track(data, tmp, "--config", str(tmp / "cfg.toml"))


CASES: list[Case] = [
    Case("track --config: TOML file that is not UTF-8", _config_not_utf8("track"),
         ("{tmp}/cfg.toml", "not UTF-8")),
    Case("dump --config: TOML file that is not UTF-8", _config_not_utf8("dump"),
         ("{tmp}/cfg.toml", "not UTF-8")),
    Case("sweep --config: TOML file that is not UTF-8", _config_not_utf8("sweep"),
         ("{tmp}/cfg.toml", "not UTF-8")),
    Case("sizes.toml that is not UTF-8", _sizes_not_utf8, ("sizes.toml", "not UTF-8")),
    Case("<Subject>_body.toml that is not UTF-8", _body_not_utf8, ("S1_body.toml", "not UTF-8")),
    Case("a camera asked for has no .ofs sync file", _missing_ofs_camera,
         ("Walking_1_(C2).ofs", "sync file not found")),
    Case("negative image start in a .ofs file", _negative_start, ("Walking_1_(C1).ofs",)),
    Case("--cameras names a camera the sequence does not have", _unknown_camera,
         ("--cameras", "unknown camera 'C9'")),
    Case("voxel_size = 1e9 in the config", _huge_voxels, ("voxel_size", "between")),
    Case("min_volume_share = -0.5 in the config's [recovery]", _bad_recovery_share,
         ("{tmp}/cfg.toml", "'recovery.min_volume_share' must be > 0")),
    Case("--frames -5:3", _negative_frames, ("--frames", "-5")),
    Case("dump --out names an existing folder", _dump_out_is_folder, ("{tmp}/existing",)),
    Case("view --out below a file", _view_out_unwritable, ("{tmp}/file",)),
    Case("synth into a place that cannot be created", _synth_unwritable, ("{tmp}/file",)),
    Case("overlay --out x.gif (not a video format)", _overlay_gif, ("x.gif",)),
    Case("overlay --fps 0", _overlay_fps_zero, ("frame rate must be a positive number",)),
    Case("ground truth coordinate 1e308", _gt_huge_coordinate, ("Walking_1.xml", "1e308")),
    Case("evaluate --json below a file", _evaluate_json_unwritable, ("{tmp}/file",)),
    Case("track --rerun x.txt (not a Rerun file)", _rerun_not_rrd,
         ("{tmp}/x.txt", "expected a Rerun .rrd file name")),
    Case("track --all --workers 0", _all_zero_workers, ("--workers", "at least 1")),
    Case("track --all --masks (masks belong to one sequence)",
         lambda data, tmp: ["track", str(data), "--all", "--masks", str(tmp),
                            "--out", str(tmp / "run"), "--no-progress"],
         ("--masks", "not with --all")),
    Case("track --plate-from a folder without this sequence's result",
         lambda data, tmp: _track(data, tmp, "--plate-from", str(tmp)),
         ("{tmp}/S1/Walking_1.h5", "no result of S1/Walking_1 here")),
    Case("track --plate-from a file that is not a result", _plate_from_not_hdf5,
         ("{tmp}/x.h5", "cannot read HDF5")),
    Case("dump --plate-from a folder without this sequence's result",
         lambda data, tmp: ["dump", str(data), "--subject", "S1", "--sequence", "Walking_1",
                            "--out", str(tmp / "vox.h5"), "--no-progress", "--plate-from",
                            str(tmp)],
         ("{tmp}/S1/Walking_1.h5", "no result of S1/Walking_1 here")),
    Case("export of a result that does not exist", _export(result=False),
         ("{tmp}/run/S1/Walking_1.h5", "no such result file or run folder")),
    Case("export of a file that is not HDF5", _export_not_hdf5,
         ("{tmp}/run/S1/Walking_1.h5", "cannot read HDF5")),
    Case("export --format xyz", _export("--format", "trc,xyz"), ("--format", "unknown format 'xyz'")),
    Case("export --smooth 40 (above Nyquist at 60 Hz)", _export("--smooth", "40"),
         ("--smooth", "between 0 and half the frame rate")),
    Case("export --order 3 (odd)", _export("--smooth", "6", "--order", "3"), ("even integer",)),
    Case("export --opensim of a result without a person in any frame", _export_nobody_seen,
         ("{tmp}/run/S1/Walking_1.h5", "no frame with a person and all 15 landmarks")),
    Case("evaluate --reference: file not found",
         _evaluate_reference(lambda tmp: tmp / "missing.trc"),
         ("{tmp}/missing.trc", "TRC file not found")),
    Case("evaluate --reference: TRC with a non-numeric value", _evaluate_reference(_malformed_trc),
         ("{tmp}/ref.trc", "line 7", "not a number")),
    Case("evaluate --reference: not a TRC", _evaluate_reference(_not_a_trc),
         ("{tmp}/ref.trc", "not a TRC file")),
    Case("evaluate --reference: TRC at another frame rate",
         _evaluate_reference(lambda tmp: _reference(tmp, rate=100.0)),
         ("{tmp}/ref.trc", "differs from the result's 60 Hz")),
    Case("evaluate --reference: mapping names an unknown landmark",
         _evaluate_reference(make_mapping=lambda tmp: _mapping(tmp, '[landmarks]\nnose = "Head"\n')),
         ("{tmp}/map.toml", "unknown landmark 'nose'")),
    Case("evaluate --reference: mapping names a point the reference lacks",
         _evaluate_reference(make_mapping=lambda tmp: _mapping(
             tmp, '[landmarks]\npelvis = ["RHip", "LHip"]\n')),
         ("{tmp}/map.toml", "'RHip' is not a point of ref.trc")),
    Case("evaluate --reference without --mapping", _evaluate_reference(mapping=False),
         ("--reference", "needs --mapping")),
    Case("project: the calibration names a camera the videos lack",
         _project_camera_without_video,
         ("{tmp}/proj/videos", "calibration camera BW1 (Calib.toml) has no video")),
    Case("track --masks: no masks for a camera", lambda d, t: _masks(d, t, cameras=("C1", "C2")),
         ("{tmp}/masks", "no masks for camera BW1")),
    Case("track --masks: fewer mask frames than video frames",
         lambda d, t: _masks(d, t, frames=2), ("{tmp}/masks/C1", "2 mask frames")),
    Case("track --masks: masks of another size than the video",
         lambda d, t: _masks(d, t, size=(64, 48)), ("{tmp}/masks/C1", "masks are 64x48")),
    Case("project: a video no calibration camera matches", _project_video_without_camera,
         ("{tmp}/proj/videos/C9.avi", "no camera of the calibration")),
    Case("project: an unreadable video", _project_unreadable_video,
         ("{tmp}/proj/videos/C2.avi", "cannot open video")),
    Case("project: video size far from the calibration's", _project_size_mismatch,
         ("{tmp}/proj/videos/C2.avi", "600x480 cannot be the calibration's 640x480")),
    Case("project: calibration folder with no known format", _project_unknown_calibration,
         ("{tmp}/proj/calibration", "no calibration file", "calib.json")),
    Case("project: --calibration of an unknown format", _project_calibration_option_unknown,
         ("{tmp}/calib.xml", "unknown calibration format")),
    Case("Qualisys .qca.txt with a rotated camera", _qca_viewrotation,
         ("{tmp}/proj/calibration/Calib.qca.txt", "viewrotation=90")),
    Case("EasyMocap extri.yml without a camera's T", _easymocap_broken_extri,
         ("{tmp}/emc/extri.yml", "no 'T_C2'")),
    Case("Pose2Sim Config.toml with a malformed frame_range", _project_bad_frame_range,
         ("{tmp}/proj/Config.toml", "frame_range must be 'auto', 'all' or [start, end]")),
    Case("FreeMoCap recording without its calibration TOML", _freemocap_without_calibration,
         ("{tmp}/recording", "no FreeMoCap calibration (recording_camera_calibration.toml")),
    Case("track --all where Config.toml excludes every trial", _all_trials_excluded,
         ("{tmp}/proj", "every trial is excluded from batch analysis")),
    Case("project with several trials and no --trial", _project_two_trials,
         ("{tmp}/proj", "choose one with --trial")),
    Case("track on the HumanEva layout without --subject/--sequence", _humaneva_without_subject,
         ("{data}", "needs --subject and --sequence")),
    Case("a folder that is neither a data set nor a project", _not_a_layout,
         ("{tmp}/empty", "not a Pose2Sim")),
    Case("import of a HumanEva-layout data set", _import_humaneva,
         ("{data}", "HumanEva-layout data set already")),
    Case("track --cameras C1 --cues voxel,edges (voxels from one camera)", _voxel_cue_one_camera,
         ("cues", "at least two cameras", "C1")),
    Case("track --cues names an unknown cue", _unknown_cue, ("--cues", "unknown cue 'edgse'")),
    Case("a cue weight of 0 in the config", _cue_weight_zero, ("{tmp}/cfg.toml", "roi")),
]
