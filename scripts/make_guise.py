"""A Pose2Sim project in another guise: the same recording as a user's other recording of it.

Copies a Pose2Sim project (``Config.toml``, ``calibration/``, ``videos/``) into ``OUT`` changed
as asked, so that tracking the copy tests that nothing but the guise changes the result (issue
34: "the same recording in other guises … no guise worse than the original by more than 15 mm
mean"):

* ``--scale S``: every video resized to ``round(w·S) × round(h·S)`` with ``cv2.INTER_AREA``
  and the cameras' intrinsics scaled to match. OpenCV's resize keeps the image's edges, so pixel
  centres map as ``u' = (u + ½)·s − ½`` with ``s = w'/w`` per axis (the exact factor of the
  rounded size): ``fc' = fc·s``, ``cc' = (cc + ½)·s − ½`` (as
  ``voxelmocap.measure.plate.downscale_camera``); the calibrated image size scales by the same
  ``s`` (a calibration wider than the videos, like the demo's 1088 for 1080 columns, stays so).
* ``--first-frame K``: the videos start at original frame K (frame F of the guise is frame
  F + K − 1 of the original; score with ``bench_real.py landmarks --frame-offset K-1``).
* ``--every K``: every K-th frame from the first kept, at the original rate / K (another frame
  rate: frame F of the guise is frame (F − 1)·K + first of the original; score with
  ``bench_real.py landmarks --frame-offset first-1 --frame-step K``).
* ``--drop-camera NAME`` (repeatable): the camera's video and its calibration left out.
* ``--calibration-format toml|qca``: the calibration written as a Pose2Sim TOML (translations in
  metres, as Pose2Sim writes them) or a Qualisys ``.qca.txt`` (QTM's conventions as
  ``voxelmocap.io.qualisys`` reads them, with the project's ``binning_factor``). Default: the
  original's format (the file copied as is when nothing else changes the cameras).

Videos are written as lossless numbered PNG folders (``videos/<camera>/frame_000001.png`` …)
whenever their pixels change (``--scale`` other than 1, ``--first-frame`` or ``--every`` other
than 1), copied otherwise. ``Config.toml`` is copied, with ``[project] frame_rate = 'auto'``
replaced by the original videos' rate (divided by ``--every``) when the videos become image
folders (which state none). The copy is built
in a temporary folder beside ``OUT`` and renamed when done (``OUT`` must not exist).

    python scripts/make_guise.py /work/p2s/x/Pose2Sim/Demo_SinglePerson /tmp/guise_half \\
        --scale 0.5 --calibration-format toml
    python scripts/make_guise.py DEMO /tmp/guise_no4 --drop-camera cam04
    voxelmocap track /tmp/guise_half --out RUN --no-progress
    python scripts/bench_real.py landmarks RUN --ref /work/p2s_ref

Feeds docs/benchmarks.md, "Real recording (Pose2Sim demo)" (the guises).
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import tomllib

from voxelmocap.camera import Rig
from voxelmocap.io.calibration import write_calibration_toml
from voxelmocap.io.calibration_files import calibration_format, find_calibration, read_calibration_file
from voxelmocap.io.video import VideoStream, find_videos

#: QTM stores image coordinates in 1/64 pixel (voxelmocap.io.qualisys.QUALISYS_SUBPIXEL).
SUBPIXEL = 64.0
_FLIP_X = np.diag([1.0, -1.0, -1.0])


def scaled_size(size, scale: float) -> tuple[int, int]:
    """``(W, H)`` scaled and rounded (at least 1 pixel)."""
    return tuple(max(1, int(round(v * scale))) for v in size)


def scale_camera(camera, factors):
    """The camera imaging the same view with pixels scaled by ``factors = (sx, sy)``.

    Pixel centres: ``u' = (u + ½)·sx − ½`` (OpenCV's resize keeps the image edges); the
    calibrated size scales by the same factors.
    """
    s = np.asarray(factors, dtype=float)
    return dataclasses.replace(camera, fc=np.asarray(camera.fc, dtype=float) * s,
                               cc=(np.asarray(camera.cc, dtype=float) + 0.5) * s - 0.5,
                               size=(max(1, int(round(camera.size[0] * s[0]))),
                                     max(1, int(round(camera.size[1] * s[1])))))


def write_qca(rig, path: Path, *, binning: float = 1.0) -> None:
    """A QTM ``.qca.txt`` of ``rig`` read back by ``voxelmocap.io.qualisys`` (and Pose2Sim) as
    ``rig`` with ``binning_factor = binning``: sub-pixel units (×64, ×binning, distortion too as
    Pose2Sim divides it), the camera centre in mm, ``M = diag(1, −1, −1) R`` (QTM's camera axes).
    k3 and skew cannot be held: refused when non-zero."""
    b = float(binning)
    cams = []
    for cam in rig:
        if abs(float(cam.kc[4])) > 0 or abs(float(cam.alpha_c)) > 0:
            raise SystemExit(f"camera {cam.name}: a .qca.txt holds no k3 nor skew; use "
                             "--calibration-format toml")
        w, h = (int(round(v * b)) for v in cam.size)
        M = (_FLIP_X @ np.asarray(cam.R)).tolist()
        c = np.asarray(cam.center, dtype=float).tolist()
        (fx, fy), (cx, cy) = np.asarray(cam.fc).tolist(), np.asarray(cam.cc).tolist()
        k1, k2, p1, p2 = (float(v) * SUBPIXEL * b for v in cam.kc[:4])
        u = SUBPIXEL * b
        rot = " ".join(f'r{i + 1}{j + 1}="{M[i][j]!r}"' for i in range(3) for j in range(3))
        cams.append(
            f'    <camera active="1" avg-residual="0" model="none" point-count="0" '
            f'serial="{cam.name}" viewrotation="0">\n'
            f'      <fov_video bottom="{h - 1}" left="0" right="{w - 1}" top="0"/>\n'
            f'      <transform {rot} x="{c[0]!r}" y="{c[1]!r}" z="{c[2]!r}"/>\n'
            f'      <intrinsic centerPointU="{cx * u!r}" centerPointV="{cy * u!r}" '
            f'focalLengthU="{fx * u!r}" focalLengthV="{fy * u!r}" '
            f'radialDistortion1="{k1!r}" radialDistortion2="{k2!r}" radialDistortion3="0" '
            f'skew="0" tangentalDistortion1="{p1!r}" tangentalDistortion2="{p2!r}"/>\n'
            "    </camera>\n")
    path.write_text("<?xml version='1.0' encoding='ASCII'?>\n"
                    '<calibration source="voxelmocap scripts/make_guise.py" type="regular">\n'
                    f"  <cameras>\n{''.join(cams)}  </cameras>\n</calibration>\n")


def binning_factor(config: Path) -> float:
    """``[calibration.convert.qualisys] binning_factor`` of a Pose2Sim Config.toml (default 1)."""
    if not config.is_file():
        return 1.0
    data = tomllib.loads(config.read_text())
    return float(data.get("calibration", {}).get("convert", {}).get("qualisys", {})
                 .get("binning_factor", 1))


def _state_frame_rate(config: str, videos: dict, drop, every: int = 1) -> str:
    """``config`` with ``[project] frame_rate = 'auto'`` replaced by the videos' frame rate
    (divided by ``every``, the guise keeping every ``every``-th frame).

    Numbered images state no frame rate (voxelmocap would assume 30 Hz, Pose2Sim 60): a user
    filming into image folders states it in Config.toml, and so does the guise."""
    rates = {round(VideoStream(p, gray=False).fps or 0, 3) for n, p in videos.items()
             if n not in drop}
    if len(rates) != 1 or not next(iter(rates)) > 0:
        return config                                   # no single stated rate to keep
    rate = next(iter(rates)) / every
    new, n = re.subn(r"^(\s*frame_rate\s*=\s*)(['\"])auto\2", rf"\g<1>{rate:g}", config,
                     count=1, flags=re.M)
    if n:
        print(f"Config.toml: frame_rate = {rate:g} (the original videos' rate"
              + (f" / {every})" if every > 1 else ")"))
    return new


def _write_video(src: Path, dest: Path, scale: float, first: int, every: int = 1
                 ) -> tuple[int, int, int, int]:
    """``src`` from frame ``first`` (1-based), every ``every``-th frame, resized, as a PNG
    folder; ``(w, h, w', h')``."""
    stream = VideoStream(src, gray=False)
    if first > stream.n_frames:
        raise SystemExit(f"{src}: --first-frame {first} but the video has {stream.n_frames} frames")
    dest.mkdir(parents=True)
    size = new = None
    for k, (_, image) in enumerate(stream.read(range(first - 1, stream.n_frames, every)),
                                   start=1):
        h, w = image.shape[:2]
        size, new = (w, h), scaled_size((w, h), scale)
        if new != size:
            image = cv2.resize(image, new, interpolation=cv2.INTER_AREA)
        if not cv2.imwrite(str(dest / f"frame_{k:06d}.png"), image):
            raise SystemExit(f"{dest}: could not write frame {k}")
    if size is None:
        raise SystemExit(f"{src}: no frames read")
    return (*size, *new)


def _build(project, tmp, calib_path, rig, videos, *, scale, first_frame, every, drop, fmt,
           original_format, binning) -> None:
    """The guise's files, in ``tmp``."""
    (tmp / "calibration").mkdir(parents=True)
    (tmp / "videos").mkdir()
    factors = {}
    for name, src in videos.items():
        if name in drop:
            continue
        if scale == 1 and first_frame == 1 and every == 1:
            dest = tmp / "videos" / src.name
            (shutil.copytree if src.is_dir() else shutil.copy2)(src, dest)
            factors[name] = (1.0, 1.0)
            continue
        w, h, w2, h2 = _write_video(src, tmp / "videos" / name, scale, first_frame, every)
        factors[name] = (w2 / w, h2 / h)
        print(f"{name}: {w}x{h} -> {w2}x{h2}, frames {first_frame}.. of the original"
              + (f", every {every}th" if every > 1 else ""))
    if (project / "Config.toml").is_file():
        text = (project / "Config.toml").read_text()
        if any(p.is_dir() for p in (tmp / "videos").iterdir()):
            text = _state_frame_rate(text, videos, drop, every)
        (tmp / "Config.toml").write_text(text)
    cameras = [scale_camera(c, factors.get(c.name, (scale, scale))) for c in rig
               if c.name not in drop]
    changed = drop or fmt != original_format or any(f != (1.0, 1.0) for f in factors.values())
    if not changed:
        shutil.copy2(calib_path, tmp / "calibration" / calib_path.name)
    elif fmt == "toml":
        write_calibration_toml(Rig(cameras), tmp / "calibration" / "Calib_guise.toml",
                               translation_scale=1000.0)       # Pose2Sim's metres
    else:
        write_qca(Rig(cameras), tmp / "calibration" / "Calib_guise.qca.txt", binning=binning)


def make_guise(project: Path, out: Path, *, scale: float = 1.0, first_frame: int = 1,
               every: int = 1, drop: tuple[str, ...] = (), calibration: str | None = None) -> Path:
    """Write the guise of ``project`` to ``out`` (see the module docstring); returns ``out``."""
    project, out = Path(project), Path(out)
    if out.exists():
        raise SystemExit(f"{out} exists: choose a new folder")
    if not (scale > 0 and np.isfinite(scale)):
        raise SystemExit(f"--scale must be a positive number, got {scale}")
    if first_frame < 1:
        raise SystemExit(f"--first-frame must be >= 1, got {first_frame}")
    if every < 1:
        raise SystemExit(f"--every must be >= 1, got {every}")
    calib_path = find_calibration(project / "calibration")
    original_format = "qca" if calibration_format(calib_path) == "qualisys" else "toml"
    fmt = calibration or original_format
    binning = binning_factor(project / "Config.toml")
    rig, _ = read_calibration_file(calib_path, binning_factor=binning)
    videos = find_videos(project / "videos")
    unknown = set(drop) - set(videos) - {c.name for c in rig}
    if unknown:
        raise SystemExit(f"--drop-camera {sorted(unknown)}: no such camera (videos: "
                         f"{', '.join(videos)})")
    tmp = out.with_name(f".{out.name}.tmp")
    if tmp.exists():
        shutil.rmtree(tmp)
    try:
        _build(project, tmp, calib_path, rig, videos, scale=scale, first_frame=first_frame,
               every=every, drop=drop, fmt=fmt, original_format=original_format, binning=binning)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    tmp.rename(out)
    kept = [c.name for c in rig if c.name not in drop]
    print(f"{out}: cameras {', '.join(kept)}, scale {scale:g}, first frame {first_frame}, "
          f"every {every} frame(s), calibration {fmt}")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("project", type=Path, help="a Pose2Sim project (Config.toml, calibration/, "
                                               "videos/)")
    ap.add_argument("out", type=Path, help="the guise's folder (must not exist)")
    ap.add_argument("--scale", type=float, default=1.0, help="resize the videos by S")
    ap.add_argument("--first-frame", type=int, default=1, metavar="K",
                    help="start the videos at original frame K (1-based)")
    ap.add_argument("--every", type=int, default=1, metavar="K",
                    help="keep every K-th frame (the frame rate divided by K)")
    ap.add_argument("--drop-camera", action="append", default=[], metavar="NAME",
                    help="leave a camera out (repeatable)")
    ap.add_argument("--calibration-format", choices=("toml", "qca"),
                    help="the calibration's format (default: the original's)")
    args = ap.parse_args(argv)
    make_guise(args.project, args.out, scale=args.scale, first_frame=args.first_frame,
               every=args.every, drop=tuple(args.drop_camera), calibration=args.calibration_format)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
