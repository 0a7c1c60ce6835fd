"""A clip where the person leaves every camera's view for some frames and comes back.

Renders a ``../shared/mocap`` clip (never ``holdout/``) with :func:`voxelmocap.synth.generate`
(7 cameras of the ``humaneva_i_like`` rig, 60 fps), except that during the absent frames the whole
body is moved ``--offset-mm`` away horizontally: out of the room the synthetic scene builds
around the cameras, so the walls hide it from every camera (as a person who walked out through
a door). The motion itself goes on while the person is away, so they come back 15 frames later
in the clip, in another pose and place than where they left. The ground truth (body_pose XML)
holds the true, far-away positions of those frames; ``absence.json`` beside the subject folders
names the absent frames.

Walking out of the capture volume takes seconds, not 15 frames, at any real speed; the jump
keeps the clip short while giving the tracker what it sees when someone leaves and returns:
frames without a person, then a person in an unexpected pose.

Usage::

    python scripts/make_absence_clip.py OUT [--motion PATH.bvh] [--start 2.0] [--frames 100] \\
        [--absent 41:55] [--offset-mm 30000] [--subject S1] [--action Walking]

Feeds docs/benchmarks.md, "Recovery" (the absence clip; ``bench_recovery.py --absence`` makes it when
missing).
"""

from __future__ import annotations

import argparse
import contextlib
import json
from pathlib import Path

import numpy as np

MOCAP = Path(__file__).resolve().parents[1].parent / "shared" / "mocap"


@contextlib.contextmanager
def _away(first: int, last: int, frames: int, offset_mm: float):
    """Make ``generate`` place synchronised frames ``first..last`` ``offset_mm`` away (+X).

    ``generate`` places the motion with ``writer.place_in_area`` over the camera-lead frames and
    the ``frames`` synchronised ones (the leads first), so synchronised frame F is row
    ``F - 1 + lead``.
    """
    from voxelmocap.synth import writer

    original = writer.place_in_area

    def placed(points, fps, **kwargs):
        out = original(points, fps, **kwargs)
        lead = len(out) - frames
        out[lead + first - 1:lead + last, :, 0] += offset_mm
        return out

    writer.place_in_area = placed
    try:
        yield
    finally:
        writer.place_in_area = original


def make_absence_clip(out, *, motion: str | None = None, start: float = 2.0, frames: int = 100,
                      absent: tuple[int, int] = (41, 55), offset_mm: float = 30000.0,
                      subject: str = "S1", action: str = "Walking", seed: int = 0,
                      progress: bool = True, cameras=None) -> dict:
    """Render the clip into ``out`` (a HumanEva-layout data set); returns ``absence.json``'s dict."""
    from voxelmocap.synth import generate

    out = Path(out)
    motion = motion or str(MOCAP / "05_01.bvh")
    first, last = (int(v) for v in absent)
    if not 1 < first <= last < frames:
        raise SystemExit(f"--absent {first}:{last} must lie inside 2..{frames - 1}")
    with _away(first, last, frames, offset_mm):
        generate(out, motion=motion, frames=frames, subject=subject, action=action, start=start,
                 seed=seed, progress=progress, cameras=cameras)
    info = {"subject": subject, "sequence": f"{action}_1", "absent": [first, last],
            "offset_mm": offset_mm, "motion": Path(motion).name, "start_s": start,
            "frames": frames}
    (out / "absence.json").write_text(json.dumps(info, indent=1) + "\n")
    return info


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="data set root to write")
    parser.add_argument("--motion", default=None, help="BVH clip (default ../shared/mocap/05_01)")
    parser.add_argument("--start", type=float, default=2.0, help="start time in the clip (s)")
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--absent", default="41:55", help="first:last absent frame (inclusive)")
    parser.add_argument("--offset-mm", type=float, default=30000.0)
    parser.add_argument("--subject", default="S1")
    parser.add_argument("--action", default="Walking")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.motion is None and not MOCAP.is_dir():
        raise SystemExit(f"{MOCAP} is not available")
    if "holdout" in Path(args.motion or "").parts:
        raise SystemExit("the holdout clips are not for development")
    first, last = (int(v) for v in args.absent.split(":"))
    info = make_absence_clip(args.out, motion=args.motion, start=args.start, frames=args.frames,
                             absent=(first, last), offset_mm=args.offset_mm,
                             subject=args.subject, action=args.action, seed=args.seed)
    print(f"wrote {args.out}: {info['subject']}/{info['sequence']}, absent frames "
          f"{first}–{last} ({last - first + 1}); {np.int64(args.frames)} frames")


if __name__ == "__main__":
    main()
