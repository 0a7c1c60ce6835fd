"""voxelmocap.portable: the C library's functions and sums in index order, the same bits on any CPU.

The reference for the element-wise functions is Python's ``math`` module (the same C library,
one scalar at a time), for the sums a Python loop and ``math.fsum``, for ``logsumexp``
:func:`scipy.special.logsumexp`. The last test runs a few steps of the particle filter in child
processes with NumPy's CPU-specific loops and OpenBLAS's CPU-specific kernels switched off
(``NPY_DISABLE_CPU_FEATURES``, ``OPENBLAS_CORETYPE``) and asks for the same bytes as with them.
"""

from __future__ import annotations

import math
import os
import platform
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from scipy.special import logsumexp as scipy_logsumexp

from voxelmocap import portable


@pytest.mark.parametrize("name, domain", [("exp", (-700.0, 700.0)), ("log", (1e-300, 1e300)),
                                          ("expm1", (-40.0, 700.0)), ("log1p", (-1.0, 1e6))])
def test_functions_are_the_c_librarys_bit_for_bit(name, domain):
    rng = np.random.default_rng(3)
    lo, hi = domain
    if name == "log":
        x = np.exp(rng.uniform(np.log(lo), np.log(hi), 4000))
    else:
        x = rng.uniform(lo, hi, 4000)
    x = np.concatenate([x, rng.normal(0.0, 1e-6, 200), rng.normal(0.0, 2.0, 200)])
    x = x[(x > lo) if name in ("log", "log1p") else np.ones(x.size, bool)]
    got = getattr(portable, name)(x)
    want = np.array([getattr(math, name)(float(v)) for v in x])
    assert got.dtype == np.float64 and got.shape == x.shape
    assert got.tobytes() == want.tobytes()


def test_edges_follow_numpy():
    with np.errstate(all="ignore"):
        for name in ("exp", "log", "expm1", "log1p"):
            x = np.array([0.0, -0.0, -1.0, -2.0, np.inf, -np.inf, np.nan, 1e-320])
            got = getattr(portable, name)(x)
            want = getattr(np, name)(x)
            np.testing.assert_array_equal(got, want, err_msg=name)
    assert portable.exp(np.float64(0.0)) == 1.0
    assert portable.log(2.0).shape == ()


def test_logsumexp_matches_scipy():
    rng = np.random.default_rng(4)
    a = rng.normal(0.0, 300.0, (6, 9))
    a[0, :3] = -np.inf
    a[1] = -np.inf
    for axis in (None, 0, 1):
        want = scipy_logsumexp(a, axis=axis)
        got = portable.logsumexp(a, axis=axis)
        np.testing.assert_allclose(got, want, rtol=1e-14, atol=0)
    assert portable.logsumexp(np.array([-np.inf, -np.inf])) == -np.inf
    assert portable.logsumexp(np.array([1.0, np.inf])) == np.inf
    assert np.isnan(portable.logsumexp(np.array([1.0, np.nan])))
    assert isinstance(portable.logsumexp(a), float)


def test_weighted_sum_runs_in_row_order():
    rng = np.random.default_rng(5)
    w = rng.random(301)
    x = rng.normal(0.0, 1e3, (301, 7))
    got = portable.weighted_sum(w, x)
    want = np.zeros(7)
    for p in range(301):
        want = want + w[p] * x[p]
    assert got.tobytes() == want.tobytes()
    exact = [math.fsum(w[p] * x[p, j] for p in range(301)) for j in range(7)]
    np.testing.assert_allclose(got, exact, rtol=1e-12, atol=1e-9)
    assert portable.weighted_sum(w, x[:, 2]) == got[2]
    with pytest.raises(ValueError, match="do not match"):
        portable.weighted_sum(w[:-1], x)


_WORK = textwrap.dedent("""
    import hashlib
    import numpy as np
    from voxelmocap.tracking import AnnealedParticleFilter
    from voxelmocap.tracking.truncated import truncated_normal, truncated_normal_logpdf
    from voxelmocap.measure.silhouette import GaussianBackground

    rng = np.random.default_rng(7)
    dim = 12
    low, high = -np.ones(dim) * 2.0, np.ones(dim) * 2.0
    target = rng.uniform(-1.0, 1.0, dim)
    pf = AnnealedParticleFilter(300, 4, low, high, np.full(dim, 0.2),
                                rng=np.random.default_rng(11))
    pf.initialise(np.zeros(dim), np.full(dim, 0.3))
    h = hashlib.sha256()
    for frame in range(6):
        goal = target * (1.0 + 0.05 * frame)
        est = pf.step(lambda x: -0.5 * np.sum(((x - goal) / 0.15) ** 2, axis=1))
        h.update(est.tobytes())
        h.update(np.asarray(pf.layer_betas).tobytes())
    draws = truncated_normal(rng.normal(size=2000), 0.7, -0.5, 3.0, rng)
    h.update(draws.tobytes())
    h.update(truncated_normal_logpdf(draws, 0.1, 0.7, -0.5, 3.0).tobytes())
    frames = rng.integers(0, 256, (3, 24, 32, 3)).astype(np.float32)
    bg = GaussianBackground(list(frames), [np.full((24, 32, 3), 30.0, np.float32)] * 3)
    h.update(bg.log_likelihood(rng.integers(0, 256, (24, 32, 3)).astype(np.uint8))[0].tobytes())
    # the start's geometry: landmarks to a state, a pose re-aimed at another body, a camera
    from voxelmocap.body import BodyModel, analytic_state, retarget
    from voxelmocap.camera import Camera
    model = BodyModel()
    states = model.clip(model.default_state()[None] + rng.normal(0.0, 0.4, (20, 27)))
    joints = model.forward(states).joints
    h.update(np.stack([analytic_state(model, j) for j in joints]).tobytes())
    h.update(retarget(model, BodyModel.scaled(1900.0), states).tobytes())
    K = np.array([[600.0, 0.0, 320.0], [0.0, 600.0, 240.0], [0.0, 0.0, 1.0]])
    cam = Camera.from_opencv("c", K, np.zeros(5), np.array([1.9, 0.3, -0.4]),
                             np.array([120.0, 800.0, 4200.0]))
    h.update(cam.world_to_camera(rng.normal(0.0, 1000.0, (500, 3))).tobytes())
    h.update(cam.center.tobytes())
    print(h.hexdigest())
""")


_PINS = ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")


def _digest(env_extra: dict) -> str:
    # the machine's own NumPy loops and OpenBLAS kernel unless ``env_extra`` switches them
    env = {k: v for k, v in os.environ.items() if k not in _PINS}
    out = subprocess.run([sys.executable, "-c", _WORK], env={**env, **env_extra},
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert len(out.stdout.strip()) == 64
    return out.stdout.strip()


def _numpy_dispatch() -> list[str]:
    from numpy._core import _multiarray_umath as m

    return [f for f in m.__cpu_dispatch__ if m.__cpu_features__.get(f)]


def test_the_filter_gives_the_same_bits_without_cpu_specific_code():
    """NumPy's dispatched loops (AVX2, AVX-512) and OpenBLAS's kernel for this CPU switched off
    in child processes, each in turn: the filter's estimates and β, truncated draws, a
    background's log-likelihood, states from landmarks, re-aimed poses and a camera's products
    are the same bytes as with the machine's own (a last-bit difference became another track).
    With the code before voxelmocap.portable the three digests differed on an AVX-512 EPYC."""
    variants = [{}]
    if _numpy_dispatch():
        variants.append({"NPY_DISABLE_CPU_FEATURES": " ".join(_numpy_dispatch())})
    if platform.machine() in ("x86_64", "AMD64"):
        variants.append({"OPENBLAS_CORETYPE": "Prescott"})   # SSE3 kernels: another sum order
    if len(variants) == 1:
        pytest.skip("no CPU-specific NumPy loops or OpenBLAS kernels to switch off here")
    digests = {_digest(v) for v in variants}
    assert len(digests) == 1
