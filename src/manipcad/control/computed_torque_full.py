"""``computed_torque_full``: centralized inverse-dynamics control from the full model.

The textbook (and Drake's ``InverseDynamicsController``) law over all its joints:
``v = q̈* + K_d·ė + K_p·e``, ``τ = H(q)·v + c(q, q̇) + Q(q)`` with the whole joint-space
inertia matrix (the coupling Σ_k H_ik·v_k included), passed through each joint's gear
with its losses (f = 1/η motoring or holding, η braking:
:func:`manipcad.control.computed_torque.drive_torque`, the plant's gear factor), plus each
drive's rotor inertia, viscous and dry friction; each joint's torque is turned into its
amplifier input through the static drive equations
(:func:`manipcad.control.computed_torque.joint_torque_to_input`). One regulator spans the
joints; its parameters hold one packed drive per joint and the efficiency η of each
joint's gear (``drives_assumed.<joint>.gear_efficiency``; 1: no losses).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from manipcad._lazy import ct
from manipcad.control.computed_torque import drive_torque, joint_torque_to_input, outer_gains
from manipcad.control.design import DEFAULT_PERIOD, check_period, joint_drive, law_efficiency
from manipcad.control.method import GEAR_EFFICIENCY_OPTIONAL, Method
from manipcad.control.regulator import Regulator, u_limit
from manipcad.control.signals import (
    NPARAM,
    NSIG,
    NSTATE,
    S_CI,
    S_Q,
    S_QD,
    S_QDDREF,
    S_QDREF,
    S_QI,
    S_QREF,
    SIGNALS,
)
from manipcad.drives.dc import clip
from manipcad.drives.params import NPAR, pack_drive
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot

# gains k_p (1/s²), k_d (1/s), compensate dry friction (1/0); drive k from DRV + k·NPAR,
# its input limit (V) at ULIM0 + k, its gear's efficiency η (-) at ETA0 + k
CTF_KP, CTF_KD, CTF_FRIC = 0, 1, 2
CTF_ULIM0 = 3
CTF_ETA0 = 17
CTF_DRV = 32
#: most joints one spanning regulator can hold
MAX_JOINTS = min((NPARAM - CTF_DRV) // NPAR, CTF_ETA0 - CTF_ULIM0, CTF_DRV - CTF_ETA0)
FIELDS = {"kp_per_s2": CTF_KP, "kd_per_s": CTF_KD, "friction_compensation": CTF_FRIC}


@nb.njit(cache=True)
def computed_torque_full_update(p, s, sig, H, joints, nj, Ts, U):
    """τ = H·v + c + Q (+ drive terms) over the regulator's joints; writes U of each, V.

    ``H`` is the rigid-body joint-space inertia matrix (n × n, kg·m²) at the sample;
    the rows of ``sig`` give q, q̇, the reference and c_i, Q_i of each joint.
    """
    for a in range(nj):
        ja = joints[a]
        load = sig[ja, S_CI] + sig[ja, S_QI]
        va = 0.0
        for b in range(nj):
            jb = joints[b]
            v = (sig[jb, S_QDDREF] + p[CTF_KD] * (sig[jb, S_QDREF] - sig[jb, S_QD])
                 + p[CTF_KP] * (sig[jb, S_QREF] - sig[jb, S_Q]))
            load += H[ja, jb] * v
            if a == b:
                va = v
        o = CTF_DRV + a * NPAR
        qd = sig[ja, S_QD]
        tau = drive_torque(load, va, qd, p[CTF_ETA0 + a], p[CTF_FRIC], p[o:o + NPAR])
        U[ja] = clip(joint_torque_to_input(tau, qd, p[o:o + NPAR]), p[CTF_ULIM0 + a])


#: the signals each joint's row gives the law, in the order of the export's inputs
EXPORT_SIGNALS = ("q_ref", "q_dot_ref", "q_ddot_ref", "q", "q_dot", "c_i", "Q_i")


def export_computed_torque_full(reg: Regulator) -> ct.NonlinearIOSystem:
    """``computed_torque_full`` as a python-control system: a discrete-time (period
    ``reg.period``, s) static MIMO nonlinear I/O system over all its joints, whose
    output calls the very compiled law the simulator runs.

    Inputs: for each joint k (in ``reg.joint_names`` order) the signals of
    :data:`EXPORT_SIGNALS` labelled ``"q_ref[k]"``, ... (units as in
    :data:`~manipcad.control.signals.SIGNALS`), then the inertia matrix H(q) of those
    joints, ``"H[a,b]"`` row by row, kg·m² (kg on a prismatic joint). Outputs: the
    amplifier inputs ``"U[k]"``, V. No state.

    Example:
        >>> import manipcad
        >>> from manipcad.control import to_control
        >>> arm = manipcad.load_robot("cylindrical")
        >>> sys_ = to_control(manipcad.synthesize(arm, "all", "computed_torque_full", period=1e-3))
        >>> sys_.ninputs, sys_.noutputs, sys_.nstates, sys_.dt
        (30, 3, 0, 0.001)
    """
    nj = len(reg.joints)
    names = list(reg.joint_names) or [str(j) for j in reg.joints]
    inputs = [f"{s}[{k}]" for k in names for s in EXPORT_SIGNALS]
    inputs += [f"H[{a},{b}]" for a in names for b in names]
    cols = [SIGNALS[s][0] for s in EXPORT_SIGNALS]
    p = np.ascontiguousarray(reg.params, dtype=float)
    Ts = float(reg.period)
    local = np.arange(nj, dtype=np.int64)

    def output(t, x, u, params):
        u = np.asarray(u, dtype=float)
        sig = np.zeros((nj, NSIG))
        sig[:, 0] = t
        sig[:, cols] = u[:nj * len(cols)].reshape(nj, len(cols))
        H = np.ascontiguousarray(u[nj * len(cols):].reshape(nj, nj))
        U = np.zeros(nj)
        computed_torque_full_update(p, np.zeros(NSTATE), sig, H, local, nj, Ts, U)
        return U

    return ct.nlsys(None, output, inputs=inputs, outputs=[f"U[{k}]" for k in names],
                    dt=Ts, name=f"computed_torque_full_{'_'.join(names)}")


def synthesize_computed_torque_full(robot: Robot, joints="all", *, spec=None,
                                    period: float = DEFAULT_PERIOD, friction: bool = True,
                                    order: int = 3, load_range=None) -> Regulator:
    """Inverse-dynamics control of several joints from the full model.

    Args:
        robot: the robot (a drive on every joint controlled).
        joints: "all", or a list of joint names or indices.
        spec: ``{"bandwidth": ω_n rad/s, "damping": ζ}`` of each joint's error dynamics
            (default 30 rad/s, 1.0): K_p = ω_n², K_d = 2ζω_n.
        period: control period, s.
        friction: compensate the drives' dry friction.
        order: packed drive order (the law neglects L).
        load_range: not used (the full model needs no load range); refused if given.

    Returns:
        One :class:`~manipcad.control.regulator.Regulator` spanning the joints.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> reg = manipcad.synthesize(arm, "all", "computed_torque_full")
        >>> reg.joint_names
        ('turn', 'lift', 'reach')
    """
    if load_range is not None:
        raise ManipcadError("computed_torque_full uses the full model; it takes no load_range")
    period = check_period(period)
    if isinstance(joints, str | int):
        joints = list(range(robot.n)) if joints == "all" else [joints]
    idx = []
    for jt in joints:
        j, _ = joint_drive(robot, jt)
        if j in idx:
            raise ManipcadError(f"computed_torque_full: joint {robot.joint_names[j]!r} "
                                "listed twice")
        idx.append(j)
    if not idx or len(idx) > MAX_JOINTS:
        raise ManipcadError(f"computed_torque_full spans 1 to {MAX_JOINTS} joints, "
                            f"got {len(idx)}")
    kp, kd, wn, zeta = outer_gains(spec, period, "computed_torque_full")
    p = np.zeros(NPARAM)
    p[CTF_KP], p[CTF_KD], p[CTF_FRIC] = kp, kd, float(friction)
    for a, j in enumerate(idx):
        d = robot.drives[j]
        p[CTF_DRV + a * NPAR: CTF_DRV + (a + 1) * NPAR] = pack_drive(d, order=order)
        p[CTF_ULIM0 + a] = u_limit(d)
        p[CTF_ETA0 + a] = law_efficiency(d)
    names = tuple(robot.joint_names[j] for j in idx)
    etas = ", ".join(f"{p[CTF_ETA0 + a]:g}" for a in range(len(idx)))
    law = (f"computed_torque_full ({', '.join(names)}): v = q̈* + {kd:.6g}·ė + {kp:.6g}·e; "
           f"τ = f·(H(q)·v + c(q, q̇) + Q(q)) + J·i_r²·v + k_v·i_r²·q̇"
           f"{' + |i_r|·M_f·sgn q̇' if friction else ''} (full model, coupling included; "
           f"f = 1/η motoring or holding, η braking, η = {etas}); "
           f"U = (R·τ/(k_m·i_r) + k_w·i_r·q̇)/k_u per joint; T = {period:g} s")
    needs = ("q", "q_dot", "q_ref", "q_dot_ref", "q_ddot_ref", "H", "c_i", "Q_i")
    return Regulator(
        method="computed_torque_full", joints=tuple(idx), period=period, params=p,
        needs=needs, law=law, joint_names=names,
        design={"kp": kp, "kd": kd, "bandwidth": wn, "damping": zeta},
        linear={"error": ct.tf([1.0, 0.0, 0.0], [1.0, kd, kp])})


METHOD = Method(
    name="computed_torque_full", synthesize=synthesize_computed_torque_full,
    update=computed_torque_full_update, section="baseline",
    summary="centralized inverse dynamics H(q)·v + c + Q over all joints (Drake's "
            "InverseDynamicsController)",
    fields=FIELDS, spans=True, drive_blocks="per_joint", export=export_computed_torque_full,
    joint_fields={"u_limit_V": CTF_ULIM0, "gear_efficiency": CTF_ETA0}, drive_base=CTF_DRV,
    optional_fields=GEAR_EFFICIENCY_OPTIONAL)
