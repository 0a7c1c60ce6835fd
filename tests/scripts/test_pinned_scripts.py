"""The scripts that track do it on the CPU paths ``voxelmocap track`` pins (``voxelmocap.cpu_paths``).

Unpinned, the same renders tracked by ``bench_facing.py`` on an Intel and an AMD AVX-512 server
gave runs millimetres apart (NumPy's AVX-512 loops and OpenBLAS's kernels differ by CPU), so a
benchmark's figures were the machine's, not the command's.
"""

from __future__ import annotations

import ast
import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"
#: What running a tracker in the script's own process looks like.
TRACKING = ("track_sequence", "BodyTracker")
#: Imports that load NumPy (directly or through the package or a sibling script).
HEAVY = ("numpy", "cv2", "scipy", "voxelmocap", "bench_", "make_")


def tracking_scripts() -> list[Path]:
    return sorted(p for p in SCRIPTS.glob("*.py")
                  if any(name in p.read_text(encoding="utf-8") for name in TRACKING))


def _pin_line(tree: ast.Module) -> int | None:
    """Line of the module-level ``cpu_paths.pin()`` (also inside a top-level ``if``)."""
    for node in ast.walk(tree):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                and node.func.attr == "pin" and isinstance(node.func.value, ast.Name)
                and node.func.value.id == "cpu_paths"):
            return node.lineno
    return None


def _first_heavy_import(tree: ast.Module) -> int | None:
    """Line of the first module-level import that loads NumPy."""
    for node in tree.body:
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            if node.module == "voxelmocap" and [a.name for a in node.names] == ["cpu_paths"]:
                continue            # the pin's own module imports nothing but the stdlib
            names = [node.module]
        else:
            continue
        if any(n.startswith(h) for n in names for h in HEAVY):
            return node.lineno
    return None


def test_the_tracking_scripts_are_found():
    names = {p.stem for p in tracking_scripts()}
    assert {"bench_facing", "bench_accuracy", "bench_tracking", "profile_track"} <= names


@pytest.mark.parametrize("script", tracking_scripts(), ids=lambda p: p.stem)
def test_a_tracking_script_pins_before_numpy_loads(script):
    tree = ast.parse(script.read_text(encoding="utf-8"))
    pin = _pin_line(tree)
    assert pin is not None, f"{script.name} tracks without cpu_paths.pin()"
    heavy = _first_heavy_import(tree)
    assert heavy is None or pin < heavy, \
        f"{script.name}: line {heavy} loads NumPy before cpu_paths.pin() (line {pin})"


def test_the_finder_sees_a_late_pin():
    """The check above fails a script that imports NumPy first (not a test that cannot fail)."""
    late = ast.parse("from voxelmocap import cpu_paths\nimport numpy as np\ncpu_paths.pin()\n")
    assert _first_heavy_import(late) == 2 and _pin_line(late) == 3
    sibling = ast.parse("import sys\nfrom bench_accuracy import CLIPS\n")
    assert _first_heavy_import(sibling) == 2 and _pin_line(sibling) is None


@pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64"),
                    reason="the pins are for x86-64")
def test_bench_facing_runs_numpy_without_its_avx512_loops():
    """A fresh interpreter that loads the script (as its spawned workers do) has NumPy's AVX-512
    loops off whatever this CPU has: numpy's own report."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")}
    code = ("import importlib.util, sys; sys.path.insert(0, sys.argv[1]); "
            "spec = importlib.util.spec_from_file_location('bench_facing', "
            "sys.argv[1] + '/bench_facing.py'); m = importlib.util.module_from_spec(spec); "
            "spec.loader.exec_module(m); "
            "from numpy._core import _multiarray_umath as u; import os; "
            "print(os.environ.get('NPY_DISABLE_CPU_FEATURES', '')); "
            "print([k for k in u.__cpu_dispatch__ if u.__cpu_features__.get(k) and "
            "('512' in k or k == 'X86_V4')])")
    out = subprocess.run([sys.executable, "-c", code, str(SCRIPTS)], env=env,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    disabled, avx512_on = out.stdout.strip().splitlines()[-2:]
    assert "AVX512" in disabled or "X86_V4" in disabled
    assert avx512_on == "[]"
