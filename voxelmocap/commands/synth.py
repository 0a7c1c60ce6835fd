"""``voxelmocap synth OUT``: render a synthetic HumanEva-I sequence with exact ground truth."""

from __future__ import annotations

import argparse
import logging

logger = logging.getLogger(__name__)


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "synth",
        help="render a synthetic HumanEva-format sequence (procedural motion or a BVH clip)",
        description="Render a motion (built-in walk/jog/box/gestures/throwcatch, a BVH file of "
                    "a supported skeleton or a CMU AMC file) into every camera of a rig, over a "
                    "textured room with "
                    "a soft floor shadow, sensor noise and flicker, and write it in the "
                    "HumanEva-I layout: .cal, .avi, .ofs (different lead per camera), background "
                    "videos, body_pose XML ground truth and <Subject>_body.toml.",
    )
    parser.add_argument("out", help="data set root to write (created if needed)")
    parser.add_argument("--motion", default="walk",
                        help="walk, jog, box, gestures, throwcatch, PATH.bvh or PATH.amc (its .asf "
                             "beside it; default walk)")
    parser.add_argument("--subject", default="S1", help="subject name (default S1)")
    parser.add_argument("--action", default=None,
                        help="HumanEva action name (default from the motion, Combo for BVH)")
    parser.add_argument("--trial", type=int, default=1, help="trial number (default 1)")
    parser.add_argument("--frames", type=int, default=100,
                        help="synchronised frames with ground truth (default 100)")
    parser.add_argument("--rig", default=None,
                        help="calibration folder of .cal files (default: packaged humaneva_i_like)")
    parser.add_argument("--cameras", default=None,
                        help="comma-separated subset of the rig's cameras (default all)")
    parser.add_argument("--fps", type=float, default=60.0, help="video frame rate (default 60)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--noise", type=float, default=1.0,
                        help="sensor noise and flicker scale; 1 = σ 2 grey levels (default 1)")
    parser.add_argument("--start", type=float, default=0.0,
                        help="start time in the BVH clip, seconds (default 0)")
    parser.add_argument("--heading", type=float, default=0.0, metavar="DEG",
                        help="turn the motion by DEG degrees about the vertical through the "
                             "pelvis at frame 1, counter-clockwise seen from above, before "
                             "rendering; the ground truth is the turned motion's (default 0)")
    parser.add_argument("--unit", default="auto",
                        help="BVH length unit: auto, mm, cm, m, inch, cmu or mm per unit")
    parser.add_argument("--codec", default="MJPG", choices=["MJPG", "FFV1", "XVID", "HFYU"],
                        help="video codec (default MJPG; FFV1 and HFYU are lossless)")
    parser.add_argument("--masks", action="store_true",
                        help="also write noise-free person masks to <Subject>/Mask_Data/")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing sequence of the same subject/action/trial")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..io._outputs import check_output_dir
    from ..synth import generate

    check_output_dir(args.out)

    unit = args.unit
    try:
        unit = float(unit)
    except ValueError:
        pass
    cameras = [c.strip() for c in args.cameras.split(",") if c.strip()] if args.cameras else None
    try:
        root = generate(args.out, motion=args.motion, frames=args.frames, subject=args.subject,
                        action=args.action, trial=args.trial, rig=args.rig, fps=args.fps,
                        seed=args.seed, noise=args.noise, cameras=cameras,
                        progress=not args.no_progress, render_masks=args.masks,
                        codec=args.codec, start=args.start, unit=unit, overwrite=args.overwrite,
                        heading_deg=args.heading)
    except OSError as exc:  # e.g. the disk filled up or the folder turned read-only mid-way
        raise InputError(args.out, f"cannot write the data set ({exc.strerror or exc})") from None
    logger.info("wrote %s", root)
    return 0
