"""Benchmark: a learnt plate's set-up on a real recording, its time and peak memory.

Opens a sequence without background videos (the Pose2Sim demo by default) and builds its
measurement runner with every default: the first pass's plate learnt by carving
(``measure.background.learn_plates`` over ``plate_frames`` sampled frames of every camera, then
the grid placed around the person from 20 of them). That is where a run's memory peaked while the
rig's sampled frames were held together (1.5 GB for 60 frames of four 1080 × 1920 cameras).

Prints the wall and CPU seconds, the process's peak resident memory, the package it ran and a
digest of the plates and the grid (equal digests: the same plates bit for bit). To compare two
checkouts, time this script as a whole process from each, side by side, several runs, e.g. with
``/usr/bin/time -v``, starting it inside each checkout so that ``python`` imports that checkout's
package (the script prints which it did)::

    cd CHECKOUT && python scripts/bench_plate_learning.py [--demo DIR] [--trial NAME]

Feeds docs/benchmarks.md, "Real recording (Pose2Sim demo)" (memory).
"""

from __future__ import annotations

import argparse
import hashlib
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # this checkout's package first

#: The Pose2Sim demo project beside the checkouts of this workplace (``--demo`` otherwise).
DEMO = Path("/work/p2s/x/Pose2Sim/Demo_SinglePerson")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--demo", type=Path, default=DEMO,
                        help="a project or data set whose cameras have no background video")
    parser.add_argument("--trial", default=None, help="the project's trial (default: the only)")
    args = parser.parse_args(argv)

    import numpy as np

    import voxelmocap
    from voxelmocap.config import TrackConfig
    from voxelmocap.io.sequence import open_sequence
    from voxelmocap.run.measurement import MeasurementRunner

    wall, cpu = time.perf_counter(), time.process_time()
    seq = open_sequence(args.demo, trial=args.trial)
    runner = MeasurementRunner(seq, TrackConfig(), log=None)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    if not runner.learnt_plate:
        sys.exit(f"{args.demo}: every camera has a background video: no plate is learnt")
    digest = hashlib.sha256()
    for name in seq.camera_names:
        plate = runner.backgrounds[name]
        for array in (plate.plate, plate.sigma, plate.known):
            digest.update(np.ascontiguousarray(array).tobytes())
    digest.update(np.asarray([*runner.grid.low, runner.grid.voxel_size, *runner.grid.shape],
                             float).tobytes())
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024 ** 2   # KiB → GiB
    print(f"package {Path(voxelmocap.__file__).parent}")
    print(f"{args.demo.name}: plates of {', '.join(seq.camera_names)} and grid "
          f"{tuple(runner.grid.shape)} in {wall:.1f} s wall, {cpu:.1f} s CPU; "
          f"peak RSS {peak:.2f} GiB; digest {digest.hexdigest()[:16]}")


if __name__ == "__main__":
    main()
