"""``voxelmocap view``: look at one frame of a voxel dump.

With a display (``DISPLAY`` / ``WAYLAND_DISPLAY`` set) and without ``--png`` it opens an Open3D
window on the occupied voxels. Otherwise (headless machines, ``--png``) it writes a PNG: front
(x–z), side (y–z) and top (x–y) depth-shaded orthographic views of the volume, and beside them each
camera's silhouette (when the dump holds masks) with the occupied voxel centres projected on it.
"""

from __future__ import annotations

import argparse
import logging

logger = logging.getLogger(__name__)

VOLUMES = ("occupancy", "surface", "smoothed")


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "view",
        help="show one frame of a voxel dump (Open3D window, or PNG views when headless)",
        description="Open an Open3D window on one frame of a voxel dump written by "
                    "'voxelmocap dump', or write PNG views (front, side, top, silhouettes) when "
                    "there is no display or --png is given.",
    )
    parser.add_argument("dump", help="the HDF5 voxel dump (from 'voxelmocap dump')")
    parser.add_argument("--frame", type=int, help="synchronised frame number (default: the first)")
    parser.add_argument("--volume", choices=VOLUMES, default="occupancy",
                        help="what to show (smoothed: voxels with Ṽ^S > 0.5)")
    parser.add_argument("--png", action="store_true", help="write PNG views even with a display")
    parser.add_argument("--out", metavar="DIR_OR_PNG",
                        help="folder (created if needed) receiving <dump>_frame<F>.png, or a "
                             "file name ending in .png (default: beside the dump)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..run.inspection import view_dump

    outcome = view_dump(args.dump, frame=args.frame, volume=args.volume, out=args.out,
                        window=False if args.png else None)
    if outcome.message:
        logger.info(outcome.message)
    if outcome.png is not None:
        logger.info("wrote %s", outcome.png)
    return 0
