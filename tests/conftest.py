"""Shared fixtures and helpers: random robots, modified-DH chains, relative errors."""

from __future__ import annotations

import logging
import os

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from manipcad.model.dh import rot_x, rot_z
from manipcad.model.robot import Drive, Robot

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
# integrator: one specialization each, with or without the online payload estimator, see
# manipcad.control.estimator.no_estimator) and the batched dynamics cost most of the
# suite's numba compile (benchmarks/compile_times.py measures each step). Under
# pytest-xdist the workers first share these out (a file lock per step in the kernel cache
# folder, each worker starting at a different step of each phase) and wait for each
# other's, so each kernel compiles once, on all cores at once, and every test, subprocess
# and Dask worker after that loads it from the cache. A plain `pytest` run compiles each
# kernel where it is first needed, as before.
#
# The two cores call the same compiled functions (the regulators' updates, the payload
# estimator, the moment components, the drives). numba compiles a callee when it types
# its caller's call, and loads it from the cache if it is there (the caller then links
# the callee's cached code and optimizes it again with its own, but does not type, lower
# or optimize the callee apart a second time). So the callees are compiled first, in
# two disjoint halves on the two workers (phase 1, with the inverse dynamics), and the
# two cores after them (phase 2, with the forward dynamics): each core then compiles only
# itself (benchmarks/prewarm_wall.py names any callee a core step still compiles).


class _Arguments(Exception):
    """Raised in place of the simulator's compiled core: carries the call's arguments."""


def _warm_up_run(integrator: str) -> None:
    """The warm-up run: the cylindrical arm with its drives, a PID per joint, 2 ms."""
    import warnings

    import manipcad
    from manipcad.control import pid

    arm = manipcad.load_robot("cylindrical")
    regs = [pid(j, kp=10.0, kd=1.0) for j in range(arm.n)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", manipcad.errors.ManipcadWarning)
        manipcad.simulate(arm, t_end=2e-3, dt=1e-3, regulators=regs, joint_limits="ignore",
                          integrator=integrator)


def _core_arguments(integrator: str) -> tuple:
    """The arguments :func:`manipcad.simulate` hands its compiled core (``run`` for RK4,
    ``run_adaptive`` otherwise) in the warm-up run (the cylindrical arm with its drives,
    a PID per joint), taken at the call instead of running it."""
    import importlib

    sim = importlib.import_module("manipcad.sim.integrate")
    name = "run" if integrator == "rk4" else "run_adaptive"
    core = getattr(sim, name)

    def take(*args):
        raise _Arguments(args)

    setattr(sim, name, take)
    try:
        _warm_up_run(integrator)
    except _Arguments as taken:
        return taken.args[0]
    finally:
        setattr(sim, name, core)
    raise RuntimeError(f"manipcad.simulate did not call sim.integrate.{name}")


def _compile(kernel, *args) -> None:
    """Compile (or load from the cache) ``kernel`` for the numba types of ``args``, as its
    caller in the core passes them, without running it."""
    import numba as nb

    kernel.compile(tuple(nb.typeof(a) for a in args))


def _prewarm_control() -> None:
    """Phase 1: the regulators' updates (every method of the registry) and the online
    payload estimator, with the argument types the cores' sampling step passes."""
    import numpy as np

    from manipcad.control.estimator import estimator_update, no_estimator
    from manipcad.control.registry import METHODS
    from manipcad.control.signals import NPARAM, NSIG, NSTATE
    from manipcad.model.robot import TABLE_COLS

    n = 2
    p, s, sig = np.zeros(NPARAM), np.zeros(NSTATE), np.zeros((n, NSIG))
    H, joints, U = np.zeros((n, n)), np.zeros(n, dtype=np.int64), np.zeros(n)
    for m in METHODS.values():
        _compile(m.update, *((p, s, sig, H, joints, 1, 1e-3, U) if m.spans
                             else (p, s, sig, 0, 1e-3)))
    _compile(estimator_update, no_estimator(), sig, np.zeros((n, TABLE_COLS)), 1e-3)


def _prewarm_plant() -> None:
    """Phase 1: the plant's side of the cores (the moment components, the drives, the
    payload swap, the scratch, the articulated-body method's rotations, the
    error-controlled core's exact currents) with the
    argument types of the warm-up run's own (this compiles the initial state's check,
    the forward dynamics by Cholesky, too)."""
    import numpy as np

    from manipcad.analysis.realtime import components_one
    from manipcad.drives.coupling import drive_rates
    from manipcad.drives.dc import rigid_drive_rate, static_current
    from manipcad.dynamics.aba import _rot_gen, _rot_sym
    from manipcad.sim import adaptive, loop

    plant, _, _, _, work = _core_arguments("rk4")[:5]
    n, nx = plant.rtable.shape[0], work.x.shape[0]
    q, qd, _, xd, dxd, tau, _, H, _, _, comp = loop.scratch(n, nx)
    cq, cqd, zero, rwork, cwork, tmp, Hii, hv, qg = comp
    _compile(components_one, plant.ctable, plant.g, cq, cqd, zero, rwork, cwork, tmp, H,
             Hii, hv, qg)
    _compile(drive_rates, plant.dtable, plant.off, xd, work.U, q, qd, tau, dxd, plant.ev.gm,
             plant.ev.gh)
    _compile(rigid_drive_rate, 0.0, 0.0, 0.0, plant.dtable[0])
    _compile(static_current, 0.0, 0.0, plant.dtable[0])
    _compile(loop._pick_up, plant)
    _compile(_rot_sym, *[0.0] * 15)  # the articulated-body method's (inlined) rotations
    _compile(_rot_gen, *[0.0] * 18)
    args = _core_arguments("adaptive")
    plant, work, tab, rtol, atol = args[0], args[4], args[13], args[14], args[15]
    S, x = tab.c.shape[0], work.x
    ph = np.zeros((S, n, 5))
    Ks = np.zeros((S, nx))
    _compile(adaptive._phi_table, plant, tab.c, 1e-3, n, ph)
    _compile(adaptive._currents, plant, x, x, work.U, 1e-3, n, ph[0])
    _compile(adaptive._current_error, plant, x, x, work.U, Ks[0, n:2 * n],
             Ks[S - 1, n:2 * n], 1e-3, n, rtol, atol, ph[S - 1])


def _prewarm_rk4() -> None:
    from manipcad.cli.warmup import _simulator

    _simulator()


def _prewarm_adaptive() -> None:
    _warm_up_run("adaptive")


def _dynamics_states():
    import numpy as np

    import manipcad

    arm = manipcad.load_robot("cylindrical")
    return manipcad, arm, np.full((2, arm.n), 0.1)


def _prewarm_inverse_dynamics() -> None:
    """The batched inverse dynamics (and its one-state kernel) and mass matrix."""
    manipcad, arm, q = _dynamics_states()
    manipcad.inverse_dynamics(arm, q, q, q, drives=True)
    manipcad.inverse_dynamics(arm, q[0], q[0], q[0], drives=False)
    manipcad.mass_matrix(arm, q)


def _prewarm_forward_dynamics() -> None:
    """The batched forward dynamics (articulated-body method)."""
    manipcad, arm, q = _dynamics_states()
    manipcad.forward_dynamics(arm, q, q, q)


#: name -> compile step, in the order one process runs them (benchmarks/compile_times.py)
PREWARM = {
    "control": _prewarm_control,
    "plant": _prewarm_plant,
    "inverse dynamics": _prewarm_inverse_dynamics,
    "rk4": _prewarm_rk4,
    "adaptive": _prewarm_adaptive,
    "forward dynamics": _prewarm_forward_dynamics,
}

#: the steps in phases: every step of a phase is done before the next phase starts (the
#: cores load the callees phase 1 cached). Worker w of W starts each phase at step
#: w·len/W, then takes any step of it nobody has taken; the costs (CPU s, cold cache,
#: benchmarks/compile_times.py) are about even per worker: phase 1 control ≈ plant
#: (+ the inverse dynamics to whoever is first), phase 2 the RK4 core plus the forward
#: dynamics ≈ the error-controlled core
PHASES = (
    ("control", "plant", "inverse dynamics"),
    ("rk4", "adaptive", "forward dynamics"),
)
assert sorted(sum(PHASES, ())) == sorted(PREWARM)


def _prewarm(worker: int, workers: int) -> None:
    """Run this worker's share of :data:`PREWARM`, phase by phase (:data:`PHASES`): take
    the steps of a phase nobody has taken, then wait for (or take over) the rest."""
    import fcntl

    from manipcad.cli.warmup import cache_dir

    folder = cache_dir()
    if folder is None:
        return

    def step(name: str, wait: bool) -> None:
        with open(folder / f"prewarm-{name.replace(' ', '-')}.lock", "w") as lock:
            try:
                fcntl.flock(lock, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
            except BlockingIOError:
                return  # another worker is compiling it
            done = folder / f"prewarm-{name.replace(' ', '-')}.done"
            if not done.exists():
                PREWARM[name]()
                done.touch()

    for phase in PHASES:
        start = (worker * len(phase)) // workers
        order = phase[start:] + phase[:start]
        for name in order:
            step(name, wait=False)
        for name in order:
            step(name, wait=True)


@pytest.fixture(scope="session", autouse=True)
def _kernels_compiled_once():
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    if workers > 1 and worker.startswith("gw"):
        _prewarm(int(worker[2:]), workers)
