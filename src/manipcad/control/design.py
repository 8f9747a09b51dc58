"""What every synthesis method shares: the joint's drive, the load range, the spec, the PD design.

SI units: V, rad (m), s, kg·m² (kg), N·m (N). Loads are joint side unless
marked ``*`` (motor side, divided by i_r²).
"""

from __future__ import annotations

import math

import numpy as np

from manipcad._lazy import ct
from manipcad.control.signals import NPARAM
from manipcad.drives.linear import drive_gain, mechanical_time_constant
from manipcad.drives.params import check_electrics, pack_drive
from manipcad.dynamics import mass_matrix
from manipcad.errors import ManipcadError, ModelError
from manipcad.model.robot import Drive, Robot

#: default control period of the synthesized regulators, s
DEFAULT_PERIOD = 1e-4


def joint_drive(robot: Robot, joint: int | str) -> tuple[int, Drive]:
    """The joint index and its drive; clear errors for a missing or incomplete drive."""
    try:
        j = robot.joint_index(joint)
    except (KeyError, IndexError, ValueError) as exc:
        raise ManipcadError(f"robot {robot.name!r} has no joint {joint!r}") from exc
    d = robot.drives[j] if robot.drives is not None else None
    if d is None:
        raise ManipcadError(f"joint {robot.joint_names[j]!r} of {robot.name!r} has no drive; "
                            "the synthesis methods design for a drive")
    try:
        check_electrics(d, need_L=False)
    except ModelError as exc:
        raise ManipcadError(f"joint {robot.joint_names[j]!r}: missing drive parameters: "
                            f"{exc}") from exc
    if not d.ratio:
        raise ManipcadError(f"joint {robot.joint_names[j]!r}: the drive has no gear ratio")
    return j, d


def law_efficiency(drive: Drive) -> float:
    """The gear efficiency η a law models, -: the drive's ``efficiency``, or 1 (no losses)
    where it is unknown (nan), as the simulated plant and the sizing take it.

    Example:
        >>> import math
        >>> from manipcad.model.robot import Drive
        >>> law_efficiency(Drive(efficiency=0.8)), law_efficiency(Drive(efficiency=math.nan))
        (0.8, 1.0)
    """
    eta = float(drive.efficiency)
    return eta if math.isfinite(eta) else 1.0


def packed(drive: Drive, order: int) -> np.ndarray:
    """A parameter vector of length NPARAM starting with the packed drive."""
    p = np.zeros(NPARAM)
    try:
        dp = pack_drive(drive, order=order)
    except ModelError as exc:
        raise ManipcadError(f"drive {drive.name or ''!r}: {exc}") from exc
    p[:len(dp)] = dp
    return p


def check_period(period: float) -> float:
    """The control period as a float, s; refused unless finite and > 0."""
    try:
        period = float(period)
    except (TypeError, ValueError):
        raise ManipcadError(f"period must be a number of seconds, got {period!r}") from None
    if not (math.isfinite(period) and period > 0):
        raise ManipcadError(f"period must be > 0 s, got {period}")
    return period


def check_finite(name: str, value: float, what: str) -> float:
    """``value`` as a float; refused unless finite (``what`` names the method)."""
    v = float(value)
    if not math.isfinite(v):
        raise ManipcadError(f"{what} {name} must be finite, got {value}")
    return v


def nominal_drive(robot: Robot, joint, load_range=None, H_nominal: float | None = None):
    """The joint's drive at its nominal load (default the largest H_ii, the slowest drive).

    Returns:
        (j, drive, (H_min, H_max) kg·m², H kg·m², K rad/(V·s) = k_u·k_p/i_r of the
        2nd-order model q/U = K/(s·(T_m·s + 1)), T_m s).
    """

    j, d = joint_drive(robot, joint)
    Hmin, Hmax = inertia_range(robot, j, load_range)
    H = Hmax if H_nominal is None else float(H_nominal)
    if not (math.isfinite(H) and H >= 0):
        raise ManipcadError(f"H_nominal must be >= 0 kg·m², got {H}")
    return (j, d, (Hmin, Hmax), H, *second_order_model(d, H))


def second_order_model(d: Drive, H: float) -> tuple[float, float]:
    """The drive's 2nd-order model q/U = K/(s·(T_m·s + 1)) at the joint-side load H
    (kg·m², kg for a prismatic joint; h* = 0, L neglected): (K rad/(V·s) = k_u·k_p/i_r,
    T_m s), from :func:`~manipcad.drives.linear.drive_gain` and
    :func:`~manipcad.drives.linear.mechanical_time_constant`.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> d = Drive(J=1e-4, ratio=10, R=1.0, L=1e-3, k_m=0.1, k_w=0.1)
        >>> K, T = second_order_model(d, 0.01)
        >>> round(K, 9), round(T, 9)
        (1.0, 0.02)
    """
    K = d.k_u * drive_gain(d, H, 0.0) / d.ratio
    T = mechanical_time_constant(d, H, 0.0)
    return K, T


def pd_gains(K: float, T: float, wn: float, zeta: float) -> tuple[float, float]:
    """PD gains placing the poles of K/(s·(T·s + 1)) at ω_n, ζ: the characteristic
    polynomial T·s² + (1 + K·k_d)·s + K·k_p gives k_p = T·ω_n²/K (V/rad) and
    k_d = (2ζω_n·T − 1)/K (V·s/rad); unchecked (:func:`design_pd` checks them).

    Example:
        >>> pd_gains(2.0, 0.05, 30.0, 1.0)
        (22.5, 1.0)
    """
    kp = T * wn * wn / K
    kd = (2.0 * zeta * wn * T - 1.0) / K
    return kp, kd


def back_emf_feedforward(d: Drive) -> float:
    """k_ff = k_w·i_r/k_u, V·s/rad (V·s/m): the velocity feed-forward that cancels the
    back-EMF at the reference speed.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> back_emf_feedforward(Drive(ratio=10, R=1.0, L=1e-3, k_m=0.1, k_w=0.1, k_u=2.0))
        0.5
    """
    return d.k_w * d.ratio / d.k_u


def inertia_range(robot: Robot, j: int, given=None, *, samples: int = 256,
               seed: int = 0) -> tuple[float, float]:
    """Range of the rigid-body inertia H_ii of joint j over the workspace, kg·m² (kg).

    Args:
        robot: the robot.
        j: joint index.
        given: (H_min, H_max) to use instead, kg·m².
        samples: random configurations within the joint limits (plus the
            corners of the limit box when n <= 10); an infinite limit is taken
            as ±π.
        seed: random seed.

    Returns:
        (H_min, H_max), kg·m².
    """
    if given is not None:
        try:
            lo, hi = (float(v) for v in given)
        except (TypeError, ValueError) as exc:
            raise ManipcadError(f"load_range must be a pair (H_min, H_max) in kg·m², "
                                f"got {given!r}") from exc
        if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
            raise ManipcadError(f"load_range must satisfy 0 <= H_min <= H_max, got {given!r}")
        return lo, hi

    lim = (np.tile([-math.inf, math.inf], (robot.n, 1)) if robot.limits is None
           else np.array(robot.limits, dtype=float))
    lim = np.where(np.isfinite(lim), lim, np.array([-math.pi, math.pi]))
    rng = np.random.default_rng(seed)
    qs = lim[:, 0] + rng.random((samples, robot.n)) * (lim[:, 1] - lim[:, 0])
    if robot.n <= 10:
        corners = np.array(np.meshgrid(*lim)).reshape(robot.n, -1).T
        qs = np.vstack([qs, corners])
    H = np.array([mass_matrix(robot, q, drives=False)[j, j] for q in qs])
    return float(H.min()), float(H.max())


_SPEC_KEYS = {"bandwidth", "damping"}


def parse_spec(spec, *, bandwidth: float, damping: float,
               accuracy: bool = False) -> tuple[float, float]:
    """(ω_n rad/s, ζ) of the closed loop asked, from ``spec`` or the defaults.

    ``accuracy=True`` also admits the key ``max_error`` (read by :func:`max_error_of`).
    """
    spec = dict(spec or {})
    keys = _SPEC_KEYS | ({"max_error"} if accuracy else set())
    unknown = set(spec) - keys
    if unknown:
        raise ManipcadError(f"unknown spec keys {sorted(unknown)}; known: {sorted(keys)}")
    wn = float(spec.get("bandwidth", bandwidth))
    zeta = float(spec.get("damping", damping))
    if not (math.isfinite(wn) and wn > 0):
        raise ManipcadError(f"spec bandwidth must be > 0 rad/s, got {wn}")
    if not (math.isfinite(zeta) and 0 < zeta <= 5):
        raise ManipcadError(f"spec damping must be in (0, 5], got {zeta}")
    return wn, zeta


def _check_pd(plant, K: float, T: float, wn: float, zeta: float, period: float, *,
              what: str) -> tuple[float, float, ct.TransferFunction]:
    """The PD of :func:`design_pd` without the damping-sign check (see there)."""
    if wn * period > 0.5:
        raise ManipcadError(f"{what}: bandwidth {wn:g} rad/s is unreachable with the control "
                            f"period {period:g} s (need ω_n·T_s <= 0.5)")
    kp, kd = pd_gains(K, T, wn, zeta)
    C = ct.tf([kd, kp], [1.0])
    cl = ct.feedback(C * plant, 1)
    poles = np.asarray(cl.poles())
    if not np.all(poles.real < 0):
        raise ManipcadError(f"{what}: the spec (ω_n = {wn:g} rad/s, ζ = {zeta:g}) is "
                            f"unreachable: the loop with the drive's inductance is unstable "
                            f"(poles {np.round(poles, 3).tolist()})")
    slow = poles[np.argmin(np.abs(poles))]
    zs = -slow.real / abs(slow)
    if zs < 0.5 * zeta:
        raise ManipcadError(f"{what}: the spec (ω_n = {wn:g} rad/s, ζ = {zeta:g}) is "
                            f"unreachable: with the inductance the slowest poles have "
                            f"damping {zs:.3g}")
    return kp, kd, cl


def damping_floor(T: float, zeta: float) -> float:
    """The lowest ω_n whose PD keeps the drive's own damping, rad/s: 1/(2ζ·T).

    Below it k_d = (2ζω_n·T − 1)/K has the sign opposite to the plant gain K: the
    derivative term feeds the velocity back positively and cancels part of the damping
    the back-EMF gives (the nominal poles are still where asked, but any load or model
    error the law leaves finds a loop with less damping than the bare drive).

    Example:
        >>> damping_floor(0.01, 1.0)
        50.0
    """
    return 1.0 / (2.0 * zeta * T)


def bandwidth_range(plant, K: float, T: float, zeta: float, period: float, *,
                    what: str = "pd") -> tuple[float, float] | None:
    """The bandwidths ω_n (rad/s) whose PD :func:`design_pd` accepts: (lowest, highest).

    The lowest is :func:`damping_floor`; the highest the last of 60 geometric steps up to
    0.5/T_s that is stable and well damped with the inductance. None when no bandwidth
    works at this period.
    """
    lo = damping_floor(T, zeta)
    top = 0.5 / period
    if lo > top:
        return None
    hi = None
    for w in np.geomspace(lo, top, 60):
        try:
            _check_pd(plant, K, T, float(w), zeta, period, what=what)
        except ManipcadError:
            if hi is None:
                continue
            break
        hi = float(w)
    return None if hi is None else (lo, hi)


def pd_bandwidth(spec, default: float, T: float, zeta: float) -> tuple[float, str]:
    """ω_n of a PD design, rad/s, and a note: the spec's, or the default raised to keep damping.

    A bandwidth given in ``spec`` is used as is (:func:`design_pd` refuses it when it
    removes damping). Without one, the default is raised to :func:`damping_floor` where
    it lies below it (a fast drive: small T), and the note says so.
    """
    if spec and "bandwidth" in spec:
        return float(spec["bandwidth"]), ""
    lo = damping_floor(T, zeta)
    if default >= lo:
        return default, ""
    return lo, (f"bandwidth raised from the default {default:g} to {lo:.4g} rad/s: below "
                f"1/(2ζ·T_m) the derivative gain would remove the drive's own damping")


def design_pd(plant: ct.TransferFunction, K: float, T: float, wn: float, zeta: float,
              period: float, *, what: str) -> tuple[float, float, ct.TransferFunction]:
    """PD U = k_p·e + k_d·ė placing the poles of K/(s·(T·s + 1)) at ω_n, ζ; checked on ``plant``.

    The characteristic polynomial T·s² + (1 + K·k_d)·s + K·k_p gives
    k_p = T·ω_n²/K (V/rad), k_d = (2ζω_n·T − 1)/K (V·s/rad). The loop is then
    closed on the full ``plant`` (3rd order with the inductance) with
    python-control; the design is refused if it is unstable, if its slowest
    pole's damping is below half of ζ, if ω_n·T_s > 0.5 (the sampled
    realization could not follow), or if ω_n < 1/(2ζ·T) (:func:`damping_floor`:
    k_d of the wrong sign removes the drive's own damping); the refusal names the
    bandwidth range that works (:func:`bandwidth_range`).

    Returns:
        (k_p, k_d, closed-loop transfer function q/q*).

    Example:
        >>> import control as ct
        >>> K, T = 2.0, 0.05               # rad/(V·s), s
        >>> kp, kd, cl = design_pd(ct.tf([K], [T, 1.0, 0.0]), K, T, 30.0, 1.0, 1e-3,
        ...                        what="demo")
        >>> round(kp, 3), round(kd, 3)
        (22.5, 1.0)
        >>> design_pd(ct.tf([K], [T, 1.0, 0.0]), K, T, 5.0, 1.0, 1e-3,
        ...           what="demo")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        manipcad.errors.ManipcadError: demo: ...wrong sign...that work: 10 to 500 rad/s...
    """
    if 2.0 * zeta * wn * T < 1.0 - 1e-9:
        kd = pd_gains(K, T, wn, zeta)[1]
        rng = bandwidth_range(plant, K, T, zeta, period, what=what)
        works = (f"bandwidths that work: {rng[0]:.4g} to {rng[1]:.4g} rad/s" if rng else
                 f"no bandwidth works at this period (need ω_n >= {damping_floor(T, zeta):.4g}"
                 f" rad/s and ω_n·T_s <= 0.5)")
        raise ManipcadError(f"{what}: bandwidth {wn:g} rad/s gives a derivative gain of the "
                            f"wrong sign (k_d = {kd:.4g} V·s/rad, plant gain K = {K:.4g}): it "
                            f"removes the drive's own damping; {works} (ζ = {zeta:g}, "
                            f"T_m = {T:.4g} s, T_s = {period:g} s)")
    return _check_pd(plant, K, T, wn, zeta, period, what=what)


def max_error_of(spec, reference, joint: int) -> tuple[float | None, tuple | None]:
    """The accuracy asked (``spec["max_error"]``, rad or m) and the joint's reference.

    Args:
        spec: the spec mapping.
        reference: a trajectory (``.sample(t)``, ``.duration``) of the robot's
            joints, or a pair (t s, q_ref rad) of arrays for this joint.
        joint: joint index.

    Returns:
        (max_error or None, (t, q_ref) or None).
    """
    e = (spec or {}).get("max_error")
    if e is None:
        return None, None
    e = float(e)
    if not (math.isfinite(e) and e > 0):
        raise ManipcadError(f"spec max_error must be > 0, got {e}")
    if reference is None:
        raise ManipcadError("spec max_error needs reference= (the joint's reference motion "
                            "the accuracy is asked on)")
    if hasattr(reference, "sample"):
        T = float(getattr(reference, "duration", 0.0)) or 1.0
        tt = np.linspace(0.0, 1.25 * T, 8001)
        q = np.asarray(reference.sample(tt)[0])[:, joint]
    else:
        try:
            tt, q = (np.asarray(a, dtype=float) for a in reference)
        except (TypeError, ValueError) as exc:
            raise ManipcadError("reference must be a trajectory or a pair (t, q_ref)") from exc
        if tt.ndim != 1 or tt.shape != q.shape or len(tt) < 3:
            raise ManipcadError("reference (t, q_ref) must be two 1-D arrays of equal length")
    return e, (tt, q)


def nominal_error(plant: ct.TransferFunction, kp: float, kd: float, kfv: float, kfa: float,
                  t: np.ndarray, q_ref: np.ndarray) -> float:
    """max |q* − q| of the nominal linear loop with the SCE and its feed-forward, rad.

    E(s)/Q*(s) = (d − n·F)/(d + n·C) with plant n/d, C = k_d·s + k_p,
    F = k_fa·s² + k_fv·s; python-control ``forced_response`` on the reference.
    """
    n = np.asarray(plant.num[0][0], dtype=float)
    d = np.asarray(plant.den[0][0], dtype=float)
    num = np.polysub(d, np.polymul(n, [kfa, kfv, 0.0]))
    den = np.polyadd(d, np.polymul(n, [kd, kp]))
    E = ct.tf(np.trim_zeros(num, "f") if np.any(num) else [0.0], den)
    resp = ct.forced_response(E, T=t, U=q_ref - q_ref[0])
    return float(np.abs(np.asarray(resp.outputs)).max())


def design_for_accuracy(plant, K: float, T: float, wn: float, zeta: float, period: float,
                        ff: tuple[float, float], max_error: float, ref, *, what: str):
    """The smallest ω_n >= the spec's that meets ``max_error`` on the reference.

    Searches 40 geometric steps from ω_n up to 0.5/T_s; the PD of each is
    checked by :func:`design_pd` (stops at the first unstable or badly damped
    one). Returns (k_p, k_d, closed loop, ω_n, max error reached).

    Raises:
        ManipcadError: "unreachable accuracy" with the best error found.
    """
    wn = max(wn, damping_floor(T, zeta))
    best = (math.inf, wn)
    for w in np.geomspace(wn, max(wn, 0.5 / period), 40):
        try:
            kp, kd, cl = design_pd(plant, K, T, float(w), zeta, period, what=what)
        except ManipcadError:
            break
        err = nominal_error(plant, kp, kd, ff[0], ff[1], *ref)
        if err <= max_error:
            return kp, kd, cl, float(w), err
        if err < best[0]:
            best = (err, float(w))
    raise ManipcadError(f"{what}: unreachable accuracy: max error {max_error:g} asked, the best "
                        f"the nominal loop gives on the reference is {best[0]:.3g} "
                        f"(ω_n = {best[1]:.4g} rad/s, ζ = {zeta:g}, T_s = {period:g} s)")
