"""``synthesize``: a method's regulators for a robot's joints.

The method's own synthesis (its registry entry) gives the regulator; this module
fills in what every regulator carries (joint indices and names, the robot's name and
content hash, the spec and options asked for), checks the sampled loop of a
single-joint regulator whose drive has an inductance
(:func:`~manipcad.control.sampled.check_sampled`) and records its bounds against the
drive's ratings (:func:`drive_bounds`).
"""

from __future__ import annotations

import math
import warnings

from manipcad.control.design import inertia_range
from manipcad.control.method import Method
from manipcad.control.registry import method
from manipcad.control.regulator import current_limit, stall_current, u_limit
from manipcad.control.sampled import check_sampled
from manipcad.errors import ManipcadError, ManipcadWarning
from manipcad.model.hashing import robot_hash


def synthesize(robot, joint, method_name: str, *, spec=None, **options):
    """Synthesize the regulator(s) of one joint, of several, or of all.

    Args:
        robot: a :class:`~manipcad.model.robot.Robot` with drives.
        joint: a joint index or name; a list of them; or ``"all"``. A method that spans
            joints (``computed_torque_full``) gives ONE regulator of those joints; the
            others give one regulator per joint (a list when several were asked).
        method_name: a name of :data:`METHODS`.
        spec: the closed-loop spec of the method (see each method; e.g.
            ``{"bandwidth": 30.0, "damping": 1.0}`` rad/s and ζ).
        **options: method options (``period`` s, ``load_range`` (H_min, H_max) kg·m²,
            ``order`` 2|3, ...).

    Returns:
        A :class:`~manipcad.control.regulator.Regulator`, or a list of them.

    Raises:
        ManipcadError: unknown method or option, missing drive parameters, an
            unreachable spec.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> reg = manipcad.synthesize(arm, "turn", "none")
        >>> reg.needs
        ('q', 'q_ref')
        >>> [r.method for r in manipcad.synthesize(arm, "all", "pid")]
        ['pid', 'pid', 'pid']
    """
    m = method(method_name)
    several = isinstance(joint, list | tuple) or joint == "all"
    if m.spans:
        regs = [_call(m, robot, joint if several else [joint], spec, options)]
        return regs[0]
    if several:
        joints = range(robot.n) if joint == "all" else joint
        return [_call(m, robot, j, spec, options) for j in joints]
    return _call(m, robot, joint, spec, options)


def _call(m: Method, robot, joint, spec, options):
    try:
        reg = m.synthesize(robot, joint, spec=spec, **options)
    except TypeError as exc:
        if "unexpected keyword" in str(exc):
            raise ManipcadError(f"{m.name}: {exc}") from None
        raise
    idx = []
    for j in reg.joints:
        idx.append(robot.joint_index(j))
    reg.joints = tuple(idx)
    reg.joint_names = tuple(robot.joint_names[j] for j in idx)
    reg.robot = robot.name
    reg.robot_hash = robot_hash(robot)
    reg.spec = dict(spec or {})
    opts = {k: v for k, v in options.items()
            if k not in ("progress", "n_jobs", "scheduler", "reference")}
    reg.options = {**opts, **reg.options}
    if not m.spans and robot.drives is not None and robot.drives[idx[0]] is not None:
        lo, hi = reg.design.get("load_range") or inertia_range(robot, idx[0])
        drive = robot.drives[idx[0]]
        if drive.has_electrics and drive.L > 0:
            reg.design["sampled_loop"] = check_sampled(reg, drive, (float(lo), float(hi)))
        reg.design["bounds"] = drive_bounds(drive, reg)
    return reg


def drive_bounds(drive, reg) -> dict:
    """The regulator's output bound against the drive's ratings; warns where the voltage
    bound can drive more than the motor's peak current through the winding at rest.

    Returns:
        ``{"u_limit_V", "i_limit_A", "stall_current_A"}``: the voltage bound
        (:func:`~manipcad.control.regulator.u_limit`), the current bound
        (:func:`~manipcad.control.regulator.current_limit`) and the current that voltage
        drives through the winding at rest, k_u·u_limit/R, A.

    Warns:
        ManipcadWarning: the stall current is over 5 % above the motor's peak current
            (none of the methods limits the current itself: the amplifier's current limit
            must, and the run checks' ``current_peak`` tells whether a run exceeds it).
    """
    ulim = u_limit(drive)
    stall = stall_current(drive)
    peak = drive.peak_current
    if math.isfinite(stall) and math.isfinite(peak) and stall > 1.05 * peak:
        names = ", ".join(reg.joint_names)
        warnings.warn(ManipcadWarning(
            f"{reg.method} on {names}: its voltage bound {ulim:.4g} V drives "
            f"{stall:.3g} A through the winding at rest (R = {drive.R:g} Ω), above the "
            f"motor's peak current {peak:.3g} A; the regulator does not limit the current: "
            f"set the amplifier's current limit at {peak:.3g} A, and check the runs' "
            f"current_peak"), stacklevel=3)
    return {"u_limit_V": ulim, "i_limit_A": current_limit(drive), "stall_current_A": stall}
