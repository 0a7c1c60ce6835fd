"""``voxelmocap overlay RUN --dataset DATASET --camera C1|all``: tracked cones over the camera images."""

from __future__ import annotations

import argparse
import logging

from ..logs import NO_PROGRESS_HELP

logger = logging.getLogger(__name__)


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "overlay",
        help="draw the tracked cones and landmarks (and the ground truth) over a camera's images",
        description="Writes a video of one camera's frames with the tracked body model (coloured "
                    "cone outlines), its landmarks (red) and the ground-truth landmarks (green) "
                    "when the data set has them: H.264 at the data's frame rate (.mp4), which "
                    "browsers and slide software play.",
    )
    parser.add_argument("run_dir", metavar="RUN", help="run folder written by 'voxelmocap track'")
    parser.add_argument("--dataset", required=True, help="the data set that was tracked")
    parser.add_argument("--camera", default="C1",
                        help="camera name, or 'all' for every camera side by side in one video "
                             "(default C1)")
    parser.add_argument("--subject", help="subject (default: the only one in RUN)")
    parser.add_argument("--sequence", help="sequence (default: the only one in RUN)")
    parser.add_argument("--out", help="output video: .mp4, .mov or .mkv (H.264, plays in "
                                      "browsers and slide software) or .avi (Motion-JPEG); "
                                      "default RUN/<Subject>/<Action>_<Trial>_(<CAM>)_overlay.mp4")
    parser.add_argument("--fps", type=float,
                        help="video frame rate (default: the data's, as the result file "
                             "records it: the video plays in real time)")
    parser.add_argument("--no-progress", action="store_true", help=NO_PROGRESS_HELP)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..run.inspection import overlay_video

    out = overlay_video(args.run_dir, args.dataset, camera=args.camera, subject=args.subject,
                        sequence=args.sequence, out=args.out, fps=args.fps,
                        progress=not args.no_progress)
    logger.info("overlay: %s", out)
    return 0
