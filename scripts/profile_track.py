"""Where the time of a ``voxelmocap`` command goes: CPU and wall seconds by stage and by pass.

Usage::

    python scripts/profile_track.py [--prof FILE] [--no-cprofile] [--json FILE] -- \\
        track DATA --out RUN --no-progress [track options]

The command runs in this process (``voxelmocap.cli.main``). The run's *phases*
(:data:`PHASES`: plate learning, grid placement, the start's search, multi-start and body fit,
result writing, exports; the rest is the tracked frames) and *operations* (:data:`OPERATIONS`:
decoding, silhouettes, GrabCut, plate medians, carving, surface, prefix sums, the filter, the
likelihood kernels, kinematics, limb sweeps, checkpoints …) are wrapped by timers that keep a
stack of each: a second is charged to the outermost phase and the innermost operation running
(the frames the plate reads are *plate learning / decode*; GrabCut inside a silhouette is
GrabCut's), so the rows add up to the whole command. Each is split by pass (``pass1``,
``pass2`` … the folder a pass writes to; ``final`` for the last). CPU seconds are the process's
(every thread's: numba, OpenCV, BLAS) from :func:`time.process_time` — the figure to trust on a
shared machine; wall seconds grow with the load.

The resident memory is sampled at every stage boundary (``/proc/self/statm``); the table says
in which stage the peak was reached, and the peak RSS from ``getrusage``.

By default the command also runs under :mod:`cProfile` (``--prof FILE``, default
``track.prof``; ``--no-cprofile`` to measure without its overhead, which slows Python-heavy
stages most), and the functions with the most own time are listed after the table.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import inspect
import json
import os
import resource
import sys
import threading
import time
from collections import defaultdict

try:
    from voxelmocap import cpu_paths
except ImportError:  # a checkout older than the pin (its command did not pin either)
    cpu_paths = None
if cpu_paths is not None:
    # Before NumPy loads (the stages below import it before the command's module would): the
    # NumPy loops and OpenBLAS kernels `voxelmocap track` runs with (voxelmocap.cpu_paths).
    cpu_paths.pin()

#: Phases of a run: (phase, "module:qualified.name") — every call of the function, and what it
#: calls, belongs to the phase (the outermost phase running wins: the tracker's steps inside the
#: multi-start are the multi-start's). Work outside every phase is the tracked frames' own.
PHASES = [
    ("open sequence", "voxelmocap.io.sequence:open_sequence"),
    ("plate learning", "voxelmocap.measure.background:learn_plates"),
    ("plate learning", "voxelmocap.measure.background:plates_from_covers"),
    ("plate learning", "voxelmocap.pose.body_cover:plate_covers_of"),
    ("plate learning", "voxelmocap.io.synchronised:FramesByCamera.__getitem__"),
    ("grid placement", "voxelmocap.run.measurement:person_grid"),
    ("start: search", "voxelmocap.pose.tracker:BodyTracker.initial_state"),
    ("start: continued (arms)", "voxelmocap.pose.tracker:BodyTracker.searched_starts"),
    ("start: multi-start", "voxelmocap.pose.multistart:MultiStart.step"),
    ("start: multi-start", "voxelmocap.pose.multistart:MultiStart.finish"),
    ("start: body fit", "voxelmocap.pose.body_size:refit_start"),
    ("start: body size", "voxelmocap.run.bodies:voxel_height"),
    ("result writing", "voxelmocap.io.results:ResultWriter.append"),
    ("exports", "voxelmocap.run.outputs:write_exports"),
    ("exports", "voxelmocap.run.outputs:landmark_exports"),
]
#: Operations: (operation, "module:qualified.name") — the innermost operation running is charged
#: (the GrabCut of a silhouette is GrabCut's, not the silhouette's). Generator functions are
#: timed per item they yield.
OPERATIONS = [
    ("decode", "voxelmocap.io.video:VideoStream.read"),
    ("decode", "voxelmocap.io.video:VideoStream.__init__"),
    ("voxel tables", "voxelmocap.measure.carving:Carver.__init__"),
    ("silhouettes", "voxelmocap.measure.stage:MeasurementStage.masks"),
    ("silhouettes", "voxelmocap.measure.plate:PlateBackground.foreground"),
    ("GrabCut", "voxelmocap.measure.plate:PlateBackground.refine"),
    ("plate medians", "voxelmocap.measure.plate:masked_median"),
    ("carving", "voxelmocap.measure.stage:MeasurementStage.carve"),
    ("carving", "voxelmocap.measure.carving:Carver.carve_with_holes"),
    ("surface + smoothing", "voxelmocap.measure.observation:VoxelObservation.__init__"),
    ("prefix sums", "voxelmocap.measure.observation:VoxelObservation.prefix"),
    ("filter step", "voxelmocap.pose.tracker:BodyTracker.step"),
    ("recovery", "voxelmocap.pose.tracker:BodyTracker.observe"),
    ("limb sweeps", "voxelmocap.pose.limb_search:sweep_limbs"),
    ("image cues: frame preparation", "voxelmocap.score.cues.fusion:CueSet.prepare"),
    ("image cues: projection", "voxelmocap.score.cues.terms:Views.__init__"),
    ("image cues: silhouette", "voxelmocap.score.cues.terms:SilhouetteCue.__call__"),
    ("likelihood", "voxelmocap.score.likelihood:counts_of"),
    ("likelihood", "voxelmocap.score.partial:PartialScorer.counts"),
    ("likelihood", "voxelmocap.score.partial:PartialScorer.__init__"),
    ("kinematics", "voxelmocap.body.model:BodyModel.geometry"),
    ("kinematics", "voxelmocap.body.model:BodyModel.forward"),
    ("checkpoints", "voxelmocap.pose.tracker:BodyTracker.get_state"),
    ("checkpoints", "voxelmocap.pose.tracker:BodyTracker.set_state"),
]
#: The phase of work outside every :data:`PHASES` entry: the tracked frames.
FRAMES = "tracked frames"


def _statm_rss() -> int:
    """Resident set size now (bytes)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except OSError:
        return 0


class StageClock:
    """Exclusive CPU and wall seconds per (pass, phase, operation), kept with two stacks.

    The measurement hands pieces of work to a few threads (:mod:`voxelmocap.measure.threads`).
    A worker keeps its own operation stack and charges its own CPU seconds
    (:func:`time.thread_time`) to the main thread's pass and phase and its innermost operation
    (or, with none, the main thread's); those seconds are taken off what the main thread
    charges next, since the process's CPU time counts every thread. Wall seconds are the main
    thread's only.
    """

    def __init__(self):
        self.cpu = defaultdict(float)
        self.wall = defaultdict(float)
        self.calls = defaultdict(int)
        self.phases: list[str] = []
        self.ops: list[str] = []
        self.pass_name = "setup"
        self.t_cpu, self.t_wall = time.process_time(), time.perf_counter()
        self.peak = (0, "")
        self._lock = threading.Lock()
        self._workers = threading.local()
        self._offloaded = 0.0                  # worker CPU charged since the main's last charge

    def key(self, ops=None):
        ops = self.ops if ops is None else (ops or self.ops)
        return (self.pass_name, self.phases[0] if self.phases else FRAMES,
                ops[-1] if ops else "")

    def _charge(self):
        if threading.current_thread() is not threading.main_thread():
            return self._charge_worker()
        c, w = time.process_time(), time.perf_counter()
        key = self.key()
        with self._lock:
            self.cpu[key] += c - self.t_cpu - self._offloaded
            self._offloaded = 0.0
        self.wall[key] += w - self.t_wall
        self.t_cpu, self.t_wall = c, w
        rss = _statm_rss()
        if rss > self.peak[0]:
            self.peak = (rss, " / ".join(k for k in key if k))

    def _worker_ops(self) -> list:
        if not hasattr(self._workers, "ops"):
            self._workers.ops, self._workers.t = [], time.thread_time()
        return self._workers.ops

    def worker_begin(self):
        """A worker starts a piece of work: its CPU from here on is charged (earlier seconds,
        the pool's own, stay with the main thread's count)."""
        self._worker_ops()
        self._workers.t = time.thread_time()

    def _charge_worker(self):
        ops = self._worker_ops()
        c = time.thread_time()
        with self._lock:
            self.cpu[self.key(ops)] += c - self._workers.t
            self._offloaded += c - self._workers.t
        self._workers.t = c

    def enter(self, kind, name):
        self._charge()
        if threading.current_thread() is not threading.main_thread():
            if kind == "op":
                self._worker_ops().append(name)
            return
        (self.phases if kind == "phase" else self.ops).append(name)
        self.calls[self.key()] += 1

    def leave(self, kind):
        self._charge()
        if threading.current_thread() is not threading.main_thread():
            if kind == "op":
                self._worker_ops().pop()
            return
        (self.phases if kind == "phase" else self.ops).pop()

    def set_pass(self, name):
        self._charge()
        self.pass_name = name


CLOCK = StageClock()


def _timed(kind, name, fn):
    if inspect.isgeneratorfunction(fn):
        @functools.wraps(fn)
        def gen_wrapper(*args, **kwargs):
            gen = fn(*args, **kwargs)
            while True:
                CLOCK.enter(kind, name)
                try:
                    item = next(gen)
                except StopIteration:
                    return
                finally:
                    CLOCK.leave(kind)
                yield item
        return gen_wrapper

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        CLOCK.enter(kind, name)
        try:
            return fn(*args, **kwargs)
        finally:
            CLOCK.leave(kind)
    return wrapper


def install() -> None:
    """Wrap every :data:`PHASES` and :data:`OPERATIONS` entry (and the pass loop) in the clock."""
    import pkgutil

    import voxelmocap

    for info in pkgutil.walk_packages(voxelmocap.__path__, "voxelmocap."):
        if not info.name.rsplit(".", 1)[-1].startswith("_"):
            importlib.import_module(info.name)
    modules = [m for n, m in list(sys.modules.items()) if n.startswith("voxelmocap")]
    entries = [("phase", *e) for e in PHASES] + [("op", *e) for e in OPERATIONS]
    for kind, name, where in entries:
        mod_name, qual = where.split(":")
        owner = importlib.import_module(mod_name)
        *path, attr = qual.split(".")
        for part in path:
            owner = getattr(owner, part)
        original = inspect.getattr_static(owner, attr)
        if isinstance(original, functools.cached_property):
            original.func = _timed(kind, name, original.func)
            continue
        if isinstance(original, staticmethod):
            setattr(owner, attr, staticmethod(_timed(kind, name, original.__func__)))
            continue
        wrapped = _timed(kind, name, original)
        setattr(owner, attr, wrapped)
        if not path:  # a module-level function: also where it was imported by name
            for m in modules:
                for key, value in list(vars(m).items()):
                    if value is original:
                        setattr(m, key, wrapped)

    from voxelmocap.run import frame_loop

    run = frame_loop.PassRun.run

    @functools.wraps(run)
    def pass_run(self, *args, **kwargs):
        CLOCK.set_pass(self.folder.rsplit("/", 1)[-1] if self.folder else "final")
        try:
            return run(self, *args, **kwargs)
        finally:
            CLOCK.set_pass("after")

    frame_loop.PassRun.run = pass_run

    from voxelmocap.measure import threads

    item = threads._as_worker

    def as_worker(fn, x):
        CLOCK.worker_begin()
        try:
            return item(fn, x)
        finally:
            CLOCK._charge()

    threads._as_worker = as_worker


def table(clock: StageClock, min_cpu: float = 0.05) -> str:
    """Phase / operation × pass (CPU s, wall s in parentheses), phases by CPU, then totals.

    Rows under ``min_cpu`` CPU seconds in total are folded into their phase's "other" row."""
    passes = []
    for p, _, _ in clock.cpu:
        if p not in passes:
            passes.append(p)
    cells = defaultdict(lambda: [0.0, 0.0])
    for (p, ph, op), c in clock.cpu.items():
        cells[(ph, op, p)][0] += c
        cells[(ph, op, p)][1] += clock.wall[(p, ph, op)]
    rows = defaultdict(float)
    for (ph, op, _), (c, _) in cells.items():
        rows[(ph, op)] += c
    folded = defaultdict(lambda: [0.0, 0.0])
    for (ph, op, p), (c, w) in cells.items():
        label = op if (rows[(ph, op)] >= min_cpu and op) else ("(own)" if not op or
                                                                rows[(ph, op)] >= min_cpu
                                                                else "(other)")
        folded[(ph, label, p)][0] += c
        folded[(ph, label, p)][1] += w
    phase_cpu = defaultdict(float)
    for (ph, _, _), (c, _) in folded.items():
        phase_cpu[ph] += c
    width = 34
    head = f"{'phase / operation':{width}s}" + "".join(f"{p:>16s}" for p in passes) \
        + f"{'total':>16s}"
    lines = [head, "-" * len(head)]

    def cell(c, w):
        return f"{c:8.1f} ({w:5.0f})"

    for ph in sorted(phase_cpu, key=lambda k: -phase_cpu[k]):
        labels = {lab for (q, lab, _) in folded if q == ph}
        tot = {p: [sum(folded[(ph, lab, p)][i] for lab in labels if (ph, lab, p) in folded)
                   for i in (0, 1)] for p in passes}
        lines.append(f"{ph:{width}s}" + "".join(cell(*tot[p]) if any(tot[p]) else " " * 16
                                                for p in passes)
                     + cell(sum(t[0] for t in tot.values()), sum(t[1] for t in tot.values())))
        by_cpu = sorted(labels, key=lambda lab: -sum(folded[(ph, lab, p)][0] for p in passes
                                                     if (ph, lab, p) in folded))
        if len(by_cpu) > 1 or by_cpu[0] != "(own)":
            for lab in by_cpu:
                row = f"{'  ' + lab:{width}s}"
                for p in passes:
                    row += cell(*folded[(ph, lab, p)]) if (ph, lab, p) in folded else " " * 16
                c = sum(folded[(ph, lab, p)][0] for p in passes if (ph, lab, p) in folded)
                w = sum(folded[(ph, lab, p)][1] for p in passes if (ph, lab, p) in folded)
                lines.append(row + cell(c, w))
    lines.append("-" * len(head))
    ops = defaultdict(lambda: [0.0, 0.0])
    for (p, _, op), c in clock.cpu.items():
        ops[op or "(phases' own code)"][0] += c
        ops[op or "(phases' own code)"][1] += clock.wall[(p, _, op)]
    row = f"{'total':{width}s}"
    for p in passes:
        row += cell(sum(v for (q, _, _), v in clock.cpu.items() if q == p),
                    sum(v for (q, _, _), v in clock.wall.items() if q == p))
    lines.append(row + cell(sum(clock.cpu.values()), sum(clock.wall.values())))
    lines.append("")
    lines.append("by operation, all phases and passes (CPU s, wall s):")
    for op in sorted(ops, key=lambda k: -ops[k][0]):
        lines.append(f"  {op:{width - 2}s}{cell(*ops[op])}")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--prof", default="track.prof", help="cProfile statistics file")
    parser.add_argument("--no-cprofile", action="store_true", help="run without cProfile")
    parser.add_argument("--json", help="also write the table's numbers to this JSON file")
    parser.add_argument("--top", type=int, default=25, help="cProfile functions listed")
    parser.add_argument("command", nargs=argparse.REMAINDER,
                        help="the voxelmocap command line, after --")
    args = parser.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("give the voxelmocap command after --")
    from voxelmocap.cli import main as cli_main

    install()
    load = os.getloadavg()
    t0_cpu, t0_wall = time.process_time(), time.perf_counter()
    CLOCK.t_cpu, CLOCK.t_wall = t0_cpu, t0_wall
    if args.no_cprofile:
        status = cli_main(command)
    else:
        import cProfile

        # CPU seconds of the whole process (every thread), like the table
        profiler = cProfile.Profile(time.process_time)
        status = profiler.runcall(cli_main, command)
        profiler.dump_stats(args.prof)
    CLOCK.set_pass("after")
    cpu, wall = time.process_time() - t0_cpu, time.perf_counter() - t0_wall
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print()
    print(f"command: voxelmocap {' '.join(command)}")
    print(f"exit status {status}; {cpu:.1f} s CPU, {wall:.1f} s wall "
          f"({'no cProfile' if args.no_cprofile else 'under cProfile'}); load average at the "
          f"start {load[0]:.1f}, at the end {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"peak RSS {peak / 2**30:.2f} GiB (largest RSS sampled at a stage boundary "
          f"{CLOCK.peak[0] / 2**30:.2f} GiB, in {CLOCK.peak[1]})")
    print("CPU seconds by phase and operation and by pass (wall seconds in parentheses); a "
          "second counts for the outermost phase and the innermost operation running")
    print(table(CLOCK))
    if not args.no_cprofile:
        import pstats

        print(f"\ncProfile ({args.prof}): the {args.top} functions with the most own time")
        pstats.Stats(args.prof).sort_stats("tottime").print_stats(args.top)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"command": command, "cpu": cpu, "wall": wall, "peak_rss": peak,
                       "load": load, "cprofile": not args.no_cprofile,
                       "rows": [{"pass": p, "phase": ph, "operation": op, "cpu": c,
                                 "wall": CLOCK.wall[(p, ph, op)],
                                 "calls": CLOCK.calls[(p, ph, op)]}
                                for (p, ph, op), c in CLOCK.cpu.items()]}, f, indent=1)
    return int(status or 0)


if __name__ == "__main__":
    sys.exit(main())
