"""``voxelmocap overlay RUN --dataset DATASET --camera C1``: tracked cones over the camera images."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "overlay",
        help="draw the tracked cones and landmarks (and the ground truth) over a camera's images",
        description="Writes a video of one camera's frames with the tracked body model (coloured "
                    "cone outlines), its landmarks (red) and the ground-truth landmarks (green) "
                    "when the data set has them.",
    )
    parser.add_argument("run_dir", metavar="RUN", help="run folder written by 'voxelmocap track'")
    parser.add_argument("--dataset", required=True, help="the data set that was tracked")
    parser.add_argument("--camera", default="C1", help="camera name (default C1)")
    parser.add_argument("--subject", help="subject (default: the only one in RUN)")
    parser.add_argument("--sequence", help="sequence (default: the only one in RUN)")
    parser.add_argument("--out", help="output video (.mp4 or .avi; default "
                                      "RUN/<Subject>/<Action>_<Trial>_(<CAM>)_overlay.mp4)")
    parser.add_argument("--fps", type=float, default=30.0, help="video frame rate (default 30)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import cv2
    import numpy as np
    from tqdm.auto import tqdm

    from ..errors import InputError
    from ..io._atomic import atomic_path
    from ..io.humaneva import Dataset
    from ..io.reports import find_result_files
    from ..io.results import read_result
    from ..joints import endpoints_to_landmarks
    from ..pipeline import body_model_for
    from ..viz.overlay import draw_landmarks, draw_pose

    files = [p for p in find_result_files(args.run_dir) if p.suffix == ".h5"
             and (args.subject is None or p.parent.name.lower() == args.subject.lower())
             and (args.sequence is None or p.stem.lower() == args.sequence.lower())]
    if len(files) != 1:
        raise InputError(args.run_dir, f"{len(files)} matching result files; choose one with "
                                       "--subject and --sequence")
    path = files[0]
    result = read_result(path)
    seq = Dataset(args.dataset).sequence(path.parent.name, path.stem, cameras=[args.camera])
    camera = seq.rig[args.camera]
    gt = seq.ground_truth()
    model, _ = body_model_for(seq, gt)
    out = Path(args.out) if args.out else path.with_name(f"{path.stem}_({camera.name})_overlay.mp4")
    fourcc = "MJPG" if out.suffix.lower() == ".avi" else "mp4v"
    rows = {int(f): i for i, f in enumerate(result.frames)}
    with atomic_path(out) as tmp:
        writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*fourcc), args.fps,
                                 tuple(camera.size))
        if not writer.isOpened():
            raise InputError(out, f"OpenCV cannot write this video format ({fourcc})")
        try:
            for frame, images in tqdm(seq.frames(result.frames), total=len(result.frames),
                                      desc="overlay", unit="frame"):
                image = images[camera.name]
                image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
                i = rows[int(frame)]
                draw_pose(image, camera, model, result.state[i])
                if gt is not None:
                    g = int(gt.index_of([frame])[0])
                    if g >= 0:
                        draw_landmarks(image, camera, endpoints_to_landmarks(gt.endpoints[g]),
                                       (0, 220, 0))
                draw_landmarks(image, camera, result.landmarks[i], (0, 0, 255))
                cv2.putText(image, f"{seq.subject} {seq.name} {camera.name} F={frame}", (8, 18),
                            cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
                writer.write(np.ascontiguousarray(image))
        finally:
            writer.release()
    print(f"overlay: {out}")
    return 0
