"""Shared fixtures and helpers: random robots, modified-DH chains, relative errors."""

from __future__ import annotations

import logging
import os
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from manipcad.model.dh import rot_x, rot_z
from manipcad.model.robot import Drive, Robot
from manipcad.sim.warm import share

# pytest-xdist's workers start with COLUMNS=80, LINES=24: the CLI's rich console would fix
# its width at import and ignore the width each CliRunner test asks for
for _name in ("COLUMNS", "LINES"):
    os.environ.pop(_name, None)


def random_tree(seed: int, n: int = 7, *, chain: bool = False, drives: bool = False) -> Robot:
    """A random tree (or chain) of revolute and prismatic joints with full inertias."""
    rng = np.random.default_rng(seed)
    types = rng.choice(["revolute", "prismatic"], n)
    parent = np.arange(n) - 1 if chain else [-1] + [int(rng.integers(-1, i)) for i in range(1, n)]
    A = rng.normal(size=(n, 3, 3))
    inertia = A @ A.transpose(0, 2, 1) * 0.05 + 0.001 * np.eye(3)
    drv = None
    if drives:
        drv = [Drive(J=rng.uniform(1e-5, 1e-4), ratio=rng.uniform(-100, 100),
                     k_v=rng.uniform(0, 1e-3), M_f=(rng.uniform(0, 0.05), rng.uniform(0, 0.05)))
               for _ in range(n)]
    return Robot.from_arrays(
        f"tree{seed}", types, parent, Rotation.random(n, random_state=seed).as_matrix(),
        rng.normal(size=(n, 3)) * 0.3, rng.uniform(0.5, 3.0, n), rng.normal(size=(n, 3)) * 0.1,
        inertia, offset=rng.normal(size=n), drives=drv,
        gravity=rng.normal(size=3) * 5.0)


# the PUMA 560 as modified-DH rows (type, a_{i-1} m, alpha_{i-1} rad, d_i m, theta_i rad)
# for mdh_robot; the kinematics and trajectory tests build their arms from it
PUMA_MDH = [
    ("R", 0.0, 0.0, 0.0, 0.0),
    ("R", 0.0, -np.pi / 2, 0.2435, 0.0),
    ("R", 0.4318, 0.0, -0.0934, 0.0),
    ("R", 0.0203, np.pi / 2, 0.4331, 0.0),
    ("R", 0.0, -np.pi / 2, 0.0, 0.0),
    ("R", 0.0, np.pi / 2, 0.0, 0.0),
]


def mdh_robot(rows, tool: np.ndarray | None = None, name: str = "mdh", *,
              tool_p=None) -> Robot:
    """A serial Robot from modified-DH rows (type "R" or "P", a_{i-1} m, alpha_{i-1} rad,
    d_i m, theta_i rad); the joint variable adds to theta (R) or d (P).

    The placement is Rot_x(alpha)·Trans_x(a) with the fixed z part (d for a
    revolute joint, theta for a prismatic one) folded in. Links of 1 kg at the
    frame origin with inertia 0.01·I kg·m². ``tool``: the (4, 4) tool transform
    in the last link frame (m); ``tool_p``: a tool offset (m) replacing its
    translation.
    """
    Rs, ps, off, types = [], [], [], []
    for kind, a, alpha, d, theta in rows:
        if kind == "R":
            Rs.append(rot_x(alpha))
            ps.append(np.array([a, 0.0, 0.0]) + rot_x(alpha) @ [0.0, 0.0, d])
            off.append(theta)
            types.append("revolute")
        else:
            Rs.append(rot_x(alpha) @ rot_z(theta))
            ps.append(np.array([a, 0.0, 0.0]))
            off.append(d)
            types.append("prismatic")
    n = len(rows)
    T = np.eye(4) if tool is None else tool
    return Robot.from_arrays(
        name, types, list(range(-1, n - 1)), np.array(Rs), np.array(ps), np.ones(n),
        np.zeros((n, 3)), np.tile(np.eye(3) * 0.01, (n, 1, 1)), offset=off,
        tool_R=T[:3, :3], tool_p=T[:3, 3] if tool_p is None else tool_p)


@pytest.fixture(params=range(6))
def tree(request) -> Robot:
    return random_tree(request.param, n=3 + request.param, chain=request.param % 2 == 0)


def rel_err(a, b) -> float:
    """Largest difference relative to the largest magnitude (1 when both are tiny)."""
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1.0))


@pytest.fixture(scope="session")
def dask_scheduler():
    """The address of one LocalCluster of 2 worker processes, shared by the tests that
    compare serial and distributed runs (one cluster start, ~5-15 s, for all of them)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None, memory_limit=0,
                      silence_logs=logging.ERROR) as cluster:
        yield cluster.scheduler_address


# ------------------------------------------------------------------ longest files first
# With -n the files are the units of work (--dist loadfile) and xdist hands them out in
# collection order (--no-loadscope-reorder in pyproject; its default orders them by how
# many tests they hold, which put the 2-test, half-minute browser file near the end and
# left one worker running it alone). Longest first is the classic schedule for the least
# idle tail. Weights: each file's share of the suite's test time in seconds, from a
# timestamp log of a whole run (session 6); files not listed follow in their own order.
FILE_SECONDS = {
    "tests/test_codegen.py": 149, "tests/test_ui_browser.py": 88,
    "tests/test_sim_adaptive.py": 48, "tests/test_hardening.py": 33, "tests/test_ui.py": 31,
    "tests/test_drives.py": 29, "tests/test_workspace.py": 26,
    "tests/test_identification_sim.py": 23, "tests/test_synthesis.py": 18,
    "tests/test_claims.py": 16, "tests/test_cli_simulate.py": 14, "tests/test_expert.py": 13,
    "tests/test_dynamics_pinocchio.py": 13, "tests/test_study.py": 12,
    "tests/test_ws_commands.py": 11, "tests/test_trajectories.py": 10,
    "tests/test_control_registry.py": 10, "tests/test_readme.py": 10, "tests/test_parallel.py": 9,
}


def pytest_collection_modifyitems(config, items):
    """Order the collected tests by their file's weight in :data:`FILE_SECONDS`, longest
    first (a stable sort: within a file, and among unlisted files, the order stays)."""
    def weight(item) -> int:
        path = item.nodeid.split("::", 1)[0]
        return -FILE_SECONDS.get(path, 0)
    items.sort(key=weight)


# ------------------------------------------------------------------ kernels compiled once
# On a cold kernel cache the simulator's compiled cores (RK4 and the error-controlled
# integrator) with their callees and the batched dynamics cost most of the suite's numba
# compile. Under pytest-xdist the workers first share out the steps of
# manipcad.sim.warm (what `manipcad warmup` compiles: a file lock per step in the kernel
# cache folder, each worker starting at a different step of each phase) and wait for each
# other's, so each kernel compiles once, on all cores at once, and every test, subprocess
# and Dask worker after that loads it from the cache. A plain `pytest` run compiles each
# kernel where it is first needed.


@pytest.fixture(scope="session", autouse=True)
def _kernels_compiled_once():
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    if workers > 1 and worker.startswith("gw"):
        for line in share(int(worker[2:]), workers):
            warnings.warn(f"kernel prewarm step failed: {line}", stacklevel=1)
