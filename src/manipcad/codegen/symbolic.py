"""Symbolic customized dynamics of one robot (the SYMORO line of work), with symengine.

The robot's numbers are fixed, so the recursions below run on symengine
expressions in the joint variables only: every product by an exact 0 or ±1
disappears as it is built, constants fold, and the expression trees share
their sub-trees (a DAG), which :mod:`manipcad.codegen.emit` turns into
straight-line code with common subexpressions eliminated. Nothing is ever
expanded or simplified: the trees keep the nesting of the recursion.

Steps (Khalil & Kleinfinger 1987; Khalil & Gautier 1990):

1. **Exact constants** (:func:`snapped`). Rotation entries within
   ``SNAP_RTOL`` = 1e-9 of 0 or ±1 become the exact integers (cos(π/2) is 6e-17 in
   floating point, and a URDF's π written to 12 digits leaves sin = 2e-12: products
   that would never vanish), lengths within 1e-9 of the robot's length scale (its
   largest joint placement, m) become 0, and a joint offset within 1e-9 rad of a
   multiple of π/2 turns cos/sin(q + offset) into ±cos q or ±sin q. The code is then
   the dynamics of the snapped robot, which differs from the given one by at most
   1e-9 relative in a placement (the UR5's torques by about 5e-12 relative).
2. **Inertial parameters about the joint frame's origin**: mass M (kg),
   first moment MS = M·c (kg·m) and inertia J about the origin (kg·m²), body
   axes, so the recursion needs no centre-of-mass acceleration.
3. **Grouping** (no torque changes, it is the same Lagrangian): for a
   revolute joint j the part of link j that is symmetric about z_j (its mass,
   its first moment along z_j and the inertia diag(J_yy, J_yy, 0)) moves as if
   it were fixed to the parent link, so it is added to the parent's parameters
   (numerically) and removed from link j; for a prismatic joint the link's
   rotational inertia about its centre of mass moves to the parent. Links are
   done leaf first, so what a link receives moves on with it; what reaches the
   fixed base is dropped.
4. **Recursions** in body frames with U = ω̇^ + ω^ω^ (Khalil's form):

       ω_j = Aᵀω_p + q̇_j z,   ω̇_j = Aᵀω̇_p + (Aᵀω_p) × q̇_j z + q̈_j z        (revolute)
       V̇_j = Aᵀ(V̇_p + U_p p_j)  [+ 2 q̇_j ω_j × z + q̈_j z  (prismatic)],   V̇_base = -g
       F_j = M_j V̇_j + U_j MS_j,   N_j = J_j ω̇_j + ω_j × J_j ω_j + MS_j × V̇_j
       f_j = F_j + Σ_c A_c f_c,   n_j = N_j + Σ_c (A_c n_c + p_c × A_c f_c),   τ_j = z·n_j (z·f_j)

   and for the mass matrix the composite links about their origins (CRBA).

The drive terms are those of :attr:`manipcad.model.robot.Robot.table`
(``COL_JR``, ``COL_BV``, ``COL_FCP``, ``COL_FCN``): J·i_r² on the diagonal of
H, k_v·i_r²·q̇ and the dry friction |i_r|·M_f·sign(q̇), the last as a branch in
the emitted code (it is not a smooth expression).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import symengine as se

from manipcad.model.robot import (
    COL_BV,
    COL_FCN,
    COL_FCP,
    COL_JR,
    COL_OFFSET,
    COL_TYPE,
    Robot,
)

#: constants within this of 0 or ±1 are made exact: rotation entries (dimensionless),
#: offsets of revolute joints from a multiple of π/2 (rad), lengths relative to the
#: robot's length scale (:func:`length_scale`) and gravity relative to its magnitude
SNAP_RTOL = 1e-9
#: entries of a rotation within this of 0 or ±1 are made exact
ROT_TOL = SNAP_RTOL
#: inertial parameters within this fraction of the robot's largest of the kind become 0
PARAM_RTOL = 1e-14

ZERO = se.Integer(0)
ONE = se.Integer(1)


def num(v: float, tol: float = 0.0):
    """A symengine number for ``v``: exact 0 and ±1 when within ``tol``, else a double."""
    v = float(v)
    if abs(v) <= tol:
        return ZERO
    if abs(v - 1.0) <= tol:
        return ONE
    if abs(v + 1.0) <= tol:
        return -ONE
    return se.RealDouble(v)


# ------------------------------------------------------------ vector helpers
def _add(*xs):
    out = ZERO
    for x in xs:
        out = out + x
    return out


def v_add(a, b):
    return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def mat_vec(M, v):
    return [_add(*(M[r][k] * v[k] for k in range(3))) for r in range(3)]


def mat_t_vec(M, v):
    return [_add(*(M[r][k] * v[r] for r in range(3))) for k in range(3)]


# ------------------------------------------------------------ the model
@dataclass
class Frames:
    """Symbols and per-joint rotations of one robot (see :func:`frames`)."""

    n: int
    q: list
    qd: list
    qdd: list
    trig: list  # (symbol, "cos"|"sin", joint, offset) of each trig call
    R: list  # per joint: 3x3 expressions, parent <- body
    p: list  # per joint: 3 expressions, m
    revolute: list  # bool per joint
    parent: list  # int per joint
    children: list  # list of child indices per joint
    Rp: list  # per joint: the exact placement rotation (3x3), parent <- joint frame
    cs: list  # per revolute joint: (cos, sin) of q + offset as expressions; None if prismatic


def _exact_rot(R) -> list:
    return [[num(R[r, k], ROT_TOL) for k in range(3)] for r in range(3)]


def length_scale(robot: Robot) -> float:
    """The robot's length scale, m: its largest joint-placement coordinate (1 m when every
    placement is at the origin); lengths within ``SNAP_RTOL`` of it are made 0.

    Example:
        >>> import manipcad
        >>> round(length_scale(manipcad.load_robot("puma560")), 5)  # its tool-side d, m
        0.67183
    """
    p = np.abs(np.asarray(robot.placement_p, dtype=float))
    big = float(p.max(initial=0.0))
    return big if big > 0.0 else 1.0


def _len_tol(robot: Robot) -> float:
    return SNAP_RTOL * length_scale(robot)


def _quarter_turns(off: float) -> int | None:
    """k when ``off`` (rad) is within SNAP_RTOL of k·π/2, else None."""
    k = off / (math.pi / 2)
    kq = round(k)
    return kq if abs(off - kq * math.pi / 2) <= SNAP_RTOL else None


def snapped(robot: Robot) -> Robot:
    """The robot whose dynamics the generated code computes: the near-exact constants of
    step 1 of the module made exact (placement rotations, placements, offsets, gravity,
    and centres of mass within 1e-9 of the length scale and inertia entries within 1e-9
    of the robot's largest: a payload placed through a frame turned by a 12-digit π).

    Args:
        robot: the manipulator.

    Returns:
        a new :class:`Robot` (the same one when nothing is snapped).

    Example:
        >>> import numpy as np, manipcad
        >>> ur5 = manipcad.load_robot("examples/ur5/ur5.yaml")  # π to 12 digits in its URDF
        >>> R = ur5.placement_R
        >>> float(np.abs(R[R != 0]).min())  # cos(1.57079632679)
        4.8965888601467475e-12
        >>> R = snapped(ur5).placement_R
        >>> float(np.abs(R[R != 0]).min())
        1.0
    """
    tol = _len_tol(robot)
    R = np.array([[[float(num(robot.placement_R[i][r, k], ROT_TOL)) for k in range(3)]
                   for r in range(3)] for i in range(robot.n)])
    p = np.array([[float(num(v, tol)) for v in robot.placement_p[i]] for i in range(robot.n)])
    off = np.array(robot.offset, dtype=float)
    for i, jt in enumerate(robot.joint_types):
        if jt == "revolute":
            k = _quarter_turns(off[i])
            if k is not None:
                off[i] = k * math.pi / 2
        else:
            off[i] = float(num(off[i], tol))
    g = np.asarray(robot.gravity, dtype=float)
    gt = SNAP_RTOL * float(np.abs(g).max(initial=0.0))
    g = np.array([float(num(v, gt)) for v in g])
    com = np.where(np.abs(robot.com) <= tol, 0.0, robot.com)
    inertia = np.asarray(robot.inertia, dtype=float)
    it = SNAP_RTOL * float(np.abs(inertia).max(initial=0.0))
    inertia = np.where(np.abs(inertia) <= it, 0.0, inertia)
    new = {"placement_R": R, "placement_p": p, "offset": off, "gravity": g, "com": com,
           "inertia": inertia}
    if all(np.array_equal(v, getattr(robot, k)) for k, v in new.items()):
        return robot
    return robot.replace(**new)


def frames(robot: Robot) -> Frames:
    """Joint symbols and the exact, joint-dependent placements of every body.

    Args:
        robot: the manipulator.

    Returns:
        :class:`Frames` (rotations dimensionless, translations in m).

    Example:
        >>> import manipcad
        >>> from manipcad.codegen.symbolic import frames
        >>> fr = frames(manipcad.load_robot("puma560"))
        >>> fr.R[1]  # modified DH α = π/2, then q: exact 0 and ±1, no 6e-17
        [[c1, -s1, 0], [0, 0, -1], [s1, c1, 0]]
    """
    n = robot.n
    table = robot.table
    q = [se.Symbol(f"q{i}") for i in range(n)]
    qd = [se.Symbol(f"qd{i}") for i in range(n)]
    qdd = [se.Symbol(f"qdd{i}") for i in range(n)]
    trig, Rs, ps, rev, Rps, css = [], [], [], [], [], []
    len_tol = _len_tol(robot)
    for i in range(n):
        Rp = _exact_rot(robot.placement_R[i])
        pp = [num(v, len_tol) for v in robot.placement_p[i]]
        off = float(table[i, COL_OFFSET])
        if table[i, COL_TYPE] == 0.0:
            rev.append(True)
            kq = _quarter_turns(off)
            if kq is not None:  # offset a multiple of π/2: ±cos q, ±sin q
                c0 = se.Symbol(f"c{i}")
                s0 = se.Symbol(f"s{i}")
                trig += [(c0, "cos", i, 0.0), (s0, "sin", i, 0.0)]
                c, s = {0: (c0, s0), 1: (-s0, c0), 2: (-c0, -s0), 3: (s0, -c0)}[kq % 4]
            else:
                c = se.Symbol(f"c{i}")
                s = se.Symbol(f"s{i}")
                trig += [(c, "cos", i, off), (s, "sin", i, off)]
            # R_placement · Rot_z(θ)
            R = [[Rp[r][0] * c + Rp[r][1] * s, Rp[r][1] * c - Rp[r][0] * s, Rp[r][2]]
                 for r in range(3)]
            Rs.append(R)
            ps.append(pp)
            Rps.append(Rp)
            css.append((c, s))
        else:
            rev.append(False)
            th = q[i] + num(off, len_tol)
            Rs.append(Rp)
            ps.append([pp[r] + Rp[r][2] * th for r in range(3)])
            Rps.append(Rp)
            css.append(None)
    parent = [int(v) for v in robot.parent]
    children = [[c for c in range(n) if parent[c] == j] for j in range(n)]
    return Frames(n, q, qd, qdd, trig, Rs, ps, rev, parent, children, Rps, css)


def _shift_inertia(m, ms, p):
    """Inertia change (3x3, kg·m²) when a body with mass m, first moment ms (about
    its own origin, already in the new axes) is referred to an origin shifted by -p."""
    pp = float(p @ p)
    pm = float(p @ ms)
    return m * (pp * np.eye(3) - np.outer(p, p)) + 2 * pm * np.eye(3) - np.outer(p, ms) \
        - np.outer(ms, p)


def grouped_parameters(robot: Robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Link parameters about each joint frame's origin after grouping (see the module).

    Args:
        robot: the manipulator.

    Returns:
        (M (n,) kg, MS (n, 3) kg·m, J (n, 3, 3) kg·m²), body axes; the same joint
        torques as the robot's own parameters for every motion.

    Example:
        >>> import manipcad
        >>> from manipcad.codegen.symbolic import grouped_parameters
        >>> M, MS, J = grouped_parameters(manipcad.load_robot("puma560"))
        >>> float(M[5])  # the wrist's mass has moved down the chain, kg
        0.0
    """
    n = robot.n
    M = robot.mass.astype(float).copy()
    MS = robot.mass[:, None] * robot.com
    J = np.array([robot.inertia[i] + _shift_inertia(robot.mass[i], np.zeros(3), robot.com[i])
                  for i in range(n)])
    Rex = [np.array([[float(num(robot.placement_R[i][r, k], ROT_TOL)) for k in range(3)]
                     for r in range(3)]) for i in range(n)]
    pex = [np.array([float(num(v, _len_tol(robot))) for v in robot.placement_p[i]])
           for i in range(n)]
    for j in range(n - 1, -1, -1):
        par = int(robot.parent[j])
        R = Rex[j]
        if robot.joint_types[j] == "revolute":
            m_e = M[j]
            ms_e = np.array([0.0, 0.0, MS[j, 2]])
            J_e = np.diag([J[j, 1, 1], J[j, 1, 1], 0.0])
            M[j] = 0.0
            MS[j, 2] = 0.0
            J[j] = J[j] - J_e
            J[j, 1, 1] = 0.0  # exactly
            if par >= 0:
                p = pex[j]
                ms_r = R @ ms_e
                M[par] += m_e
                MS[par] += m_e * p + ms_r
                J[par] += R @ J_e @ R.T + _shift_inertia(m_e, ms_r, p)
        else:
            m = M[j]
            # the link as a point mass at its centre: J = (|MS|² E - MS MSᵀ) / M
            J_pt = (_shift_inertia(1.0, np.zeros(3), MS[j]) / m) if m > 0 else np.zeros((3, 3))
            J_e = J[j] - J_pt
            J[j] = J_pt
            if par >= 0:
                J[par] += R @ J_e @ R.T
    return M, MS, J


def _snap_params(M, MS, J):
    def snap(a):
        scale = np.abs(a).max(initial=0.0)
        a = a.copy()
        a[np.abs(a) <= PARAM_RTOL * scale] = 0.0
        return a

    return snap(M), snap(MS), snap(J)


@dataclass
class Dynamics:
    """Symbolic outputs of one robot (lists of symengine expressions)."""

    frames: Frames
    tau: list  # rigid-body inverse dynamics, (q, qd, qdd) with gravity
    bias: list  # rigid-body (q, qd, 0) with gravity
    velocity: list  # h_i: (q, qd, 0) without gravity
    gravity: list  # Q_i: (q, 0, 0) with gravity
    H: list  # lower triangle rows: H[i][j] for j <= i (links only)
    rotor: list  # J·i_r² per joint (float)
    viscous: list  # k_v·i_r² per joint (float)
    dry_pos: list  # |i_r|·M_f+ per joint (float)
    dry_neg: list  # |i_r|·M_f- per joint (float)


def _rnea(fr: Frames, params, qd, qdd, g):
    """Rigid-body joint torques as expressions (see the module docstring)."""
    M, MS, J = params
    n = fr.n
    zero3 = [ZERO, ZERO, ZERO]
    w, wd, vd, U = [None] * n, [None] * n, [None] * n, [None] * n
    F, N = [None] * n, [None] * n
    for j in range(n):
        R, par = fr.R[j], fr.parent[j]
        if par < 0:
            wp, wdp = zero3, zero3
            a = [-g[0], -g[1], -g[2]]
        else:
            wp, wdp = w[par], wd[par]
            a = v_add(vd[par], mat_vec(U[par], fr.p[j]))
        wdj = mat_t_vec(R, wdp)
        vdj = mat_t_vec(R, a)
        if fr.revolute[j]:
            # ω in the joint frame, then about z: |ω_xy|² does not depend on q_j
            u = mat_t_vec(fr.Rp[j], wp)
            c, s = fr.cs[j]
            wj = [c * u[0] + s * u[1], c * u[1] - s * u[0], u[2]]
            wdj = [wdj[0] + wj[1] * qd[j], wdj[1] - wj[0] * qd[j], wdj[2] + qdd[j]]
            wj = [wj[0], wj[1], wj[2] + qd[j]]
            nxy = u[0] * u[0] + u[1] * u[1]
        else:
            wj = mat_t_vec(R, wp)
            vdj = [vdj[0] + 2 * wj[1] * qd[j], vdj[1] - 2 * wj[0] * qd[j], vdj[2] + qdd[j]]
            nxy = None
        x, y, z = wj
        dx, dy, dz = wdj
        xx, yy, zz, xy, xz, yz = x * x, y * y, z * z, x * y, x * z, y * z
        if nxy is None:
            nxy = xx + yy
        Uj = [[-(yy + zz), xy - dz, xz + dy],
              [xy + dz, -(xx + zz), yz - dx],
              [xz - dy, yz + dx, -nxy]]
        w[j], wd[j], vd[j], U[j] = wj, wdj, vdj, Uj
        ms = [num(v) for v in MS[j]]
        Jj = [[num(J[j][r, k]) for k in range(3)] for r in range(3)]
        m = num(M[j])
        F[j] = v_add([m * vdj[r] for r in range(3)], mat_vec(Uj, ms))
        N[j] = v_add(v_add(mat_vec(Jj, wdj), cross(wj, mat_vec(Jj, wj))), cross(ms, vdj))
    f, nn, tau = list(F), list(N), [None] * n
    for j in range(n - 1, -1, -1):
        for c in fr.children[j]:
            Rf = mat_vec(fr.R[c], f[c])
            f[j] = v_add(f[j], Rf)
            nn[j] = v_add(nn[j], v_add(mat_vec(fr.R[c], nn[c]), cross(fr.p[c], Rf)))
        tau[j] = nn[j][2] if fr.revolute[j] else f[j][2]
    return tau


def _crba(fr: Frames, params):
    """Lower triangle of the links' mass matrix as expressions (composite links)."""
    M, MS, J = params
    n = fr.n
    Mc = [num(M[j]) for j in range(n)]
    MSc = [[num(v) for v in MS[j]] for j in range(n)]
    Jc = [[[num(J[j][r, k]) for k in range(3)] for r in range(3)] for j in range(n)]
    for j in range(n - 1, -1, -1):
        par = fr.parent[j]
        if par < 0:
            continue
        R, p = fr.R[j], fr.p[j]
        ms = mat_vec(R, MSc[j])  # first moment in the parent's axes, about the joint origin
        # R J Rᵀ, symmetric: the upper triangle, mirrored
        RJ = [mat_vec(Jc[j], [R[r][0], R[r][1], R[r][2]]) for r in range(3)]  # (J Rᵀ)[:, r]
        RJR = [[None] * 3 for _ in range(3)]
        for r in range(3):
            for k in range(r, 3):
                RJR[r][k] = RJR[k][r] = _add(*(R[r][i] * RJ[k][i] for i in range(3)))
        m = Mc[j]
        pp = _add(*(p[i] * p[i] for i in range(3)))
        pms = _add(*(p[i] * ms[i] for i in range(3)))
        for r in range(3):
            for k in range(r, 3):
                e = RJR[r][k] - m * p[r] * p[k] - p[r] * ms[k] - ms[r] * p[k]
                if r == k:
                    e = e + m * pp + 2 * pms
                Jc[par][r][k] = Jc[par][r][k] + e
                if k != r:
                    Jc[par][k][r] = Jc[par][r][k]
        MSc[par] = [MSc[par][r] + ms[r] + m * p[r] for r in range(3)]
        Mc[par] = Mc[par] + m
    H = [[ZERO] * (i + 1) for i in range(n)]
    for j in range(n):
        if fr.revolute[j]:
            fv = [-MSc[j][1], MSc[j][0], ZERO]
            nv = [Jc[j][0][2], Jc[j][1][2], Jc[j][2][2]]
            H[j][j] = nv[2]
        else:
            fv = [ZERO, ZERO, Mc[j]]
            nv = [MSc[j][1], -MSc[j][0], ZERO]
            H[j][j] = fv[2]
        k = j
        while fr.parent[k] >= 0:
            R, p = fr.R[k], fr.p[k]
            fv = mat_vec(R, fv)
            nv = v_add(mat_vec(R, nv), cross(p, fv))
            k = fr.parent[k]
            H[j][k] = nv[2] if fr.revolute[k] else fv[2]
    return H


def dynamics(robot: Robot) -> Dynamics:
    """All the symbolic outputs of one robot (see :class:`Dynamics`).

    Args:
        robot: the manipulator (numbers fixed).

    Returns:
        :class:`Dynamics`.

    Example:
        >>> import manipcad
        >>> from manipcad.codegen.symbolic import dynamics
        >>> d = dynamics(manipcad.load_robot("cylindrical"))
        >>> len(d.tau), len(d.H)
        (3, 3)
    """
    robot = snapped(robot)
    fr = frames(robot)
    params = _snap_params(*grouped_parameters(robot))
    gt = SNAP_RTOL * float(np.abs(np.asarray(robot.gravity, dtype=float)).max(initial=0.0))
    g = [num(v, gt) for v in robot.gravity]
    zeros = [ZERO] * fr.n
    table = robot.table
    return Dynamics(
        frames=fr,
        tau=_rnea(fr, params, fr.qd, fr.qdd, g),
        bias=_rnea(fr, params, fr.qd, zeros, g),
        velocity=_rnea(fr, params, fr.qd, zeros, [ZERO] * 3),
        gravity=_rnea(fr, params, zeros, zeros, g),
        H=_crba(fr, params),
        rotor=[float(v) for v in table[:, COL_JR]],
        viscous=[float(v) for v in table[:, COL_BV]],
        dry_pos=[float(v) for v in table[:, COL_FCP]],
        dry_neg=[float(v) for v in table[:, COL_FCN]],
    )
