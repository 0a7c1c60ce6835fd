"""voxelmocap.thread_waits: OpenMP's idle workers asked to sleep before numba loads."""

from __future__ import annotations

import os
import subprocess
import sys

from voxelmocap import thread_waits

# Seeded inputs of a parallel kernel of the package (run here and in fresh processes).
DATA = """
import numpy as np
from voxelmocap.measure import _silhouette_kernels as sk
rng = np.random.default_rng(3)
points = rng.uniform(-20, 180, (300, 9, 16, 2))
valid = rng.random((300, 9)) > 0.1
mask = rng.random((120, 160)) > 0.5
hit, extra = np.empty(300, np.int64), np.empty(300, np.int64)
"""
# The kernel in a fresh process, so that OpenMP reads the policy as it loads; its outputs
# printed as bytes.
KERNEL = "import voxelmocap.cli  # sets the policy unless given\n" + DATA + """
for _ in range(50):
    sk.cover_counts(points, valid, mask, hit, extra)
import os, numba
print(os.environ["OMP_WAIT_POLICY"], numba.threading_layer(), hit.tobytes().hex(), extra.tobytes().hex())
"""


def test_sets_the_policy_unless_the_user_chose_one():
    env = {}
    assert thread_waits.passive(env) == {"OMP_WAIT_POLICY": "PASSIVE"} == env
    mine = {"OMP_WAIT_POLICY": "ACTIVE"}
    assert thread_waits.passive(mine) == {} and mine == {"OMP_WAIT_POLICY": "ACTIVE"}


def _kernel(policy: str | None) -> list[str]:
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    env["NUMBA_NUM_THREADS"] = "2"           # a pool with a worker to wait, on any machine
    if policy is not None:
        env["OMP_WAIT_POLICY"] = policy
    out = subprocess.run([sys.executable, "-c", KERNEL], env=env, capture_output=True, text=True,
                         check=True)
    return out.stdout.split()


def test_the_command_sleeps_idle_workers_and_the_results_do_not_change():
    """The command's process gets PASSIVE (or the user's choice); a parallel kernel's counts
    are the same bytes either way, and equal the kernel run in this process."""
    default, active = _kernel(None), _kernel("ACTIVE")
    assert default[0] == "PASSIVE" and active[0] == "ACTIVE"
    assert default[2:] == active[2:]
    here = {}
    exec(DATA, here)
    hit, extra = here["hit"], here["extra"]
    here["sk"].cover_counts(here["points"], here["valid"], here["mask"], hit, extra)
    assert [hit.tobytes().hex(), extra.tobytes().hex()] == default[2:]
    assert hit.sum() > 0 and extra.sum() > 0
