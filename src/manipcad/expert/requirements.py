"""Requirements to a drive's control (paper section 5), and how to derive them.

A :class:`Requirements` states what the designer asks and what the manipulator
is like; the rule base (``rules.yaml``, :mod:`manipcad.expert.engine`) turns it
into a ranked choice of synthesis methods. Every field may be left out (None);
the fields a robot and a trajectory determine can then be derived
(:func:`derive`):

==================== ===================================================================
field                meaning (unit)
==================== ===================================================================
accuracy             largest tracking error allowed, rad (revolute) or m (prismatic)
overshoot_allowed    may the transients overshoot (bool)
fast_action          is the fastest possible response asked (bool)
gripper_speed        peak speed of the gripper, m/s; derived: max |J_v(q)·q̇| along
                     the trajectory
inductance           ``negligible`` | ``significant``: is the armature's L/R small
                     next to the mechanical time constant; derived from the motors:
                     ``negligible`` when T_m/T_e > 10 (:data:`INDUCTANCE_RATIO`)
transmission         ``{backlash: bool, elasticity: bool}`` (not derivable: the robot
                     model has no transmission)
coupling             ``decoupled`` | ``inertial`` | ``full`` (the form of P_i, paper
                     section 2); derived from the coupling analysis
parameter_variation  ``slow`` | ``fast``: do the drive's load parameters change
                     slowly next to its own dynamics (the quasi-stationary hypothesis
                     of 3.1); derived from the rate of change of H_ii
load_variation       ρ = (J·i_r² + H_ii,max)/(J·i_r² + H_ii,min): how much the inertia
                     the motor moves varies along the trajectory (>= 1; 1: not at all);
                     derived from H_ii along the trajectory, the largest over the drives
joint                the joint whose drive is designed (name or 0-based index); None:
                     the whole robot, each derived field taken at its worst joint
==================== ===================================================================

Coupling classes (the paper's section 2, with the drive model of 3.1):

- ``decoupled``: P_i = H_ii·q̈_i + M_i, H_ii changing only with the gripped mass;
- ``inertial``: the other joints change the drive's own load parameters, H_ii(t)
  and the velocity coefficient h*(t) of P_i = H_ii·q̈_i + h_i + M_i with
  h_i = h*·i_r²·q̇_i (the load the ACE of (1) and law (3) stabilize; the turning
  drive of Fig. 2);
- ``full``: the general form of P_i: inertial coupling Σ_{j≠i} H_ij·q̈_j, velocity
  terms in the other joints' speeds alone, or gravity no balancer removes (3.3).

Derivation criteria (stated, so that they can be argued with):

- *gripper speed*: the peak over samples every :data:`SAMPLE_DT` s from 0 to the
  trajectory's duration;
- *coupling*: :func:`manipcad.analysis.coupling.coupling_analysis` (threshold ε =
  5 % of the own inertial peak). It calls a joint ``full`` whenever its velocity
  constituent h_i is ≥ ε; the part of h_i that is proportional to the joint's own
  speed, h_i(q̇) - h_i(q̇ with q̇_i = 0), is the h*·i_r²·q̇_i the drive model of 3.1
  already carries, so a joint whose *remaining* velocity constituent, coupling
  and unbalanced gravity are all < ε is ``inertial`` here (the turning drive of
  Fig. 2 under laws (2): h_1 = 2·m·r·ṙ·q̇_1);
- *inductance*: T_m/T_e > :data:`INDUCTANCE_RATIO` → ``negligible``, with
  T_e = L/R and T_m = (H*+J)·R/[(h*+k_v)·R + k_m·k_w] (the drive model's own,
  :func:`manipcad.drives.linear.mechanical_time_constant`) at the smallest H_ii along
  the trajectory (H* = 0, the rotor alone, without a trajectory) and h* = 0 —
  the smallest T_m, so the check is the strictest one;
- *parameter variation*: the quasi-stationary hypothesis of (1) holds when the
  drive's inertia changes little within one mechanical time constant, i.e. when
  ν = max_t |Ḣ_ii(t)|·T_m(t) / (H_ii(t) + J·i_r²) < :data:`VARIATION_LIMIT` (0.1:
  less than 10 % change per T_m, the load pole moving slowly next to the drive's
  own bandwidth 1/T_m) → ``slow``, else ``fast``. Ḣ_ii by central differences of
  H_ii sampled every :data:`SAMPLE_DT` s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    StrictBool,
    ValidationError,
    ValidationInfo,
    field_validator,
)

from manipcad.drives.linear import (
    electrical_time_constant,
    inertia_ratio,
    mechanical_time_constant,
)
from manipcad.dynamics import inverse_dynamics, mass_matrix
from manipcad.errors import InputError, ManipcadError
from manipcad.fileio import read_yaml, validation_error
from manipcad.model import load_robot
from manipcad.model.yaml_robot import OptNum
from manipcad.trajectories import load_trajectory
from manipcad.trajectories.speed import gripper_speed

COUPLING = ("decoupled", "inertial", "full")
INDUCTANCE = ("negligible", "significant")
VARIATION = ("slow", "fast")

#: T_m / T_e above which the inductance counts as negligible (the paper's T_m >> L/R)
INDUCTANCE_RATIO = 10.0
#: ν = max |Ḣ_ii|·T_m/(H_ii + J·i_r²) below which the load varies slowly (quasi-stationary)
VARIATION_LIMIT = 0.1
#: sampling step of the derivations along a trajectory, s
SAMPLE_DT = 1e-3

#: the fields in their dotted form (the ones rule conditions may name)
FIELDS = ("accuracy", "overshoot_allowed", "fast_action", "gripper_speed", "inductance",
          "transmission.backlash", "transmission.elasticity", "coupling",
          "parameter_variation", "load_variation")
#: fields a robot and a trajectory can determine
DERIVABLE = ("gripper_speed", "coupling", "inductance", "parameter_variation",
             "load_variation")


class TransmissionFeatures(BaseModel):
    """Features of the mechanical transmission: backlash (a gap), elasticity (a spring)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    backlash: StrictBool | None = None
    elasticity: StrictBool | None = None


#: the numeric fields' ranges: field -> (test of a finite value, what it must be)
_BOUNDS = {
    "accuracy": (lambda v: v > 0, "a finite number > 0 (rad or m)"),
    "load_variation": (lambda v: v >= 1, "a finite ratio >= 1"),
    "gripper_speed": (lambda v: v >= 0, "a finite number >= 0 m/s"),
}


class Requirements(BaseModel):
    """What is asked of a drive's control and what the manipulator is like (paper 5).

    Every field may be None (not given); see the module docstring for the fields,
    their units and how the derivable ones are derived. Numbers may be written as
    expressions with the constants of robot files, e.g. ``accuracy: 0.05*deg``.

    Example:
        >>> from manipcad.expert import Requirements
        >>> r = Requirements(accuracy=1e-3, gripper_speed=4.0, coupling="inertial")
        >>> r.get("transmission.backlash") is None
        True
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    accuracy: OptNum = None          # largest tracking error, rad or m (> 0)
    overshoot_allowed: StrictBool | None = None
    fast_action: StrictBool | None = None
    gripper_speed: OptNum = None     # peak gripper speed, m/s (>= 0)
    inductance: Literal["negligible", "significant"] | None = None
    transmission: TransmissionFeatures = TransmissionFeatures()
    coupling: Literal["decoupled", "inertial", "full"] | None = None
    parameter_variation: Literal["slow", "fast"] | None = None
    load_variation: OptNum = None    # (J·i_r² + H_max)/(J·i_r² + H_min), >= 1
    joint: str | int | None = None

    @field_validator(*_BOUNDS)
    @classmethod
    def _in_range(cls, v: float | None, info: ValidationInfo) -> float | None:
        ok, what = _BOUNDS[info.field_name]
        if v is not None and not (math.isfinite(v) and ok(v)):
            raise ValueError(f"must be {what}, got {v}")
        return v

    # ------------------------------------------------------------------ access

    def get(self, field: str) -> Any:
        """A field's value by its dotted name (``"transmission.backlash"``); None if not given."""
        obj: Any = self
        for part in field.split("."):
            obj = getattr(obj, part)
        return obj

    def given(self) -> dict[str, Any]:
        """The given fields (dotted names) and their values."""
        return {f: self.get(f) for f in FIELDS if self.get(f) is not None}

    def with_values(self, values: dict[str, Any]) -> Requirements:
        """A copy with some dotted fields set."""
        data = self.model_dump()
        for key, v in values.items():
            if key.startswith("transmission."):
                data["transmission"][key.split(".", 1)[1]] = v
            else:
                data[key] = v
        return Requirements.model_validate(data)

    # ------------------------------------------------------------------ loading

    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>") -> Requirements:
        """Validate a plain mapping; bad data raises :class:`InputError` (source, field, reason)."""
        if isinstance(data, Requirements):
            return data
        if not isinstance(data, dict):
            raise InputError(source, "", f"expected a mapping of requirement fields, got "
                             f"{type(data).__name__}")
        try:
            return cls.model_validate(data)
        except ValidationError as exc:
            def reason(err: Mapping[str, Any]) -> str:
                if err["type"] == "extra_forbidden":
                    return (f"unknown field; known: {', '.join(cls.model_fields)} "
                            "(transmission: backlash, elasticity)")
                if err["type"] == "literal_error":
                    return f"{err['msg']}, got {err.get('input')!r}"
                if err["type"] == "bool_type":
                    return f"expected true or false, got {err.get('input')!r}"
                return err["msg"]

            raise validation_error(source, exc, reason, skip={"str", "int"}) from None

    @classmethod
    def from_yaml(cls, path: str | Path) -> Requirements:
        """Load a requirements YAML file (a mapping of the fields; SI units).

        Raises:
            InputError: naming the file, the field and the reason.
        """
        src = str(path)
        data = read_yaml(path, "a mapping of requirement fields")
        return cls.from_dict(data, src)

    @classmethod
    def coerce(cls, value: Requirements | dict | str | Path) -> Requirements:
        """A :class:`Requirements` from itself, a plain dict or a YAML file path."""
        if isinstance(value, Requirements):
            return value
        if isinstance(value, dict):
            return cls.from_dict(value)
        if isinstance(value, str | Path):
            return cls.from_yaml(value)
        raise InputError("requirements", "", "expected a Requirements, a dict or a YAML "
                         f"file path, got {type(value).__name__}")


# ---------------------------------------------------------------------- derivation


@dataclass(frozen=True)
class Derivation:
    """How a field was derived (``value`` set) or why it could not be (``error`` set)."""

    field: str
    value: Any = None
    how: str = ""
    error: str = ""


def _samples(trajectory) -> np.ndarray:
    T = float(trajectory.duration)
    if not (math.isfinite(T) and T > 0):
        raise ManipcadError(f"the trajectory's duration must be finite and > 0 s, got {T}")
    return np.linspace(0.0, T, max(int(round(T / SAMPLE_DT)) + 1, 11))


def _joints(robot, req: Requirements) -> list[int]:
    if req.joint is None:
        return list(range(robot.n))
    try:
        return [robot.joint_index(req.joint)]
    except (KeyError, IndexError, ValueError, TypeError):
        raise InputError("requirements", "joint", f"robot {robot.name!r} has no joint "
                         f"{req.joint!r}; joints: {', '.join(robot.joint_names)}") from None


def _driven(robot, joints: list[int]) -> list[int]:
    drives = robot.drives or ()
    return [j for j in joints if j < len(drives) and drives[j] is not None]


def derive_gripper_speed(robot, trajectory) -> Derivation:
    """Peak gripper speed along the trajectory, m/s (from the Jacobian)."""

    t = _samples(trajectory)
    v = np.asarray(gripper_speed(robot, trajectory, t))
    k = int(np.argmax(v))
    return Derivation("gripper_speed", float(v[k]),
                      f"peak of |J_v(q)·q̇| = {v[k]:.3g} m/s at t = {t[k]:.3g} s")


def _own_velocity_split(robot, trajectory, j: int) -> float:
    """Peak of the velocity constituent of joint j that is not proportional to q̇_j."""

    q, qd, _ = trajectory.sample(_samples(trajectory))
    qd_other = qd.copy()
    qd_other[:, j] = 0.0
    h = inverse_dynamics(robot, q, qd_other, np.zeros_like(q), gravity=np.zeros(3),
                         drives=False)
    return float(np.abs(h[:, j]).max())


def derive_coupling(robot, trajectory, joints: list[int]) -> Derivation:
    """The coupling class (worst over ``joints``) from the coupling analysis."""
    try:
        # deferred: a missing analysis is reported as a requirement not derived
        from manipcad.analysis.coupling import coupling_analysis
    except ImportError as exc:
        return Derivation("coupling", error="cannot be derived: the coupling analysis "
                          f"(manipcad.analysis.coupling) is not available ({exc})")
    rep = coupling_analysis(robot, trajectory, dt=SAMPLE_DT)
    eps = rep.threshold
    classes, notes = [], []
    for j in joints:
        jc = rep.joints[j]
        cls = jc.classification
        if cls == "full" and jc.inertial_peak > 0 and jc.coupling_ratio < eps \
                and jc.gravity_after_balancer_ratio < eps:
            foreign = _own_velocity_split(robot, trajectory, j) / jc.inertial_peak
            if foreign < eps:
                cls = "inertial"
                notes.append(f"{jc.joint}: full by the analysis (velocity constituent "
                             f"{jc.velocity_ratio:.0%}), but the part not proportional to "
                             f"q̇_{j + 1} is {foreign:.1%} < {eps:.0%} and the drive model "
                             "carries h*·i_r²·q̇_i: inertial")
        if not notes or not notes[-1].startswith(f"{jc.joint}:"):
            notes.append(f"{jc.joint}: {cls}")
        classes.append(cls)
    worst = max(classes, key=COUPLING.index)
    return Derivation("coupling", worst, "coupling analysis (ε = "
                      f"{eps:.0%}): " + "; ".join(notes))


def derive_inductance(robot, trajectory, joints: list[int]) -> Derivation:
    """``negligible`` when T_m/T_e > INDUCTANCE_RATIO for every drive in ``joints``."""
    driven = _driven(robot, joints)
    if not driven:
        return Derivation("inductance", error="cannot be derived: no drive on the joint(s)")
    H_min = {}
    if trajectory is not None:

        q, _, _ = trajectory.sample(_samples(trajectory))
        H = mass_matrix(robot, q, drives=False)
        H_min = {j: float(H[:, j, j].min()) for j in driven}
    worst, notes = math.inf, []
    for j in driven:
        d = robot.drives[j]
        if not (math.isfinite(d.L) and math.isfinite(d.R) and d.R > 0):
            return Derivation("inductance", error=f"cannot be derived: the drive of "
                              f"{robot.joint_names[j]!r} has no R or L")
        if d.L == 0:
            ratio = math.inf
        else:
            ratio = (mechanical_time_constant(d, H_min.get(j, 0.0))
                     / electrical_time_constant(d))
        notes.append(f"{robot.joint_names[j]}: T_m/T_e = {ratio:.3g}")
        worst = min(worst, ratio)
    value = "negligible" if worst > INDUCTANCE_RATIO else "significant"
    load = "smallest H_ii along the trajectory" if trajectory is not None else "rotor alone"
    return Derivation("inductance", value, f"T_m/T_e > {INDUCTANCE_RATIO:g} → negligible "
                      f"(T_m at the {load}, h* = 0): " + "; ".join(notes))


def derive_parameter_variation(robot, trajectory, joints: list[int]) -> Derivation:
    """``slow`` when ν = max |Ḣ_ii|·T_m/(H_ii + J·i_r²) < VARIATION_LIMIT for every drive."""

    driven = _driven(robot, joints)
    if not driven:
        return Derivation("parameter_variation",
                          error="cannot be derived: no drive on the joint(s)")
    t = _samples(trajectory)
    q, _, _ = trajectory.sample(t)
    H = mass_matrix(robot, q, drives=False)
    worst, notes = 0.0, []
    for j in driven:
        d = robot.drives[j]
        Hj = H[:, j, j]
        Hdot = np.gradient(Hj, t)
        Tm = np.array([mechanical_time_constant(d, h) for h in Hj])      # s, h* = 0
        nu = float(np.max(np.abs(Hdot) * Tm / (Hj + d.reflected_inertia)))
        notes.append(f"{robot.joint_names[j]}: ν = {nu:.3g} (max |Ḣ_ii| = "
                     f"{np.abs(Hdot).max():.3g}, T_m in [{Tm.min():.3g}, {Tm.max():.3g}] s)")
        worst = max(worst, nu)
    value = "slow" if worst < VARIATION_LIMIT else "fast"
    return Derivation("parameter_variation", value,
                      f"ν = max |Ḣ_ii|·T_m/(H_ii + J·i_r²) < {VARIATION_LIMIT:g} → slow "
                      "(quasi-stationary): " + "; ".join(notes))


def derive_load_variation(robot, trajectory, joints: list[int]) -> Derivation:
    """ρ = (J·i_r² + H_ii,max)/(J·i_r² + H_ii,min) along the trajectory, worst over ``joints``."""

    driven = _driven(robot, joints)
    if not driven:
        return Derivation("load_variation", error="cannot be derived: no drive on the joint(s)")
    q, _, _ = trajectory.sample(_samples(trajectory))
    H = mass_matrix(robot, q, drives=False)
    worst, notes = 1.0, []
    for j in driven:
        d = robot.drives[j]
        rho = float(inertia_ratio(d, H[:, j, j].min(), H[:, j, j].max()))
        notes.append(f"{robot.joint_names[j]}: ρ = {rho:.3g}")
        worst = max(worst, rho)
    return Derivation("load_variation", worst, "ρ = (J·i_r² + H_ii,max)/(J·i_r² + H_ii,min) "
                      "along the trajectory: " + "; ".join(notes))


def derive(req: Requirements, robot=None, trajectory=None, *, check: bool = True,
           ) -> tuple[Requirements, dict[str, Derivation], list[str]]:
    """Fill the fields not given that the robot and the trajectory determine.

    Given fields are kept as given. A field that cannot be derived (no robot or
    trajectory, no drive, the coupling analysis missing) stays None and its
    :class:`Derivation` says why; the engine reports it only if a rule needs it.
    With ``check``, the given derivable fields are derived too and compared: a
    given gripper speed below the trajectory's peak (by more than 5 %) or a
    given class that differs from the derived one gives a note (the given value
    is used: it may be the designer's deliberate judgement).

    Args:
        req: the requirements.
        robot: a :class:`~manipcad.model.robot.Robot`, a catalog name or a file.
        trajectory: a :class:`~manipcad.trajectories.base.Trajectory` or a YAML file.
        check: compare the given derivable fields with the derived values.

    Returns:
        (the requirements with the derived fields set, {field: Derivation} of
        the fields not given, notes on given fields that disagree).
    """
    out: dict[str, Derivation] = {}
    notes: list[str] = []
    todo = [f for f in DERIVABLE if req.get(f) is None]
    if robot is None:
        for f in todo:
            out[f] = Derivation(f, error="not given, and no robot to derive it from")
        return req, out, notes

    robot = load_robot(robot)
    if isinstance(trajectory, str | Path):

        trajectory = load_trajectory(trajectory, robot=robot)
    if trajectory is not None and trajectory.n != robot.n:
        raise InputError("trajectory", "", f"has {trajectory.n} joints; robot "
                         f"{robot.name!r} has {robot.n}")
    joints = _joints(robot, req)
    values = {}
    for f in DERIVABLE:
        given = req.get(f)
        if given is not None and not check:
            continue
        if trajectory is None and f != "inductance":
            if given is None:
                out[f] = Derivation(f, error="not given, and no trajectory to derive it from")
            continue
        try:
            if f == "gripper_speed":
                dv = derive_gripper_speed(robot, trajectory)
            elif f == "coupling":
                dv = derive_coupling(robot, trajectory, joints)
            elif f == "inductance":
                dv = derive_inductance(robot, trajectory, joints)
            elif f == "load_variation":
                dv = derive_load_variation(robot, trajectory, joints)
            else:
                dv = derive_parameter_variation(robot, trajectory, joints)
        except ManipcadError as exc:
            dv = Derivation(f, error=f"cannot be derived: {exc}")
        if given is None:
            out[f] = dv
            if dv.value is not None:
                values[f] = dv.value
        elif dv.value is not None:
            if f == "load_variation":
                if abs(dv.value - given) > 0.05 * given:
                    notes.append(f"load_variation is given as {given:g} but the robot and "
                                 f"trajectory give {dv.value:.3g} ({dv.how}); the given value "
                                 "is used")
            elif f == "gripper_speed":
                if dv.value > 1.05 * given:
                    notes.append(f"gripper_speed is given as {given:g} m/s but the trajectory "
                                 f"reaches {dv.value:.3g} m/s ({dv.how}); the given value is used")
            elif dv.value != given:
                notes.append(f"{f} is given as {given!r} but the robot and trajectory give "
                             f"{dv.value!r} ({dv.how}); the given value is used")
    return (req.with_values(values) if values else req), out, notes
