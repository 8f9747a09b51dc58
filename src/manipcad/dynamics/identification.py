"""Identification of an unknown payload mass m_r from drive torques (paper 4.1).

The paper separates the terms that hold the unknown mass in the inverse
dynamics and computes m_r from the measured drive torques and the torques the
unloaded robot would need, "from one drive only or (more exactly) from the
drives k"; when the manipulator can make short stops, a simpler static method.

For a point mass m_r at a known position ``com`` on the carrying link the
torque is affine in m_r, because the recursive Newton-Euler algorithm is
linear in the links' inertial parameters (mass, first moment, inertia about
the body origin):

    tau(q, q̇, q̈) = tau_0(q, q̇, q̈) + m_r · g(q, q̇, q̈)

- tau_0: the inverse dynamics of the unloaded robot (with the drive terms
  J·i_r²·q̈ + k_v·i_r²·q̇ + |i_r|·M_f·sign(q̇) when ``drives=True``), N·m or N;
- g: the torque a 1 kg point mass at ``com`` needs, N·m/kg or N/kg: the
  inverse dynamics of a copy of the robot whose links are massless and which
  carries only that 1 kg. It equals ``ID(robot.with_payload(1, com)) - tau_0``
  exactly, without the cancellation of that difference.

Each drive j and sample t gives one equation y_tj = tau_tj - tau_0,tj =
m_r·g_tj + e_tj; m_r is their least-squares solution. With several drives the
torque noise differs per drive (and N·m and N do not mix), so the equations are
weighted by each drive's noise variance, estimated from its own residuals of a
first unweighted fit (feasible weighted least squares; with fewer than
``MIN_SAMPLES_FOR_WEIGHTS`` samples, or one drive, the plain fit is kept). The
standard deviation follows from the residual variance and the regressor:
var(m_r) = 1 / Σ_j Σ_t g_tj² / σ_j² (weighted) or s² / Σ g² (plain).

Static method (short stops, q̇ = q̈ = 0): the same fit with only the gravity
regressor g(q) = -J_c(q)ᵀ·(1 kg)·g_vec; the drive terms vanish at rest in the
model (measured torques at rest include the stiction of the gears, which the
model does not know: stop long enough for the torque to settle and approach
each stop from both sides, or use the motion data).
"""

from __future__ import annotations

import csv
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from manipcad.dynamics.api import inverse_dynamics
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.fileio import read_text
from manipcad.model.robot import REVOLUTE, Robot

SOURCE = "identify_payload"
#: a drive whose regressor RMS is below this (N·m/kg or N/kg) gives no excitation
EXCITATION_ABS = 1e-9
#: ... or below this fraction of the strongest drive's regressor RMS
EXCITATION_REL = 1e-6
#: samples needed before the drives are weighted by their estimated noise
MIN_SAMPLES_FOR_WEIGHTS = 10


@dataclass(frozen=True)
class PayloadEstimate:
    """The identified payload mass and how well the data determine it.

    Attributes:
        mass: m_r, kg (returned as found, negative values included: see the warning).
        std: standard deviation of ``mass`` from the residual variance and the
            regressor, kg (nan with a single equation).
        residual: RMS of the fit residuals over the drives and samples used, N·m
            (N for prismatic joints).
        joints: indices of the drives used (0-based, the robot's joint order).
        joint_names: their names.
        method: "dynamic" (motion: inertial, velocity and gravity terms) or
            "static" (short stops, q̇ = q̈ = 0: gravity only).
        samples: number of samples (states) N.
        com: the payload's assumed centre of mass in the carrying link's body frame, m.
        link: index of the carrying link (joint).
        weighting: "noise" (drives weighted by their estimated noise variance)
            or "equal" (plain least squares).
        per_joint_mass: m_r from each drive used alone, kg, shape (k,).
        per_joint_std: its standard deviation, kg, shape (k,).
        per_joint_residual: RMS residual of each drive in the joint fit, N·m or N, (k,).
        excitation: RMS of each drive's regressor g along the samples, N·m/kg
            (N/kg for prismatic joints), shape (k,): how strongly the payload
            shows in that drive.
    """

    mass: float
    std: float
    residual: float
    joints: tuple[int, ...]
    joint_names: tuple[str, ...]
    method: str
    samples: int
    com: np.ndarray = field(repr=False)
    link: int = -1
    weighting: str = "equal"
    per_joint_mass: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    per_joint_std: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    per_joint_residual: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    excitation: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    def to_dict(self) -> dict:
        """A JSON-ready mapping (SI units: kg, N·m or N, m)."""
        def num(x: float):
            return None if not math.isfinite(x) else float(x)

        return {
            "mass_kg": num(self.mass), "std_kg": num(self.std),
            "residual_rms": num(self.residual), "method": self.method,
            "samples": self.samples, "weighting": self.weighting,
            "link": self.link, "com_m": [float(c) for c in self.com],
            "joints": [
                {"index": j, "name": nm, "mass_kg": num(m), "std_kg": num(s),
                 "residual_rms": num(r), "excitation_per_kg": num(e)}
                for j, nm, m, s, r, e in zip(
                    self.joints, self.joint_names, self.per_joint_mass, self.per_joint_std,
                    self.per_joint_residual, self.excitation, strict=True)
            ],
        }

    def __str__(self) -> str:
        return (f"payload mass {self.mass:.4g} ± {self.std:.2g} kg ({self.method}, "
                f"{self.samples} samples, drives {', '.join(self.joint_names)}; "
                f"residual RMS {self.residual:.3g})")


def payload_regressor(robot: Robot, q, qd, qdd, *, com=None, link: int | str = -1) -> np.ndarray:
    """The torque a 1 kg point mass at ``com`` on ``link`` needs along a motion.

    Args:
        robot: the manipulator (its links' own masses do not matter here).
        q, qd, qdd: joint positions, velocities, accelerations (rad, rad/s, rad/s²
            or m, m/s, m/s²), shape (n,) or (N, n).
        com: the point mass's position in the link's body frame, m; default the origin.
        link: the carrying link (joint index or name), default the last.

    Returns:
        g, N·m/kg (N/kg for prismatic joints), shaped like q: the inverse dynamics
        of a copy of the robot with massless links carrying only the 1 kg (no
        drive terms), equal to ``ID(robot.with_payload(1, com)) - ID(robot)``.

    Example:
        >>> import numpy as np, manipcad
        >>> from manipcad.dynamics.identification import payload_regressor
        >>> puma = manipcad.load_robot("puma560")
        >>> payload_regressor(puma, np.zeros(6), np.zeros(6), np.zeros(6)).shape
        (6,)
    """
    unit = _unit_payload_robot(robot, _com(com), robot.joint_index(link))
    return inverse_dynamics(unit, q, qd, qdd, drives=False)


def identify_payload(robot: Robot, q, qd, qdd, tau, *, com=None, joints=None,
                     drives: bool = True, link: int | str = -1) -> PayloadEstimate:
    """Identify an unknown payload mass m_r on the last link from drive torques.

    Least squares over the chosen drives and all samples of
    tau - tau_0 = m_r · g (see the module docstring): tau_0 is what the unloaded
    robot needs, g what 1 kg at ``com`` needs. With ``qd`` and ``qdd`` None or
    all zero (short stops) the static method (gravity only) is used.

    Args:
        robot: the unloaded manipulator (its known links and drives).
        q: joint positions, rad or m, shape (n,) or (N, n).
        qd: joint velocities, rad/s or m/s, same shape; None at stops.
        qdd: joint accelerations, rad/s² or m/s², same shape; None at stops.
        tau: measured drive torques, N·m (N for prismatic joints), same shape.
        com: the payload's centre of mass in the carrying link's body frame, m,
            shape (3,); default the frame's origin.
        joints: the drives to use: indices (0-based) or names, one or a list;
            default every drive the payload acts on along these samples (a
            drive it does not act on, such as a vertical first axis at rest,
            is left out). Naming a drive that sees no payload is an error.
        drives: ``tau`` includes the drive terms (rotor inertia, friction) of
            the robot's drive models; False: ``tau`` is the rigid-body torque.
        link: the carrying link (joint index or name), default the last.

    Returns:
        :class:`PayloadEstimate` (``.mass`` kg, ``.std`` kg, ``.residual`` N·m
        RMS, ``.joints``, ``.method``, and the per-drive estimates).

    Raises:
        InputError: wrong shapes, NaN or infinite values, unknown or repeated
            joints, no excitation (the payload exerts no torque on the chosen
            drives along these samples).

    Warns:
        ManipcadWarning: the identified mass is negative (returned as found, not
            clipped: the data, the assumed ``com`` or the model disagree).

    Example:
        >>> import numpy as np, manipcad
        >>> puma = manipcad.load_robot("puma560")
        >>> q = np.random.default_rng(0).uniform(-1, 1, (20, 6))
        >>> z = np.zeros_like(q)
        >>> tau = manipcad.inverse_dynamics(puma.with_payload(2.0), q, z, z)
        >>> est = identify_payload(puma, q, None, None, tau)
        >>> round(est.mass, 6), est.method
        (2.0, 'static')
    """
    if not isinstance(robot, Robot):
        raise InputError(SOURCE, "robot", f"expected a manipcad Robot, got {type(robot).__name__}")
    n = robot.n
    Q = _states("q", q, n)
    N = Q.shape[0]
    QD = np.zeros_like(Q) if qd is None else _states("qd", qd, n, N)
    QDD = np.zeros_like(Q) if qdd is None else _states("qdd", qdd, n, N)
    T = _states("tau", tau, n, N)
    c = _com(com)
    try:
        i_link = robot.joint_index(link)
    except ManipcadError as exc:
        raise InputError(SOURCE, "link", str(exc)) from None
    static = not QD.any() and not QDD.any()

    tau0 = inverse_dynamics(robot, Q, QD, QDD, drives=drives)
    G = inverse_dynamics(_unit_payload_robot(robot, c, i_link), Q, QD, QDD, drives=False)
    Y = T - tau0
    excitation = np.sqrt(np.mean(G**2, axis=0))
    strongest = float(excitation.max())
    weak = (excitation <= EXCITATION_ABS) | (excitation <= EXCITATION_REL * strongest)
    sel = _select(robot, joints, weak, excitation, static, c, i_link)

    Gs, Ys = G[:, sel], Y[:, sel]
    k = len(sel)
    M = Gs.size
    gg = np.sum(Gs**2, axis=0)  # per drive, (N·m/kg)²
    gy = np.sum(Gs * Ys, axis=0)
    # unweighted fit over all equations
    m = float(gy.sum() / gg.sum())
    R = Ys - m * Gs
    weighting = "equal"
    if k > 1 and N >= MIN_SAMPLES_FOR_WEIGHTS:
        weighting = "noise"
        for _ in range(2):  # estimate each drive's noise variance, refit
            var = _drive_variance(R, Ys, M)
            w = 1.0 / var
            m = float((w * gy).sum() / (w * gg).sum())
            R = Ys - m * Gs
        var = _drive_variance(R, Ys, M)
        std = math.sqrt(1.0 / float((gg / var).sum()))
    else:
        s2 = float(np.sum(R**2)) / (M - 1) if M > 1 else math.nan
        std = math.sqrt(s2 / float(gg.sum())) if M > 1 else math.nan

    # each drive alone: the paper's "from one drive only"
    m_j = gy / gg
    R_j = Ys - m_j * Gs
    if N > 1:
        std_j = np.sqrt(np.sum(R_j**2, axis=0) / (N - 1) / gg)
    else:
        std_j = np.full(k, math.nan)

    est = PayloadEstimate(
        mass=m, std=std, residual=float(np.sqrt(np.mean(R**2))),
        joints=tuple(int(j) for j in sel), joint_names=tuple(robot.joint_names[j] for j in sel),
        method="static" if static else "dynamic", samples=N, com=c, link=i_link,
        weighting=weighting, per_joint_mass=m_j, per_joint_std=std_j,
        per_joint_residual=np.sqrt(np.mean(R**2, axis=0)), excitation=excitation[sel])
    if m < 0:
        warnings.warn(ManipcadWarning(
            f"the identified payload mass is negative: {m:.4g} ± {std:.2g} kg (returned as "
            "found, not clipped); the measured torques are below what the unloaded robot "
            "needs: check the torque sign and units, the assumed com, the drive friction "
            "model and the robot's own link masses"), stacklevel=2)
    return est


# ------------------------------------------------------------------ CSV data files


@dataclass(frozen=True)
class TorqueData:
    """Samples read from a torque data file, each array (N, n) in SI units.

    Attributes:
        q: joint positions, rad or m.
        qd: joint velocities, rad/s or m/s; None when the file has no qd columns (stops).
        qdd: joint accelerations, rad/s² or m/s²; None when the file has no qdd columns.
        tau: measured drive torques, N·m or N.
        source: the file.
    """

    q: np.ndarray
    qd: np.ndarray | None
    qdd: np.ndarray | None
    tau: np.ndarray
    source: str = ""


KINDS = ("q", "qd", "qdd", "tau")
UNITS = {"q": "rad or m", "qd": "rad/s or m/s", "qdd": "rad/s² or m/s²", "tau": "N·m or N"}
TIME_COLUMNS = ("t", "time")


def column_names(robot: Robot) -> dict[str, tuple[str, int]]:
    """Accepted CSV header names -> (kind, joint index).

    Per joint i (1-based number k = i + 1, name NAME): ``q{k}``, ``qd{k}``,
    ``qdd{k}``, ``tau{k}`` and ``q_NAME``, ``qd_NAME``, ``qdd_NAME``, ``tau_NAME``.

    Example:
        >>> import manipcad
        >>> names = column_names(manipcad.load_robot("cylindrical"))
        >>> names["qd2"], names["tau_reach"]
        (('qd', 1), ('tau', 2))
    """
    out: dict[str, tuple[str, int]] = {}
    for i in range(robot.n):
        for kind in KINDS:
            out[f"{kind}{i + 1}"] = (kind, i)
    for i, name in enumerate(robot.joint_names):
        for kind in KINDS:
            out.setdefault(f"{kind}_{name}", (kind, i))  # a number form wins a clash
    return out


def load_torque_data(path: str | Path, robot: Robot) -> TorqueData:
    """Read a CSV file of joint states and measured drive torques.

    Format: comma-separated, one header line, then one sample per line; lines
    starting with ``#`` and blank lines are skipped. Columns (any order), per
    joint numbered 1..n or named by the robot's joint names:

    - ``q1..qn`` or ``q_NAME``: positions, rad (revolute) or m (prismatic);
    - ``qd1..qdn`` or ``qd_NAME``: velocities, rad/s or m/s;
    - ``qdd1..qddn`` or ``qdd_NAME``: accelerations, rad/s² or m/s²;
    - ``tau1..taun`` or ``tau_NAME``: measured drive torques, N·m or N;
    - optionally ``t`` or ``time`` (s), read and ignored.

    q and tau are required for every joint; qd and qdd for every joint or for
    none (samples at stops: the static method).

    Args:
        path: the CSV file.
        robot: the robot whose joints the columns name.

    Returns:
        :class:`TorqueData`.

    Raises:
        InputError: naming the file, the line and column, and the reason (no
            such file, no header, unknown, repeated or missing column, wrong
            number of fields, a value that is not a finite number, no data).
    """
    src = str(path)
    text = read_text(path, src, encoding="utf-8-sig")
    accepted = column_names(robot)
    header: list[str] | None = None
    cols: list[tuple[str, int] | None] = []
    rows: list[list[float]] = []
    for lineno, fields in _csv_lines(src, text):
        if header is None:
            header = [f.strip() for f in fields]
            cols = _header(src, lineno, header, accepted, robot)
            continue
        if len(fields) != len(header):
            raise InputError(src, f"line {lineno}", f"{len(fields)} fields, the header has "
                             f"{len(header)}")
        row = []
        for name, value in zip(header, fields, strict=True):
            try:
                x = float(value)
            except ValueError:
                raise InputError(src, f"line {lineno}, column {name}",
                                 f"{value.strip()!r} is not a number") from None
            if not math.isfinite(x):
                raise InputError(src, f"line {lineno}, column {name}",
                                 f"{value.strip()!r} is not a finite number")
            row.append(x)
        rows.append(row)
    if header is None:
        raise InputError(src, "", "empty file: expected a header line (q1.., tau1.., ...) "
                         "and data lines")
    if not rows:
        raise InputError(src, "", "no data lines after the header")
    data = np.asarray(rows, dtype=float)
    arrays = {kind: None for kind in KINDS}
    for kind in KINDS:
        idx = [next((c for c, col in enumerate(cols) if col == (kind, i)), -1)
               for i in range(robot.n)]
        if all(c >= 0 for c in idx):
            arrays[kind] = data[:, idx]
    return TorqueData(arrays["q"], arrays["qd"], arrays["qdd"], arrays["tau"], src)


def _csv_lines(src: str, text: str):
    """(line number, fields) of the non-blank, non-comment lines."""
    lines = text.splitlines()
    for lineno, line in enumerate(lines, start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        try:
            fields = next(csv.reader([line]))
        except csv.Error as exc:
            raise InputError(src, f"line {lineno}", f"not a CSV line: {exc}") from None
        yield lineno, fields


def _header(src: str, lineno: int, header: list[str], accepted: dict, robot: Robot):
    cols: list[tuple[str, int] | None] = []
    seen: dict[tuple[str, int], str] = {}
    for k, name in enumerate(header, start=1):
        if name.lower() in TIME_COLUMNS:
            cols.append(None)
            continue
        if name not in accepted:
            n = robot.n
            raise InputError(src, f"line {lineno}, column {k}",
                             f"unknown column {name!r}; expected q1..q{n}, qd1..qd{n}, "
                             f"qdd1..qdd{n}, tau1..tau{n} (or q_NAME, ... with the joint "
                             f"names {', '.join(robot.joint_names)}) and optionally t")
        key = accepted[name]
        if key in seen:
            raise InputError(src, f"line {lineno}, column {k}",
                             f"column {name!r} repeats column {seen[key]!r}")
        seen[key] = name
        cols.append(key)
    for kind in KINDS:
        missing = [f"{kind}{i + 1}" for i in range(robot.n) if (kind, i) not in seen]
        if not missing:
            continue
        if kind in ("q", "tau") or len(missing) < robot.n:
            need = "required" if kind in ("q", "tau") else "needed when any qd/qdd column is given"
            raise InputError(src, f"line {lineno}",
                             f"missing column(s) {', '.join(missing)} ({UNITS[kind]}; {need})")
    qd_given = any(k[0] == "qd" for k in seen)
    qdd_given = any(k[0] == "qdd" for k in seen)
    if qd_given != qdd_given:
        raise InputError(src, f"line {lineno}", "give both the qd and the qdd columns, or "
                         "neither (samples at stops)")
    return cols


# ------------------------------------------------------------------ helpers


def _states(name: str, x, n: int, N: int | None = None) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(SOURCE, name, "expected an array of numbers") from None
    if a.ndim == 1:
        a = a.reshape(1, -1)
    if a.ndim != 2 or a.shape[1] != n:
        raise InputError(SOURCE, name, f"must have shape (n,) or (N, n) with n = {n} joints, "
                         f"got {np.shape(x)}")
    if N is not None and a.shape[0] != N:
        raise InputError(SOURCE, name, f"has {a.shape[0]} samples, q has {N}")
    if a.shape[0] == 0:
        raise InputError(SOURCE, name, "no samples")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        raise InputError(SOURCE, f"{name}[{bad[0, 0]}, {bad[0, 1]}]", "is not a finite number")
    return np.ascontiguousarray(a)


def _com(com) -> np.ndarray:
    if com is None:
        return np.zeros(3)
    try:
        c = np.asarray(com, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(SOURCE, "com", "expected three numbers x, y, z in m") from None
    if c.shape != (3,) or not np.isfinite(c).all():
        raise InputError(SOURCE, "com", f"expected three finite numbers x, y, z in m, got {com!r}")
    return c


def _unit_payload_robot(robot: Robot, com: np.ndarray, link: int) -> Robot:
    """The robot with massless links and no drives, carrying 1 kg at ``com`` on ``link``."""
    n = robot.n
    bare = robot.replace(mass=np.zeros(n), com=np.zeros((n, 3)), inertia=np.zeros((n, 3, 3)),
                         drives=(None,) * n)
    return bare.with_payload(1.0, com, link=link)


def _select(robot: Robot, joints, weak: np.ndarray, excitation: np.ndarray, static: bool,
            com: np.ndarray, link: int) -> np.ndarray:
    """The drives to use, as indices; raises InputError on bad names or no excitation."""
    where = (f"a point mass at com = {com.tolist()} m on link {robot.joint_names[link]!r}"
             f" ({'static: gravity only' if static else 'along this motion'})")
    if joints is None:
        sel = np.flatnonzero(~weak)
        if sel.size == 0:
            raise InputError(SOURCE, "q, qd, qdd",
                             f"no excitation: {where} exerts no torque on any drive (regressor "
                             f"RMS <= {EXCITATION_ABS:g} N·m/kg); use samples with motion or "
                             "other configurations")
        return sel
    items = [joints] if isinstance(joints, str | int | np.integer) else list(joints)
    if not items:
        raise InputError(SOURCE, "joints", "empty list: name at least one drive")
    sel = []
    for k, j in enumerate(items):
        try:
            i = robot.joint_index(j if isinstance(j, str) else int(j))
        except (ManipcadError, TypeError, ValueError) as exc:
            raise InputError(SOURCE, f"joints[{k}]", str(exc)) from None
        if i in sel:
            raise InputError(SOURCE, f"joints[{k}]",
                             f"joint {robot.joint_names[i]!r} is named twice")
        if weak[i]:
            unit = "N·m/kg" if robot.joint_types[i] == REVOLUTE else "N/kg"
            raise InputError(SOURCE, f"joints[{k}]",
                             f"no excitation: {where} exerts no torque on joint "
                             f"{robot.joint_names[i]!r} (regressor RMS {excitation[i]:.2g} "
                             f"{unit}); drop it or use other samples")
        sel.append(i)
    return np.asarray(sel, dtype=np.int64)


def _drive_variance(R: np.ndarray, Y: np.ndarray, M: int) -> np.ndarray:
    """Each drive's noise variance from its residuals (one parameter fitted over M
    equations), floored so that noise-free data keep finite weights."""
    N = R.shape[0]
    var = np.sum(R**2, axis=0) / (N * (M - 1) / M)
    scale = np.sqrt(np.mean(Y**2, axis=0)) + np.sqrt(np.mean(R**2))
    return np.maximum(var, (1e-12 * scale) ** 2 + 1e-300)
