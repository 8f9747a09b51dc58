"""One simulation run, described once: what ``manipcad simulate``, the web application's
worker, ``manipcad ws rerun`` and any script run from files.

A :class:`RunSpec` is the whole description of a run (the robot, trajectory and regulator
files, the step, end time and record stride, the drives, payload, integrator and its
tolerances, what the joint limits do, the checks' thresholds); :meth:`RunSpec.to_dict` is
what a result stores (``run`` in metrics.json) and :meth:`RunSpec.from_dict` reads it back,
so a re-run is ``from_dict`` of what was stored (:func:`stored_spec`, with the copies of
the inputs the result keeps).

:func:`execute` runs one: :func:`prepare` loads the files and checks that they make one run
(:func:`manipcad.store.plan.plan_run`), then :func:`manipcad.simulate` runs it, every
rating is checked (:func:`manipcad.sim.checks.run_checks`) and, given a ``store``
(:func:`to_folder`, or a workspace's :func:`manipcad.workspace.runs.to_workspace`), the
result is saved with its inputs and its description.

Example:
    >>> spec = RunSpec("cylindrical", "examples/fig3_laws.yaml",
    ...                ("examples/pid_cylindrical.yaml",), t_end=0.02)
    >>> done = execute(spec)
    >>> done.run["every"], float(done.result.t[-1]), done.checks.verdict in ("pass", "fail")
    (10, 0.02, True)
    >>> RunSpec.from_dict(spec.to_dict()) == spec
    True
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from manipcad.errors import InputError, ManipcadWarning
from manipcad.model.load import load_robot
from manipcad.sim import SimulationDiverged, simulate
from manipcad.sim.checks import MAX_CHATTER, MAX_SATURATION, RunChecks, run_checks
from manipcad.store.plan import NAMES, plan_run
from manipcad.store.results import INPUTS_DIR, METRICS_JSON, save_result
from manipcad.trajectories import load_trajectory

#: what :func:`execute` adds to a stored description: the loader's notes on the robot,
#: the run's wall time (s) and the checks' verdict (in ``checks``)
FACTS = ("robot_notes", "wall_time_s")


@dataclass(frozen=True)
class RunSpec:
    """The description of one simulation run from files (SI units).

    Attributes:
        robot: a robot file or a catalog robot's name.
        trajectory: the trajectory file; None: hold the start pose (then ``t_end`` is
            needed).
        regulators: regulator files (joints in none get U = 0).
        dt: integration step, s (the regulator periods are multiples of it).
        t_end: simulated time, s; None: the trajectory's duration.
        every: record stride, steps between stored samples; None: one per regulator
            period (:func:`manipcad.store.results.every_for`).
        drives: simulate the DC drives (False: the rigid body, regulator outputs are
            torques).
        payload: a mass at the tool point, kg, or a payload mapping
            (:func:`manipcad.model.payload.apply_payload`); None: none.
        integrator, rtol, atol: :func:`manipcad.simulate`'s (rtol -, atol rad or m and
            their rates; None for RK4).
        order: 3 keeps the armature inductance, 2 neglects it.
        joint_limits: "warn", "stop", "ignore" or "hard-stop" (:func:`manipcad.simulate`).
        use_generated: use the robot's generated kernels when they exist (a re-run takes
            the kernels its result ran on: the same numbers bit for bit).
        pickup: a payload gripped mid-run, ``{"mass": kg, "t": s, ...}``
            (:func:`manipcad.simulate`), or None.
        allow_other_robot: accept regulator files made for another robot model.
        accuracy: the tracking accuracy asked, rad or m (the tracking check), or None.
        max_saturation: the largest fraction of the run at the amplifier limit (0..1].
        max_chatter: the largest amplifier-input reversals per second, 1/s.
    """

    robot: str
    trajectory: str | None = None
    regulators: tuple[str, ...] = ()
    dt: float = 1e-4
    t_end: float | None = None
    every: int | None = None
    drives: bool = True
    payload: float | Mapping | None = None
    integrator: str = "rk4"
    rtol: float | None = None
    atol: float | None = None
    order: int = 3
    joint_limits: str = "warn"
    use_generated: bool = True
    pickup: Mapping | None = None
    allow_other_robot: bool = False
    accuracy: float | None = None
    max_saturation: float = MAX_SATURATION
    max_chatter: float = MAX_CHATTER

    def __post_init__(self) -> None:
        # paths as text, the regulators a tuple: a description compares and stores as data
        object.__setattr__(self, "robot", str(self.robot))
        if self.trajectory is not None:
            object.__setattr__(self, "trajectory", str(self.trajectory))
        object.__setattr__(self, "regulators", tuple(str(r) for r in self.regulators))

    def replace(self, **changes) -> RunSpec:
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The description as plain data (metrics.json's ``run``): every field, the
        checks' thresholds under ``checks``.

        Example:
            >>> d = RunSpec("puma560", "move.yaml", t_end=1.0).to_dict()
            >>> d["robot"], d["regulators"], d["checks"]["max_chatter"]
            ('puma560', [], 50.0)
        """
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
             if f.name not in _CHECKS}
        d["regulators"] = list(self.regulators)
        for key in ("payload", "pickup"):
            if isinstance(d[key], Mapping):
                d[key] = dict(d[key])
        d["checks"] = {k: getattr(self, k) for k in _CHECKS}
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str = "run") -> RunSpec:
        """The description stored by :meth:`to_dict` (or by an earlier version: a key it
        lacks takes its default; :data:`FACTS` and the checks' verdict are skipped).

        Args:
            d: the mapping.
            where: how it is named in errors (the file it was read from).

        Raises:
            InputError: not a mapping, a key that is no field, or a value of the wrong
                kind (naming ``where`` and the key).
        """
        if not isinstance(d, Mapping):
            raise InputError(where, "run", f"expected a mapping, got {type(d).__name__}")
        known = {f.name for f in dataclasses.fields(cls)}
        kw: dict[str, Any] = {}
        for key, value in d.items():
            if key in FACTS:
                continue
            if key == "checks":
                if not isinstance(value, Mapping):
                    raise InputError(where, "run.checks", "expected a mapping")
                kw.update({k: value[k] for k in _CHECKS if k in value})
                continue
            if key not in known:
                raise InputError(where, f"run.{key}", f"unknown run setting; the settings are "
                                 f"{', '.join(sorted(known - set(_CHECKS)))}")
            kw[key] = value
        if "robot" not in kw:
            raise InputError(where, "run.robot", "missing")
        for key, value in list(kw.items()):
            kw[key] = _typed(key, value, where)
        return cls(**kw)


#: the fields stored under ``checks``
_CHECKS = ("accuracy", "max_saturation", "max_chatter")
_FLOAT = ("dt", "t_end", "rtol", "atol", "accuracy", "max_saturation", "max_chatter")
_BOOL = ("drives", "use_generated", "allow_other_robot")


def _typed(key: str, value: Any, where: str) -> Any:
    """A stored value as its field's type (None kept where the field allows it)."""
    try:
        if key in _FLOAT:
            return None if value is None and key not in ("dt", "max_saturation",
                                                         "max_chatter") else float(value)
        if key in _BOOL:
            if not isinstance(value, bool):
                raise TypeError
            return value
        if key in ("every", "order"):
            if value is None and key == "every":
                return None
            if isinstance(value, bool) or float(value) != int(value):
                raise TypeError
            return int(value)
        if key == "regulators":
            if isinstance(value, str) or not all(isinstance(x, str) for x in value):
                raise TypeError
            return tuple(value)
        if key in ("payload", "pickup"):
            if value is None or isinstance(value, Mapping):
                return value
            if key == "payload":
                return float(value)
            raise TypeError
        if key in ("robot", "integrator", "joint_limits"):
            if not isinstance(value, str):
                raise TypeError
            return value
        if key == "trajectory":
            if value is not None and not isinstance(value, str):
                raise TypeError
            return value
    except (TypeError, ValueError, OverflowError):
        raise InputError(where, f"run.{key}", f"{value!r} is not a valid value") from None
    return value


@dataclass(frozen=True)
class Prepared:
    """A run's files loaded and checked (:func:`prepare`).

    Attributes:
        spec: the description, with ``t_end`` and ``every`` settled (the trajectory's
            duration, one sample per regulator period).
        robot: the loaded :class:`~manipcad.model.robot.Robot`.
        trajectory: the loaded trajectory, or None.
        regulators: the loaded regulators, in file order.
        robot_notes: the loader's notes on the robot (its data), as text.
        notes: the notes on the trajectory and the regulators, as text.
    """

    spec: RunSpec
    robot: Any
    trajectory: Any
    regulators: list
    robot_notes: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def prepare(spec: RunSpec, *, names: Mapping[str, str] = NAMES,
            sources: Mapping[str, str] | None = None) -> Prepared:
    """Load a run's files and check that they make one run (the checks of
    :func:`manipcad.store.plan.plan_run`), before anything is simulated.

    Args:
        spec: the run.
        names: how dt, t_end, every and the no-drives switch are named in errors (the
            CLI's option names).
        sources: how the robot and the trajectory are named in errors (``{"robot": ...,
            "trajectory": ...}``); their files by default.

    Returns:
        :class:`Prepared`; the loaders' :class:`~manipcad.errors.ManipcadWarning` are in
        its notes, not warned.

    Raises:
        InputError: a bad file or number, named.
    """
    sources = dict(sources or {})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ManipcadWarning)
        robot = load_robot(spec.robot)
    robot_notes = _notes(caught)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ManipcadWarning)
        traj = (None if spec.trajectory is None
                else load_trajectory(spec.trajectory, robot=robot))
        plan = plan_run(robot, traj, spec.regulators, dt=spec.dt, t_end=spec.t_end,
                        every=spec.every, drives=spec.drives,
                        allow_other_robot=spec.allow_other_robot,
                        robot_source=sources.get("robot", spec.robot),
                        trajectory_source=sources.get("trajectory", str(spec.trajectory)),
                        names=names)
    return Prepared(spec.replace(t_end=plan.t_end, every=plan.every), robot, traj,
                    plan.regulators, robot_notes, _notes(caught))


def _notes(caught) -> list[str]:
    return [str(w.message) for w in caught if issubclass(w.category, ManipcadWarning)]


#: where a result goes: called with the result, the robot that ran, the description, the
#: stored ``run`` document, the status ("ok" or "diverged") and the divergence message;
#: returns where it went (a folder, a workspace result's name)
ResultStore = Callable[..., Any]


def to_folder(out: str | Path, *, force: bool = False, csv: bool = False) -> ResultStore:
    """A :data:`ResultStore` that writes a result folder (:func:`manipcad.store.save_result`:
    atomically, the inputs copied into ``inputs/``, the robot as it ran).

    Args:
        out: the result folder.
        force: replace a result folder there (once the new one is complete).
        csv: also write timeseries.csv.
    """

    def store(result, *, robot, spec: RunSpec, run, status="ok", message="") -> Path:
        save_result(result, out, inputs=run_inputs(robot, spec), joint_types=robot.joint_types,
                    force=force, status=status, message=message, run=run, csv=csv)
        return Path(out)

    return store


def run_inputs(robot, spec: RunSpec) -> dict[str, Any]:
    """What a stored result keeps in ``inputs/``: the robot as it ran, drives included, as
    one self-contained file (a robot file that points to a URDF by a relative path would
    not re-run from the result folder), the trajectory and regulator files."""
    inputs: dict[str, Any] = {"robot": robot}
    if spec.trajectory is not None:
        inputs["trajectory"] = Path(spec.trajectory)
    if spec.regulators:
        inputs["regulator"] = [Path(r) for r in spec.regulators]
    return inputs


@dataclass
class Executed:
    """What :func:`execute` did.

    Attributes:
        prepared: the loaded run (:class:`Prepared`).
        result: the :class:`~manipcad.sim.SimulationResult` (``checks`` filled).
        checks: the run's :class:`~manipcad.sim.checks.RunChecks`.
        run: the stored description: :meth:`RunSpec.to_dict` of the settled spec, with the
            robot notes, the wall time (s) and the checks' verdict.
        wall: the simulation's wall time, s.
        where: where the store put it (None without a store).
    """

    prepared: Prepared
    result: Any
    checks: RunChecks
    run: dict[str, Any]
    wall: float
    where: Any = None


def execute(spec: RunSpec | Prepared, store: ResultStore | None = None,
            progress: Callable[[float], None] | None = None, *,
            save_diverged: bool = False) -> Executed:
    """Run one simulation from its description: load and check (:func:`prepare`, unless
    given prepared), simulate, check every rating, and store.

    Args:
        spec: the run (or its :func:`prepare` d form).
        store: where the result goes (:func:`to_folder`, a workspace's
            :func:`manipcad.workspace.runs.to_workspace`); None: nowhere.
        progress: called with the fraction done (0..1); an exception it raises stops
            the run and nothing is stored.
        save_diverged: a diverged run's partial result is stored too (status
            "diverged").

    Returns:
        :class:`Executed`.

    Raises:
        InputError: a bad file or setting (:func:`prepare`, :func:`manipcad.simulate`).
        SimulationDiverged: the run diverged; with ``save_diverged`` and a store its
            ``stored`` attribute says where the partial result went (else None).
    """
    p = spec if isinstance(spec, Prepared) else prepare(spec)
    s = p.spec
    run = s.to_dict()
    run["robot_notes"] = list(p.robot_notes)
    wall = time.perf_counter()
    try:
        res = simulate(p.robot, t_end=s.t_end, dt=s.dt, trajectory=p.trajectory,
                       regulators=p.regulators, payload=s.payload, drives=s.drives,
                       every=s.every, joint_limits=s.joint_limits, integrator=s.integrator,
                       rtol=s.rtol, atol=s.atol, order=s.order, use_generated=s.use_generated,
                       pickup=s.pickup, progress=progress)
    except SimulationDiverged as exc:
        exc.stored = None
        if save_diverged and store is not None:
            exc.stored = store(exc.result, robot=p.robot, spec=s, run=run, status="diverged",
                               message=str(exc))
        raise
    wall = time.perf_counter() - wall
    run["wall_time_s"] = wall
    checks = run_checks(res, p.robot, accuracy=s.accuracy, payload=s.payload,
                        max_saturation=s.max_saturation, max_chatter=s.max_chatter)
    res.checks = checks.to_dict()
    run["checks"]["verdict"] = checks.verdict
    where = (None if store is None
             else store(res, robot=p.robot, spec=s, run=run, status="ok", message=""))
    return Executed(p, res, checks, run, wall, where)


def stored_spec(folder: str | Path, doc: Mapping[str, Any]) -> RunSpec:
    """The description of a stored result's run, on the copies of its inputs: what a
    re-run executes.

    The stored ``run`` (:meth:`RunSpec.to_dict`) read by :meth:`RunSpec.from_dict`; for a
    result stored before it held every setting, the simulator's own record
    (``settings``: t_end, dt, drives, integrator, tolerances, order, the hard stops)
    fills what it lacks, and the record stride defaults to 1. The kernels are those the
    result ran on (``settings["generated"]``), so that the re-run is identical bit for
    bit.

    Args:
        folder: the result folder (its ``inputs/`` hold the robot, trajectory and
            regulator files).
        doc: its metrics.json document.

    Raises:
        InputError: no stored robot, no t_end or dt, or a bad stored setting (named).
    """
    folder = Path(folder)
    inputs = folder / INPUTS_DIR
    where = str(folder / METRICS_JSON)
    settings = dict(doc.get("settings") or {})
    run = {k: settings[k] for k in ("t_end", "dt", "drives", "integrator", "rtol", "atol",
                                    "order") if k in settings}
    if settings.get("joint_limits") == "hard-stop":
        run["joint_limits"] = "hard-stop"
    run.update(doc.get("run") or {})
    for key in ("t_end", "dt"):
        value = run.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float) \
                or not math.isfinite(value):
            raise InputError(where, f"run.{key}", "missing; cannot re-run")
    run["every"] = run.get("every") or 1
    robot_files = sorted(inputs.glob("robot.*"))
    if not robot_files:
        raise InputError(str(inputs), "robot", "no stored robot file; cannot re-run")
    traj_files = sorted(inputs.glob("trajectory.*"))
    run["robot"] = str(robot_files[0])
    run["trajectory"] = str(traj_files[0]) if traj_files else None
    run["regulators"] = [str(f) for f in sorted(inputs.glob("regulator*.*"),
                                                 key=_input_order)]
    if "generated" in settings:
        run["use_generated"] = bool(settings["generated"])
    return RunSpec.from_dict(run, where)


def _input_order(p: Path) -> tuple[int, str]:
    tail = p.stem.rsplit("-", 1)[-1]
    return (int(tail) if tail.isdigit() else 0, p.name)


__all__ = ["RunSpec", "Prepared", "Executed", "prepare", "execute", "to_folder",
           "run_inputs", "stored_spec", "ResultStore", "FACTS"]
