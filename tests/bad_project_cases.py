"""The bad inputs of issue 36 ("the new readers hardened"), as data: projects, calibrations in
every format, image folders, raw mocap, exports and references.

Each case takes the tiny HumanEva-layout data set (``tests/humaneva_fixture.py``), builds from
it what the issue's hostile user changed (mostly a Pose2Sim, anipose or EasyMocap project made
by :func:`bad_input_cases._project` and its siblings), and runs one command. The same checks as
``tests/bad_input_cases.py`` apply (``tests/test_bad_inputs.py``): exit code 2, one line on
stderr naming the file (or option) and the problem, no traceback, nothing new left behind.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
from bad_input_cases import Case, _project, _reference, _result, _track_project

# ---------------------------------------------------------------------- builders


def _info(root) -> list[str]:
    return ["info", str(root)]


def _qca_project(data, tmp) -> Path:
    """The project with its calibration as a Qualisys ``Calib.qca.txt`` (cameras C1, C2, BW1)."""
    from project_fixture import qca_rig, write_qca

    from voxelmocap.io.calibration import read_rig

    root = _project(data, tmp)
    (root / "calibration" / "Calib.toml").unlink()
    write_qca(qca_rig(read_rig(data / "S1" / "Calibration_Data")),
              root / "calibration" / "Calib.qca.txt")
    return root


def _qca_edit(attribute: str, value: str, camera: str = "C2"):
    """A ``.qca.txt`` whose camera ``camera`` has ``attribute`` set to ``value``."""
    import re

    def setup(data, tmp):
        root = _qca_project(data, tmp)
        path = root / "calibration" / "Calib.qca.txt"
        lines = path.read_text().splitlines(keepends=True)
        start = next(i for i, line in enumerate(lines) if f'serial="{camera}"' in line)
        for i in range(start, len(lines)):
            if re.search(rf'\b{attribute}="', lines[i]):
                lines[i] = re.sub(rf'\b{attribute}="[^"]*"', f'{attribute}="{value}"', lines[i])
                break
        path.write_text("".join(lines))
        return _info(root)
    return setup


def _toml_edit(edit):
    """The project's ``Calib.toml`` (metres) changed by ``edit(dict)``."""
    def setup(data, tmp):
        from voxelmocap.io.toml import read_toml, write_toml

        root = _project(data, tmp)
        path = root / "calibration" / "Calib.toml"
        table = read_toml(path)
        edit(table)
        write_toml(path, table)
        return _info(root)
    return setup


def _far_translation(table):
    table["cam_1"]["translation"] = [0.0, 0.0, 1e9]


def _same_names(table):
    table["cam_1"]["name"] = table["cam_0"]["name"]


def _config(text: str, command="info", calibration="toml"):
    """The project (``calibration="qca"``: with a ``.qca.txt``) with a Config.toml of ``text``."""
    def setup(data, tmp):
        root = _qca_project(data, tmp) if calibration == "qca" else _project(data, tmp)
        (root / "Config.toml").write_text(text)
        return _info(root) if command == "info" else _track_project(root, tmp)
    return setup


def _anipose(data, tmp, config: str | None = "[triangulation]\ncam_regex = '-cam([A-Z])'\n",
             stems=("walk-camA", "walk-camB", "walk-camC")) -> Path:
    """An anipose session: calibration/calibration.toml (mm), videos-raw/<stem>.avi."""
    from project_fixture import renamed

    from voxelmocap.io.calibration import read_rig, write_calibration_toml

    root = tmp / "ani"
    (root / "calibration").mkdir(parents=True)
    rig = read_rig(data / "S1" / "Calibration_Data", names=["C1", "C2", "BW1"])
    write_calibration_toml(renamed(rig, {"C1": "A", "C2": "B", "BW1": "C"}),
                           root / "calibration" / "calibration.toml")
    (root / "videos-raw").mkdir()
    for cam, stem in zip(("C1", "C2", "BW1"), stems, strict=True):
        shutil.copy(data / "S1" / "Image_Data" / f"Walking_1_({cam}).avi",
                    root / "videos-raw" / f"{stem}.avi")
    if config is not None:
        (root / "config.toml").write_text(config)
    return root


def _anipose_config(text: str, stems=("walk-camA", "walk-camB", "walk-camC")):
    def setup(data, tmp):
        return _info(_anipose(data, tmp, text, stems))
    return setup


def _easymocap(data, tmp) -> Path:
    from voxelmocap.io.calibration import read_rig
    from voxelmocap.io.easymocap import write_easymocap

    root = tmp / "emc"
    (root / "videos").mkdir(parents=True)
    write_easymocap(read_rig(data / "S1" / "Calibration_Data"), root)
    for cam in ("C1", "C2", "BW1"):
        shutil.copy(data / "S1" / "Image_Data" / f"Walking_1_({cam}).avi",
                    root / "videos" / f"{cam}.avi")
    return root


def _yml_edit(name: str, edit):
    def setup(data, tmp):
        root = _easymocap(data, tmp)
        path = root / name
        path.write_bytes(edit(path.read_bytes()))
        return _info(root)
    return setup


def _deep_names(raw: bytes) -> bytes:
    return raw.replace(b"names:\n", b"deep: " + b"[" * 100_000 + b"]" * 100_000 + b"\nnames:\n")


def _deep_block(raw: bytes) -> bytes:
    return raw.replace(b"names:\n", b"deep:\n" + b"".join(b" " * k + b"- \n"
                                                           for k in range(0, 4000, 2))
                       + b"names:\n")


def _latin1(raw: bytes) -> bytes:
    return raw.replace(b"names:\n", b"# caf\xe9\nnames:\n")


def _nan_name(raw: bytes) -> bytes:
    return raw.replace(b'  - "C2"\n', b"  - .nan\n")


def _rot_not_rotation(raw: bytes) -> bytes:
    text = raw.decode()
    start = text.index("R_C2:")
    end = text.index("Rot_C2:")
    text = text[:start] + text[end:]
    i = text.index("data: [", text.index("Rot_C2:")) + len("data: [")
    j = text.index("]", i)
    return (text[:i] + "1, 2, 3, 4, 5, 6, 7, 8, 10" + text[j:]).encode()


def _far_translation_yml(raw: bytes) -> bytes:
    text = raw.decode()
    i = text.index("data: [", text.index("T_C2:")) + len("data: [")
    j = text.index("]", i)
    return (text[:i] + "0, 0, 1e9" + text[j:]).encode()


def _image_folders(data, tmp, frames=6) -> Path:
    """The project with numbered PNG folders instead of videos (frames 1..``frames``)."""
    root = _project(data, tmp)
    for cam in ("C1", "C2", "BW1"):
        cap = cv2.VideoCapture(str(root / "videos" / f"{cam}.avi"))
        folder = root / "videos" / cam
        folder.mkdir()
        for k in range(1, frames + 1):
            ok, image = cap.read()
            assert ok
            cv2.imwrite(str(folder / f"frame_{k:06d}.png"), image)
        cap.release()
        (root / "videos" / f"{cam}.avi").unlink()
    return root


def _frame2(change: str, command="info"):
    def setup(data, tmp):
        root = _image_folders(data, tmp)
        path = root / "videos" / "C2" / "frame_000002.png"
        if change == "corrupt":
            path.write_bytes(path.read_bytes()[:60] + b"\0" * 200)
        elif change == "empty":
            path.write_bytes(b"")
        elif change == "missing":
            path.unlink()
        elif change == "resized":
            cv2.imwrite(str(path), np.zeros((240, 320, 3), np.uint8))
        elif change == "folder":
            path.unlink()
            path.mkdir()
        elif change == "huge":
            path.write_bytes(_png_header(60_000, 60_000))
        return _info(root) if command == "info" else _track_project(root, tmp)
    return setup


def _png_header(w: int, h: int) -> bytes:
    import struct
    import zlib

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    return (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", len(ihdr)) + chunk
            + struct.pack(">I", zlib.crc32(chunk)) + b"\0" * 64)


def _humaneva_truncated_frame(data, tmp):
    """The HumanEva layout's C2 as a numbered PNG folder whose third file is cut short."""
    from bad_input_cases import _track

    video = data / "S1" / "Image_Data" / "Walking_1_(C2).avi"
    folder = video.with_suffix("")
    folder.mkdir()
    cap = cv2.VideoCapture(str(video))
    k = 0
    while True:
        ok, image = cap.read()
        if not ok:
            break
        k += 1
        cv2.imwrite(str(folder / f"frame_{k:05d}.png"), image)
    cap.release()
    video.unlink()
    third = folder / "frame_00003.png"
    third.write_bytes(third.read_bytes()[:-100])
    return _track(data, tmp)


def _far_frame_number(data, tmp):
    root = _image_folders(data, tmp, frames=5)
    shutil.copy(root / "videos" / "C1" / "frame_000005.png",
                root / "videos" / "C1" / "frame_999999999.png")
    return _info(root)


def _two_containers(data, tmp):
    root = _project(data, tmp)
    shutil.copy(root / "videos" / "C1.avi", root / "videos" / "C1.mp4")
    return _info(root)


def _bad_utf8_video(data, tmp):
    root = _project(data, tmp)
    folder = bytes(root / "videos")
    (root / "videos" / "C1.avi").rename(Path((folder + b"/C1\xff.avi").decode("utf-8",
                                                                             "surrogateescape")))
    return _info(root)


def _short_videos(data, tmp):
    root = _project(data, tmp)
    for cam, n in (("C1", 1), ("C2", 2), ("BW1", 5)):
        cap = cv2.VideoCapture(str(root / "videos" / f"{cam}.avi"))
        images = [cap.read()[1] for _ in range(n)]
        cap.release()
        writer = cv2.VideoWriter(str(root / "videos" / f"{cam}.avi"),
                                 cv2.VideoWriter_fourcc(*"MJPG"), 60.0, (640, 480))
        for image in images:
            writer.write(image)
        writer.release()
    return [*_track_project(root, tmp), "--frames", "1:3"]


def _other_rate(data, tmp):
    root = _project(data, tmp)
    cap = cv2.VideoCapture(str(root / "videos" / "C1.avi"))
    images = [cap.read()[1] for _ in range(12)]
    cap.release()
    writer = cv2.VideoWriter(str(root / "videos" / "C1.avi"), cv2.VideoWriter_fourcc(*"MJPG"),
                             30.0, (640, 480))
    for image in images:
        writer.write(image)
    writer.release()
    return _info(root)


def _anipose_dots(data, tmp):
    root = _anipose(data, tmp, stems=("_..-camA", "_..-camB", "_..-camC"))
    return _track_project(root, tmp)


def _unknown_camera_one(data, tmp):
    return [*_track_project(_project(data, tmp), tmp), "--cameras", "cam09"]


def _mp_value(value: str):
    def setup(data, tmp):
        from humaneva_mocap_fixture import write_mp

        path = write_mp(tmp / "S1.mp")
        text = path.read_text().splitlines()
        name = text[0].split("=")[0]
        text[0] = f"{name}= {value}"
        path.write_text("\n".join(text) + "\n")
        return _groundtruth_with(data, tmp, mp=path)
    return setup


def _groundtruth_with(data, tmp, *, mp=None, static=None, trial=None):
    """``groundtruth`` of S1/Walking_1 with raw mocap files (the fixture's, or those given)."""
    from humaneva_mocap_fixture import standing_markers, write_mocap_mat, write_mp

    mocap = data / "S1" / "Mocap_Data"
    (mocap / "Walking_1.xml").unlink()
    markers = standing_markers(40)
    if trial is None:
        write_mocap_mat(mocap / "Walking_1.mat", markers)
    else:
        trial(mocap / "Walking_1.mat")
    if static is None:
        write_mocap_mat(mocap / "Static.mat", markers[:5])
    else:
        static(mocap / "Static.mat")
    if mp is None:
        write_mp(mocap / "S1.mp")
    else:
        shutil.copy(mp, mocap / "S1.mp")
        mp.unlink()
    return ["groundtruth", str(data), "--subject", "S1", "--sequence", "Walking_1", "--out",
            str(tmp / "gt.xml")]


def _static_folder(data, tmp):
    return _groundtruth_with(data, tmp, static=lambda p: p.mkdir())


def _static_loop(data, tmp):
    import os

    def loop(p):
        os.symlink(p.name, p)
    return _groundtruth_with(data, tmp, static=loop)


def write_mat_bomb(path, declared: int = 1_460_000_000, *, whole: bool = True) -> Path:
    """A MAT v5 file whose compressed ``Markers`` (zeros) declares ``declared`` bytes (and holds
    them, unless not ``whole``: then 1 MB of them, quicker to write)."""
    import struct
    import zlib

    n = declared // 8 // 3
    name = b"Markers"
    body = struct.pack("<IIII", 6, 8, 6, 0)  # array flags: double
    body += struct.pack("<II", 5, 12) + struct.pack("<iii", n, 1, 3) + b"\0" * 4
    body += struct.pack("<II", 1, len(name)) + name + b"\0" * (8 - len(name) % 8)
    body += struct.pack("<II", 9, n * 3 * 8)
    compressor = zlib.compressobj(1)  # fastest: the point is the size declared
    stream = compressor.compress(struct.pack("<II", 14, len(body) + n * 24) + body)
    zeros = b"\0" * (1 << 20)
    for _ in range(n * 24 // len(zeros) if whole else min(1, n * 24 // len(zeros))):
        stream += compressor.compress(zeros)
    stream += compressor.compress(b"\0" * (n * 24 % len(zeros))) + compressor.flush()
    header = b"MATLAB 5.0 MAT-file".ljust(116, b" ") + b"\0" * 8 + struct.pack("<H", 0x0100) \
        + b"IM"
    path.write_bytes(header + struct.pack("<II", 15, len(stream)) + stream)
    return path


def _mat_bomb(data, tmp):
    """A trial ``.mat`` whose compressed ``Markers`` declares 1.46 GB (zeros compress well)."""
    return _groundtruth_with(data, tmp, trial=write_mat_bomb)


def _export_attr(**attrs):
    def setup(data, tmp):
        from voxelmocap.io.results import read_result, write_result

        path = _result(tmp)
        result = read_result(path)
        for key, value in attrs.items():
            if key == "frames":
                result.frames = np.asarray(value, dtype=np.int64)
            else:
                result.attrs[key] = value
        write_result(path, result)
        return ["export", str(path)]
    return setup


def _export_order(data, tmp):
    return ["export", str(_result(tmp)), "--smooth", "6", "--order", "1000000"]


def _export_below_file(data, tmp):
    (tmp / "file").write_text("x")
    return ["export", str(_result(tmp)), "--out", str(tmp / "file" / "sub")]


def _trc_frame(value: str):
    def make(tmp):
        path = _reference(tmp)
        lines = path.read_text().splitlines()
        cells = lines[5].split("\t")
        cells[0] = value
        lines[5] = "\t".join(cells)
        path.write_text("\n".join(lines) + "\n")
        return path
    return make


def _csv_reference(body: str):
    def make(tmp):
        path = tmp / "ref.csv"
        path.write_text("frame,landmark,x_mm,y_mm,z_mm\n" + body)
        return path
    return make


def _evaluate(make_reference, mapping='[landmarks]\nhead = "Head"\n'):
    def setup(data, tmp):
        (tmp / "map.toml").write_text(mapping)
        return ["evaluate", str(_result(tmp)), "--reference", str(make_reference(tmp)),
                "--mapping", str(tmp / "map.toml")]
    return setup


# ---------------------------------------------------------------------- the cases
Q = "{tmp}/proj/calibration/Calib.qca.txt"
T = "{tmp}/proj/calibration/Calib.toml"
INTRI, EXTRI = "{tmp}/emc/intri.yml", "{tmp}/emc/extri.yml"

CASES: list[Case] = [
    # far cameras, out-of-range intrinsics (issue: tracebacks, 335 GiB grids, NumPy warnings)
    Case(".qca.txt: a camera centre at x = 1e12 mm", _qca_edit("x", "1e12"),
         (Q, "camera C2", "from the other cameras")),
    Case(".qca.txt: a camera centre at x = 1e308 mm", _qca_edit("x", "1e308"),
         (Q, "camera C2", "from the other cameras")),
    Case(".qca.txt: focalLengthU = 1e308", _qca_edit("focalLengthU", "1e308"),
         (Q, "camera 'C2'", "focal length")),
    Case(".qca.txt: radialDistortion1 = 1e300", _qca_edit("radialDistortion1", "1e300"),
         (Q, "camera 'C2'", "distortion")),
    Case(".qca.txt: skew = 1e300", _qca_edit("skew", "1e300"), (Q, "camera 'C2'", "skew")),
    Case("calibration TOML: a translation of 1e9 m", _toml_edit(_far_translation),
         (T, "camera C2", "from the other cameras")),
    Case("calibration TOML: two cameras of the same name", _toml_edit(_same_names),
         (T, "camera names are not unique", "C1")),
    # Config.toml and anipose config.toml of the wrong types
    Case("Config.toml: calibration = 5", _config("calibration = 5\n", calibration="qca"),
         ("{tmp}/proj/Config.toml", "[calibration] must be a table")),
    Case("Config.toml: calibration = 'x'", _config("calibration = 'x'\n", calibration="qca"),
         ("{tmp}/proj/Config.toml", "[calibration] must be a table")),
    Case("Config.toml: [calibration] convert = 'qualisys'",
         _config("[calibration]\nconvert = 'qualisys'\n", calibration="qca"),
         ("{tmp}/proj/Config.toml", "[calibration.convert] must be a table")),
    Case("Config.toml: project = 5", _config("project = 5\n"),
         ("{tmp}/proj/Config.toml", "[project] must be a table")),
    Case("anipose config.toml: cam_regex = 123", _anipose_config("[triangulation]\ncam_regex = 123\n"),
         ("{tmp}/ani/config.toml", "cam_regex must be a string")),
    Case("anipose config.toml: cam_regex a list",
         _anipose_config("[triangulation]\ncam_regex = ['a']\n"),
         ("{tmp}/ani/config.toml", "cam_regex must be a string")),
    Case("anipose config.toml: triangulation = 5", _anipose_config("triangulation = 5\n"),
         ("{tmp}/ani/config.toml", "[triangulation] must be a table")),
    Case("anipose config.toml: cam_regex '^(a+)+$' (catastrophic backtracking)",
         _anipose_config("[triangulation]\ncam_regex = '^(a+)+$'\n",
                         stems=("a" * 40 + "-camA", "a" * 40 + "-camB", "a" * 40 + "-camC")),
         ("{tmp}/ani/config.toml", "cam_regex", "nested")),
    # EasyMocap's OpenCV YAML
    Case("intri.yml: a 100 000-deep nested flow sequence", _yml_edit("intri.yml", _deep_names),
         (INTRI, "nested")),
    Case("intri.yml: a 2 000-deep nested block sequence", _yml_edit("intri.yml", _deep_block),
         (INTRI, "nested")),
    Case("intri.yml: a latin-1 byte", _yml_edit("intri.yml", _latin1), (INTRI, "not UTF-8")),
    Case("intri.yml: .nan in the names list", _yml_edit("intri.yml", _nan_name),
         (INTRI, "names", "nan")),
    Case("extri.yml: no R_C2 and Rot_C2 not a rotation", _yml_edit("extri.yml", _rot_not_rotation),
         (EXTRI, "Rot_C2", "not a rotation")),
    Case("extri.yml: T_C2 of 1e9 m", _yml_edit("extri.yml", _far_translation_yml),
         (EXTRI, "camera C2", "from the other cameras")),
    # videos and image folders
    Case("video name that is not UTF-8", _bad_utf8_video, ("{tmp}/proj/videos", "UTF-8")),
    Case("C1.avi and C1.mp4 both in videos/", _two_containers,
         ("{tmp}/proj/videos", "C1.avi", "C1.mp4")),
    Case("videos of 1, 2 and 5 frames with --frames 1:3", _short_videos,
         ("frame 2 is outside",)),
    Case("a 30 fps video among 60 fps ones", _other_rate,
         ("{tmp}/proj/videos/C1.avi", "30 Hz")),
    Case("image folder: frame 2 corrupt", _frame2("corrupt"),
         ("{tmp}/proj/videos/C2/frame_000002.png",)),
    Case("image folder: frame 2 empty", _frame2("empty"),
         ("{tmp}/proj/videos/C2/frame_000002.png", "empty")),
    Case("image folder: frame 2 missing", _frame2("missing"),
         ("{tmp}/proj/videos/C2", "no image file with counter 2")),
    Case("image folder: frame 2 resized", _frame2("resized"),
         ("{tmp}/proj/videos/C2/frame_000002.png", "320x240")),
    Case("image folder: frame 2 is a folder", _frame2("folder"),
         ("{tmp}/proj/videos/C2/frame_000002.png", "not a regular file")),
    Case("image folder: frame 2 declares 60000x60000 pixels", _frame2("huge"),
         ("{tmp}/proj/videos/C2/frame_000002.png", "60000x60000")),
    Case("image folder: frame 2 corrupt (track)", _frame2("corrupt", command="track"),
         ("{tmp}/proj/videos/C2/frame_000002.png",)),
    Case("HumanEva image folder: frame 3 truncated (track)", _humaneva_truncated_frame,
         ("{data}/S1/Image_Data/Walking_1_(C2)/frame_00003.png", "truncated PNG")),
    Case("image folder: frame_999999999.png beside frames 1-5", _far_frame_number,
         ("{tmp}/proj/videos/C1", "999999999")),
    Case("anipose videos named _..-camA.avi (trial name '..')", _anipose_dots,
         ("{tmp}/ani/videos-raw", "'..'", "trial name")),
    Case("track --cameras cam09 (one unknown camera)", _unknown_camera_one,
         ("--cameras", "unknown camera 'cam09'")),
    # raw HumanEva mocap
    Case(".mp value nan", _mp_value("nan"), ("S1.mp", "not a finite number")),
    Case(".mp value inf", _mp_value("inf"), ("S1.mp", "not a finite number")),
    Case("Static.mat that is a folder", _static_folder, ("Static.mat", "folder")),
    Case("Static.mat that is a symlink loop", _static_loop, ("Static.mat", "symbolic link")),
    Case(".mat whose zlib stream declares 1.46 GB of markers", _mat_bomb,
         ("Walking_1.mat", "MB")),
    # export and evaluate --reference
    Case("export: frame_rate 1e308", _export_attr(frame_rate=1e308),
         ("{tmp}/run/S1/Walking_1.h5", "frame_rate")),
    Case("export: frame_rate as text", _export_attr(frame_rate="fast"),
         ("{tmp}/run/S1/Walking_1.h5", "frame_rate")),
    Case("export: frames from 2**62", _export_attr(frames=[2**62, 2**62 + 1, 2**62 + 2]),
         ("{tmp}/run/S1/Walking_1.h5", "frame")),
    Case("export: frames <= 0", _export_attr(frames=[-1, 0, 1]),
         ("{tmp}/run/S1/Walking_1.h5", "frame")),
    Case("export: 3 landmark names for 15 columns",
         _export_attr(landmark_names=["a", "b", "c"]),
         ("{tmp}/run/S1/Walking_1.h5", "3 landmark names")),
    Case("export --order 1000000", _export_order, ("--order", "1000000")),
    Case("export --format ''", lambda data, tmp: ["export", str(_result(tmp)), "--format", ""],
         ("--format", "no format")),
    Case("export --out below a file", _export_below_file, ("{tmp}/file",)),
    Case("evaluate --reference: TRC frame number beyond int64",
         _evaluate(_trc_frame("99999999999999999999")), ("{tmp}/ref.trc", "line 6")),
    Case("evaluate --reference: frame_offset beyond int64",
         _evaluate(_reference, '[landmarks]\nhead = "Head"\n[reference]\n'
                               'frame_offset = 9223372036854775807\n'),
         ("{tmp}/map.toml", "frame_offset")),
    Case("evaluate --reference: CSV frame number beyond int64",
         _evaluate(_csv_reference("99999999999999999999,Head,0,0,0\n")),
         ("{tmp}/ref.csv", "line 2")),
    Case("evaluate --reference: CSV coordinate inf", _evaluate(_csv_reference("1,Head,inf,0,0\n")),
         ("{tmp}/ref.csv", "line 2", "finite")),
    Case("evaluate --reference: CSV with a NUL byte",
         _evaluate(_csv_reference("1,Head,0,0\x00,0\n")), ("{tmp}/ref.csv", "NUL")),
]
