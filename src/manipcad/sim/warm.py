"""Compile the numba kernels ahead of a run, in steps shared out over the cores.

On an empty kernel cache (:mod:`manipcad._numba_cache`) most of a first run's time is
numba compiling the simulator's cores: one for the fixed-step RK4 (:func:`manipcad.sim.loop.run`)
and one for every error-controlled integrator (:func:`manipcad.sim.adaptive.run_adaptive`:
the pair and the exact currents are arguments, so ``adaptive``, ``adaptive-exact``,
``adaptive-bs32`` and ``adaptive-exact-bs32`` share one specialization), with the
functions they call. numba compiles a callee when it types its caller's call and loads
it from the cache if it is there, so the work splits into :data:`STEPS`:

- phase 1, the callees, with the argument types the cores pass them: the stick-slip
  events' rates in consistent modes (``events``) and, beside them, their crossings and
  switches (``event edges``), the moment components, drives and payload swap
  (``plant``), the payload estimator (``estimator``), the error-controlled core's exact
  currents (``currents``);
- phase 2, what calls phase 1's kernels: the RK4 core's step with its events
  located (``event step``), and beside it the regulators' updates (``control``);
- phase 3, the cores themselves (``rk4``, ``adaptive``), and beside them what no core
  calls: the batched inverse dynamics a run's checks use (``inverse dynamics``), the
  rest of the dynamics API (``forward dynamics``).

:func:`compile_steps` runs the steps a command needs on up to two processes (this one
and ``python -m manipcad.sim.warm``): each worker starts each phase at a different step,
takes the steps nobody has taken (a file lock per step in the kernel cache folder) and
then waits for the others' steps of the phase before the next, so each kernel compiles
once, on both cores at once. A step done is marked ``warm-<step>`` in the cache folder;
a later process finds the marks and compiles nothing. The test suite's workers share
the same steps out the same way (``tests/conftest.py``).

Example:
    >>> from manipcad.sim.warm import needs
    >>> needs("adaptive-exact")  # doctest: +NORMALIZE_WHITESPACE
    ('events', 'event edges', 'plant', 'estimator', 'currents', 'control', 'adaptive',
     'inverse dynamics')
    >>> needs("rk4")  # doctest: +NORMALIZE_WHITESPACE
    ('events', 'event edges', 'plant', 'estimator', 'event step', 'control', 'rk4',
     'inverse dynamics')
"""

from __future__ import annotations

import functools
import importlib
import os
import subprocess
import sys
import tempfile
import time
import typing
import warnings
from collections.abc import Callable, Iterable
from pathlib import Path

import numba as nb
import numpy as np

from manipcad.analysis.realtime import components_one
from manipcad.control import pid
from manipcad.control.estimator import estimator_update, no_estimator
from manipcad.control.registry import METHODS
from manipcad.control.signals import NPARAM, NSIG, NSTATE
from manipcad.drives.coupling import drive_rates
from manipcad.drives.dc import rigid_drive_rate, static_current
from manipcad.dynamics import forward_dynamics, inverse_dynamics, mass_matrix
from manipcad.dynamics._inputs import PARALLEL_MIN_WORK
from manipcad.dynamics.aba import _rot_gen, _rot_sym
from manipcad.dynamics.gear import gear_factor_array
from manipcad.errors import ManipcadWarning
from manipcad.model import load_robot
from manipcad.model.robot import TABLE_COLS
from manipcad.sim import adaptive, events, loop
from manipcad.sim.joint_limits import column_extremes
from manipcad.sim.simulate import simulate
from manipcad.trajectories import quintic

# the modules that hold the cores' callers and the initial state's check
sim = importlib.import_module("manipcad.sim.integrate")
closed_loop = importlib.import_module("manipcad.sim.closed_loop")

MARKER = "warm"


class _Arguments(Exception):
    """Raised in place of the simulator's compiled core: carries the call's arguments."""


def _warm_up_run(integrator: str) -> None:
    """The warm-up run: the cylindrical arm with its drives, a PID per joint, 2 ms along a
    quintic (what a run along a trajectory samples and checks compiles with it)."""
    arm = load_robot("cylindrical")
    regs = [pid(j, kp=10.0, kd=1.0) for j in range(arm.n)]
    q0 = np.zeros(arm.n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        simulate(arm, t_end=2e-3, dt=1e-3, regulators=regs, joint_limits="ignore",
                          trajectory=quintic(q0, q0 + 1e-3, 2e-3), integrator=integrator)


@functools.cache
def core_arguments(integrator: str) -> tuple:
    """The arguments :func:`manipcad.simulate` hands its compiled core (``run`` for RK4,
    ``run_adaptive`` otherwise) in the warm-up run, taken at the call instead of running
    it (once per process: several steps type their kernels on them). The initial state's
    check (:func:`manipcad.dynamics.api.moves_mass`, the inverse dynamics) is left out
    here: the ``inverse dynamics`` step compiles it."""
    name = "run" if integrator == "rk4" else "run_adaptive"
    core = getattr(sim, name)
    check = closed_loop.moves_mass

    def take(*args):
        raise _Arguments(args)

    setattr(sim, name, take)
    closed_loop.moves_mass = lambda *args, **kwargs: True
    try:
        _warm_up_run(integrator)
    except _Arguments as taken:
        return taken.args[0]
    finally:
        setattr(sim, name, core)
        closed_loop.moves_mass = check
    raise RuntimeError(f"manipcad.simulate did not call sim.integrate.{name}")


def _compile(kernel, *args) -> None:
    """Compile (or load from the cache) ``kernel`` for the numba types of ``args``, as its
    caller in the core passes them, without running it."""
    kernel.compile(tuple(nb.typeof(a) for a in args))


def _control() -> None:
    """The regulators' updates (every method of the registry), with the argument types
    the cores' sampling step passes."""
    n = 2
    p, s, sig = np.zeros(NPARAM), np.zeros(NSTATE), np.zeros((n, NSIG))
    H, joints, U = np.zeros((n, n)), np.zeros(n, dtype=np.int64), np.zeros(n)
    for m in METHODS.values():
        _compile(m.update, *((p, s, sig, H, joints, 1, 1e-3, U) if m.spans
                             else (p, s, sig, 0, 1e-3)))


def _estimator() -> None:
    """The online payload estimator, with the argument types the cores' sampling step
    passes."""
    n = 2
    _compile(estimator_update, no_estimator(), np.zeros((n, NSIG)), np.zeros((n, TABLE_COLS)),
             1e-3)


def _plant() -> None:
    """The plant's side of the cores (the moment components, the drives, the payload swap,
    the scratch, the articulated-body method's rotations) with the argument types of the
    warm-up run's own."""
    plant, _, _, _, work = core_arguments("rk4")[:5]
    n, nx = plant.rtable.shape[0], work.x.shape[0]
    q, qd, _, xd, dxd, tau, _, H, _, _, comp = loop.scratch(n, nx)
    cq, cqd, zero, rwork, cwork, tmp, Hii, hv, qg = comp
    _compile(components_one, plant.ctable, plant.g, cq, cqd, zero, rwork, cwork, tmp, H,
             Hii, hv, qg)
    _compile(drive_rates, plant.dtable, plant.off, xd, work.U, q, qd, tau, dxd, plant.ev.gm)
    _compile(rigid_drive_rate, 0.0, 0.0, 0.0, plant.dtable[0])
    _compile(static_current, 0.0, 0.0, plant.dtable[0])
    _compile(loop._pick_up, plant)
    _compile(_rot_sym, *[0.0] * 15)  # the articulated-body method's (inlined) rotations
    _compile(_rot_gen, *[0.0] * 18)


def _currents() -> None:
    """The error-controlled core's exact armature currents and their error, with the
    core's argument types."""
    args = core_arguments("adaptive")
    plant, work, tab, rtol, atol = args[0], args[4], args[13], args[14], args[15]
    n, nx = plant.rtable.shape[0], work.x.shape[0]
    S, x = tab.c.shape[0], work.x
    ph = np.zeros((S, n, 5))
    Ks = np.zeros((S, nx))
    _compile(adaptive._phi_table, plant, tab.c, 1e-3, n, ph)
    _compile(adaptive._currents, plant, x, x, work.U, 1e-3, n, ph[0], Ks[0, n:2 * n],
             Ks[S - 1, n:2 * n], rtol, atol)


def _event_arguments():
    """(plant, x, U, dist, n, scratch, K) as the cores pass them to the events' steps."""
    plant, _, ref, _, work = core_arguments("rk4")[:5]
    n, nx = plant.rtable.shape[0], work.x.shape[0]
    return plant, work.x, work.U, ref.dist[0], n, loop.scratch(n, nx), np.zeros((4, nx))


def _events() -> None:
    """The stick-slip friction and gear-loss events' right-hand side with consistent modes
    (:func:`manipcad.sim.loop.settle`: the hybrid plant's rates, the releases), which both
    cores call, with the cores' argument types."""
    plant, x, U, dist, n, scr, K = _event_arguments()
    _compile(loop.settle, plant, x, U, dist, n, scr, K, 0.0)


def _event_edges() -> None:
    """The events' values, their crossings located and the mode switches at them, which
    both cores call (beside :func:`_events`: none calls the other)."""
    plant, x, U, dist, n, scr, K = _event_arguments()
    ev = plant.ev
    _compile(events.event_values, plant, x, n, ev.e0)
    _compile(events.release_edge, plant, x, n, ev.e0, ev.e1, 0.0)
    _compile(events.switch, plant, x, n, ev.e0, ev.e1, 0.0)
    _compile(events.crossing, ev.e0, ev.e1)
    _compile(events.bracket_start, ev.il, 0.0)
    _compile(events.bracket_next, ev.il, 0.0)


def _event_step() -> None:
    """The RK4 core's step with its events located (:func:`manipcad.sim.loop.hybrid_step`),
    on :func:`_events`' and :func:`_event_edges`' kernels."""
    plant, x, U, dist, n, scr, K = _event_arguments()
    _compile(loop.hybrid_step, plant, x, U, dist, 0.0, 1e-3, n, scr, K,
             np.zeros(x.shape[0]), plant.ev.xe)


def _rk4() -> None:
    _warm_up_run("rk4")


def _adaptive() -> None:
    _warm_up_run("adaptive")


def _dynamics_states():
    arm = load_robot("cylindrical")
    return arm, np.full((2, arm.n), 0.1)


def _inverse_dynamics() -> None:
    """What a simulation's checks run: the batched inverse dynamics (its initial state's
    mass matrix, :func:`manipcad.dynamics.api.moves_mass`, and the gear torques of its
    time series, on numba's threads when long) and the reference's extremes (the joint
    limits)."""
    arm, q = _dynamics_states()
    inverse_dynamics(arm, q, q, q, drives=True)
    big = _threaded_batch(arm)  # a run's checks of its time series
    inverse_dynamics(arm, big, big, big, drives=False)
    column_extremes(q)  # a run's check of its reference against the joint limits
    gear_factor_array(np.full(2, 0.9), q[0, :2], q[0, :2])  # the gear-loss checks


def _threaded_batch(arm) -> np.ndarray:
    """States enough for the dynamics' batch kernels to run on numba's threads."""
    return np.full((PARALLEL_MIN_WORK // arm.n + 2 * nb.get_num_threads(), arm.n), 0.1)


def _forward_dynamics() -> None:
    """The rest of the dynamics API (sizing, selection, the studies): the batched forward
    dynamics (articulated-body method and Cholesky), the mass matrix, the one-state
    kernels."""
    arm, q = _dynamics_states()
    forward_dynamics(arm, q, q, q)
    forward_dynamics(arm, q, q, q, method="crba")
    inverse_dynamics(arm, q[0], q[0], q[0], drives=False)
    mass_matrix(arm, q)
    mass_matrix(arm, q[0])
    mass_matrix(arm, _threaded_batch(arm))
    forward_dynamics(arm, q[0], q[0], np.zeros(arm.n), drives=True, method="crba")
    forward_dynamics(arm, q[0], q[0], np.zeros(arm.n), drives=True)


#: name -> (what, compile step), in the order one process runs them
STEPS: dict[str, tuple[str, Callable[[], None]]] = {
    "events": ("stick-slip events: consistent modes", _events),
    "event edges": ("stick-slip events: crossings and switches", _event_edges),
    "plant": ("drives, moment components", _plant),
    "estimator": ("payload estimator", _estimator),
    "currents": ("exact armature currents", _currents),
    "event step": ("stick-slip events: the RK4 step", _event_step),
    "control": ("regulators", _control),
    "rk4": ("RK4 simulator core", _rk4),
    "adaptive": ("error-controlled simulator core (every adaptive integrator)", _adaptive),
    "inverse dynamics": ("inverse dynamics, run checks", _inverse_dynamics),
    "forward dynamics": ("forward dynamics, mass matrix", _forward_dynamics),
}

#: the steps in phases: every step of a phase is done before the next phase starts (a
#: caller loads the callees an earlier phase cached). Worker w of W starts each phase at
#: step w·len/W, then takes what nobody has taken. On two workers: the events' rates on
#: one, their edges, the plant and the estimator on the other; then the RK4 core's event
#: step on one, the regulators on the other; then a core on one and what no core calls
#: (the run checks' and the API's dynamics) on the other
PHASES = (
    ("events", "event edges", "plant", "estimator", "currents"),
    ("event step", "control"),
    ("rk4", "inverse dynamics", "adaptive", "forward dynamics"),
)
assert sorted(sum(PHASES, ())) == sorted(STEPS)

#: the steps every simulation needs whatever its integrator: the callees both cores share
#: and the run checks' inverse dynamics
_CALLEES = ("events", "event edges", "plant", "estimator", "control", "inverse dynamics")

#: the core step of each integrator (``simulate(integrator=...)``)
CORES = {"rk4": "rk4", "adaptive": "adaptive", "adaptive-exact": "adaptive",
         "adaptive-bs32": "adaptive", "adaptive-exact-bs32": "adaptive"}


def needs(integrator: str = "rk4") -> tuple[str, ...]:
    """The steps a simulation with this integrator compiles (its core, the callees, and
    the inverse dynamics its run checks use), in :data:`STEPS` order (an unknown
    integrator: the RK4's; :func:`manipcad.simulate` then names the known ones)."""
    core = CORES.get(integrator, "rk4")
    own = ("event step",) if core == "rk4" else ("currents",)
    return tuple(s for s in STEPS if s in _CALLEES or s in own or s == core)


def cache_dir() -> Path | None:
    """The kernel cache folder in use, or None when numba's default (next to the
    sources) applies."""
    d = os.environ.get("NUMBA_CACHE_DIR")
    return Path(d) if d else None


def marker(step: str) -> Path | None:
    """The file that says ``step`` is compiled (in :func:`cache_dir`), or None without a
    kernel cache folder; its lock file is this path with ``.lock`` added."""
    d = cache_dir()
    return None if d is None else d / f"{MARKER}-{step.replace(' ', '-')}"


def is_warm(steps: Iterable[str] | None = None) -> bool:
    """True when these steps (default all) were compiled for this source version already."""
    markers = [marker(s) for s in (tuple(STEPS) if steps is None else steps)]
    return all(m is not None and m.is_file() for m in markers)


def _run_step(name: str, failures: list[str], report: Callable[[str], None]) -> None:
    what, step = STEPS[name]
    report(what)
    try:
        step()
    except Exception as exc:  # noqa: BLE001 - reported, and the rest still runs
        failures.append(f"{what}: {type(exc).__name__}: {exc}")
        return
    done = marker(name)
    if done is not None:
        try:
            done.write_text(time.strftime("%Y-%m-%dT%H:%M:%S\n"))
        except OSError:
            pass


def share(worker: int, workers: int, steps: Iterable[str] | None = None,
          report: Callable[[str], None] = lambda what: None) -> list[str]:
    """Worker ``worker`` of ``workers``' share of ``steps`` (default all), phase by phase:
    take the steps of a phase nobody has taken, then wait for (or take over) the rest.

    Returns the failures as "what: reason" lines (a failed step stays unmarked, and the
    others still run). ``report(what)`` is called as each step starts. Without a kernel
    cache folder (or file locks) the steps run here one after another.
    """
    wanted = set(STEPS) if steps is None else set(steps)
    unknown = wanted - set(STEPS)
    if unknown:
        raise ValueError(f"unknown compile steps {sorted(unknown)}; known: {list(STEPS)}")
    failures: list[str] = []
    folder = cache_dir()
    try:
        import fcntl  # deferred: optional dependency: POSIX file locks (absent on Windows)
    except ImportError:  # no POSIX file locks: one process does it all
        folder = None
    if folder is None:
        for name in STEPS:
            if name in wanted:
                _run_step(name, failures, report)
        return failures

    tried: set[str] = set()

    def step(name: str, wait: bool) -> None:
        if name in tried:
            return
        with open(f"{marker(name)}.lock", "w") as lock:
            try:
                fcntl.flock(lock, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
            except BlockingIOError:
                return  # another worker is compiling it
            if not is_warm((name,)):  # not done, or another worker failed it: here
                tried.add(name)
                _run_step(name, failures, report)

    for phase in PHASES:
        mine = tuple(s for s in phase if s in wanted)
        start = (worker * len(mine)) // workers
        order = mine[start:] + mine[:start]
        for name in order:
            step(name, wait=False)
        for name in order:
            step(name, wait=True)
    return failures


def workers_available() -> int:
    """Compile processes to use: 2 where there are 2 cores or more (``MANIPCAD_COMPILE_WORKERS``
    sets it; 1: this process only)."""
    env = os.environ.get("MANIPCAD_COMPILE_WORKERS")
    if env:
        return max(1, int(env))
    return 2 if (os.cpu_count() or 1) >= 2 else 1


class Compile:
    """The steps a command needs, shared out over ``workers`` processes.

    ``Compile(steps).start()`` starts the helper processes at once (they compile in the
    background); :meth:`finish` runs this process's share and waits for the helpers.
    A command that has other work first (``manipcad demo``'s dynamics tables) does it
    between the two.

    Args:
        steps: names of :data:`STEPS` (default all); the warm ones are left out.
        workers: processes in all, this one included (default :func:`workers_available`).
    """

    def __init__(self, steps: Iterable[str] | None = None, workers: int | None = None):
        steps = tuple(STEPS) if steps is None else tuple(steps)
        self.steps = tuple(s for s in steps if not is_warm((s,)))
        self.workers = workers_available() if workers is None else max(1, int(workers))
        if cache_dir() is None:
            self.workers = 1
        self._procs: list[tuple[subprocess.Popen, typing.IO[bytes]]] = []

    def start(self) -> Compile:
        """Start the helper processes (worker 1 .. workers − 1); nothing when warm."""
        if not self.steps or self._procs:
            return self
        for w in range(1, self.workers):
            # stderr to a file, not a pipe: a helper that wrote more than a pipe holds
            # would block while this process waits for its step
            err = tempfile.TemporaryFile()
            self._procs.append((subprocess.Popen(
                [sys.executable, "-m", "manipcad.sim.warm", str(w), str(self.workers),
                 *self.steps], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                stderr=err, env=os.environ.copy()), err))
        return self

    def finish(self, report: Callable[[str], None] = lambda what: None) -> list[str]:
        """This process's share, then wait for the helpers; the failures as "what: reason"
        lines (a step a helper failed is taken over here, so its failure shows here)."""
        if not self.steps:
            return []
        self.start()
        try:
            failures = share(0, self.workers, self.steps, report)
        except BaseException:  # interrupted (Ctrl-C): the helpers stop too
            self.cancel()
            raise
        for p, err in self._procs:
            p.wait()
            err.seek(0)
            tail = err.read().decode(errors="replace").strip().splitlines()[-1:] or ["?"]
            err.close()
            if p.returncode and not failures:
                failures.append(f"compile helper exited {p.returncode}: {tail[0]}")
        self._procs = []
        return failures


    def cancel(self) -> None:
        """Stop the helpers that still run (what they cached stays: numba writes each
        cache file whole, and a step's mark only when it is done)."""
        for p, err in self._procs:
            if p.poll() is None:
                p.terminate()
            p.wait()
            err.close()
        self._procs = []


def compile_steps(steps: Iterable[str] | None = None, workers: int | None = None,
                  report: Callable[[str], None] = lambda what: None) -> list[str]:
    """Compile ``steps`` (default all) on ``workers`` processes; the failures (see
    :class:`Compile`)."""
    return Compile(steps, workers).finish(report)


def _main(argv: list[str]) -> int:
    """``python -m manipcad.sim.warm WORKER WORKERS STEP...``: a helper's share."""
    worker, workers, steps = int(argv[0]), int(argv[1]), argv[2:]
    failures = share(worker, workers, steps)
    for line in failures:
        print(line, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
