#!/usr/bin/env python
"""Fontmarty et al.'s filter comparison (paper 004 §IV-B, Fig. 4) on a linear-Gaussian system.

A ``D``-dimensional random walk ``x_k = x_{k-1} + N(0, q² I)`` (``x_0 = 0``, known) is observed
as ``z_k = x_k + N(0, r² I)``. For each of ``--runs`` simulated sequences, every filter below is run
on the same data at the same number of likelihood evaluations per frame
(``--particles × --layers``), and its RMSE against the true states is printed beside the exact
posterior mean of the Kalman filter (the best any filter can do) and the raw measurement:

* ``sir``: one layer of ``particles × layers`` particles (Condensation);
* ``apf``: adaptive β (survival 0.5), noise covariance ×0.5 per layer;
* ``apf-fontmarty``: fixed β = (0.1, 0.4, 1), dynamics exponents α = (1, 4, 25) (3 layers only);
* ``iapf``: Fontmarty's IAPF, 80 % of the first layer from the dynamics and 20 % from a
  "detector" proposal ``N(z_k, q² I)`` (Fontmarty's Δ_k = the dynamics covariance), weighted by
  the tempered likelihood alone, as in the paper;
* ``iapf-corrected``: the same, with the importance correction p(x|x_{k-1}) / q(x).

``--jump J`` adds ``J·q`` to every coordinate of the truth halfway through, a target loss that only
the detector-driven proposal can recover from quickly.

Usage::

    python scripts/compare_filters.py                      # 15 runs, 10-D, 600 × 3
    python scripts/compare_filters.py --jump 20 --runs 5

Feeds docs/benchmarks.md, "Filters (``voxelmocap.tracking``, Fontmarty's experiment)".
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from datetime import datetime, timezone

import numpy as np

from voxelmocap.tracking import FONTMARTY_ALPHAS, FONTMARTY_BETAS, AnnealedParticleFilter


def simulate(rng, dim, steps, q, r, jump):
    """Truth ``(T, D)`` and measurements ``(T, D)`` of the random walk."""
    steps_noise = q * rng.standard_normal((steps, dim))
    if jump:
        steps_noise[steps // 2] += jump * q
    xs = np.cumsum(steps_noise, axis=0)
    return xs, xs + r * rng.standard_normal((steps, dim))


def kalman(zs, q, r):
    """Exact posterior means (F = H = I, Q = q² I, R = r² I, x_0 = 0 known)."""
    dim = zs.shape[1]
    m, P = np.zeros(dim), np.zeros((dim, dim))
    out = np.empty_like(zs)
    for k, z in enumerate(zs):
        P = P + q * q * np.eye(dim)
        K = P @ np.linalg.inv(P + r * r * np.eye(dim))
        m = m + K @ (z - m)
        P = (np.eye(dim) - K) @ P
        out[k] = m
    return out


def run_filter(name, zs, args, seed):
    dim = zs.shape[1]
    inf = np.full(dim, np.inf)
    kw = {"rng": seed}
    strategy = name
    if name == "apf-fontmarty":
        strategy = "apf"
        kw.update(betas=FONTMARTY_BETAS, alphas=FONTMARTY_ALPHAS)
    elif name.startswith("iapf"):
        strategy = "iapf"
        kw.update(iapf_fractions=(0.8, 0.2))
    f = AnnealedParticleFilter(args.particles, args.layers, -inf, inf, args.q,
                               strategy=strategy, **kw)
    f.initialise(np.zeros(dim), 0.0)
    q, r = args.q, args.r
    out = np.empty_like(zs)
    for k, z in enumerate(zs):
        def ll(x, z=z):
            return -0.5 * np.sum((x - z) ** 2, axis=1) / r**2

        def proposal(n, rng, z=z):
            return z + q * rng.standard_normal((n, dim))

        def proposal_log_pdf(x, z=z):
            return np.sum(-0.5 * ((x - z) / q) ** 2 - np.log(q * np.sqrt(2 * np.pi)), axis=1)

        out[k] = f.step(ll, proposal=proposal,
                        proposal_log_pdf=proposal_log_pdf if name == "iapf-corrected" else None)
    return out, f.n_evaluations


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dim", type=int, default=10)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--runs", type=int, default=15)
    p.add_argument("--particles", type=int, default=600)
    p.add_argument("--layers", type=int, default=3)
    p.add_argument("--q", type=float, default=1.0, help="random-walk noise std")
    p.add_argument("--r", type=float, default=0.5, help="measurement noise std")
    p.add_argument("--jump", type=float, default=0.0, help="jump of the truth, in units of q")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    names = ["sir", "apf"] + (["apf-fontmarty"] if args.layers == 3 else []) + [
        "iapf", "iapf-corrected"]
    seeds = np.random.SeedSequence(args.seed).spawn(args.runs)
    err = {k: [] for k in ["kalman", "measurement", *names]}
    secs = {k: [] for k in names}
    evals = {}
    for i, ss in enumerate(seeds):
        data_ss, *filter_ss = ss.spawn(1 + len(names))
        xs, zs = simulate(np.random.default_rng(data_ss), args.dim, args.steps, args.q, args.r,
                          args.jump)

        def rmse(est, xs=xs):
            return float(np.sqrt(np.mean((est - xs) ** 2)))

        err["kalman"].append(rmse(kalman(zs, args.q, args.r)))
        err["measurement"].append(rmse(zs))
        for name, fss in zip(names, filter_ss, strict=True):
            t0 = time.perf_counter()
            est, n_eval = run_filter(name, zs, args, np.random.default_rng(fss))
            secs[name].append(time.perf_counter() - t0)
            err[name].append(rmse(est))
            evals[name] = n_eval // args.steps
        print(f"run {i + 1}/{args.runs} done", file=sys.stderr)

    kf = np.mean(err["kalman"])
    print(f"# compare_filters: {args.dim}-D random walk q={args.q}, measurement r={args.r}, "
          f"{args.steps} steps, {args.runs} runs, jump={args.jump}·q, seed {args.seed}")
    print(f"# {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.machine()}, "
          f"python {platform.python_version()}, numpy {np.__version__}")
    print()
    print("| filter | evaluations/frame | RMSE mean | RMSE std | / Kalman | s/run |")
    print("|---|---|---|---|---|---|")
    for name, v in err.items():
        ev = evals.get(name, "-")
        t = f"{np.median(secs[name]):.2f}" if name in secs else "-"
        print(f"| {name} | {ev} | {np.mean(v):.4f} | {np.std(v):.4f} | "
              f"{np.mean(v) / kf:.3f} | {t} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
