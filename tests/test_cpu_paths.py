"""voxelmocap.cpu_paths: NumPy's AVX-512 loops and OpenBLAS's kernel pinned before NumPy loads."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import pytest

from voxelmocap import cpu_paths

X86 = platform.machine().lower() in ("x86_64", "amd64")


@pytest.fixture
def on_x86(monkeypatch):
    monkeypatch.setattr(cpu_paths.platform, "machine", lambda: "x86_64")


def test_pins_numpy_and_openblas_on_an_avx2_machine(on_x86):
    env = {}
    done = cpu_paths.pin(env, flags={"sse4_2", "avx", "avx2", "fma"})
    assert env == done
    assert env["OPENBLAS_CORETYPE"] == "Haswell"
    assert set(env["NPY_DISABLE_CPU_FEATURES"].split()) == set(cpu_paths.avx512_groups())
    assert "X86_V3" not in env["NPY_DISABLE_CPU_FEATURES"].split()   # AVX2 loops stay


def test_the_names_follow_the_numpy_version():
    assert cpu_paths.avx512_groups("2.4.6") == ("X86_V4", "AVX512_ICL", "AVX512_SPR")
    assert "AVX512_SKX" in cpu_paths.avx512_groups("1.26.4")
    assert "AVX512_SKX" in cpu_paths.avx512_groups("2.3.1")
    assert cpu_paths.avx512_groups("dev") == cpu_paths.AVX512_GROUPS


@pytest.mark.skipif(not X86, reason="the pins are for x86-64")
def test_numpy_loads_under_warnings_as_errors():
    """Every name pinned is one the installed NumPy knows: an unknown one is an ImportWarning,
    which ``-W error`` turns into a failed import (of the command and of its Dask workers)."""
    env = {**os.environ, "NPY_DISABLE_CPU_FEATURES": " ".join(cpu_paths.avx512_groups())}
    out = subprocess.run([sys.executable, "-W", "error", "-c", "import numpy"], env=env,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-1000:]


def test_a_users_setting_wins_and_old_cpus_keep_their_blas(on_x86):
    env = {"OPENBLAS_CORETYPE": "SkylakeX"}
    done = cpu_paths.pin(env, flags={"avx2", "fma"})
    assert env["OPENBLAS_CORETYPE"] == "SkylakeX" and "OPENBLAS_CORETYPE" not in done
    env = {}
    cpu_paths.pin(env, flags={"sse4_2", "avx"})          # no AVX2: Haswell kernels would not run
    assert "OPENBLAS_CORETYPE" not in env and "NPY_DISABLE_CPU_FEATURES" in env


def test_nothing_off_x86_or_once_numpy_is_loaded(monkeypatch):
    monkeypatch.setattr(cpu_paths.platform, "machine", lambda: "aarch64")
    env = {}
    assert cpu_paths.pin(env, flags={"avx2", "fma"}) == {} and env == {}
    monkeypatch.setattr(cpu_paths.platform, "machine", lambda: "x86_64")
    assert "numpy" in sys.modules
    assert cpu_paths.pin() == {}          # os.environ untouched: too late for this process


@pytest.mark.skipif(not X86, reason="the pins are for x86-64")
def test_the_command_pins_before_numpy_loads():
    """A fresh process that imports the command's module first runs NumPy without its AVX-512
    loops (whatever this CPU has) and names the variables it set; numpy's own report agrees."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")}
    code = ("import voxelmocap.cli as c; from numpy._core import _multiarray_umath as m; "
            "print(sorted(c.PINNED)); "
            "print([k for k in m.__cpu_dispatch__ if m.__cpu_features__.get(k) and "
            "('512' in k or k == 'X86_V4')])")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    pinned, avx512_on = out.stdout.strip().splitlines()
    assert "NPY_DISABLE_CPU_FEATURES" in pinned
    assert avx512_on == "[]"
