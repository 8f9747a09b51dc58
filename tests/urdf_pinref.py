"""Reference helpers for the URDF tests: Pinocchio twins of our robots and state mapping.

Used by test_urdf.py and test_random_trees.py. Agreement is relative in the
infinity norm: ``max|ours - ref| <= rtol · max(1, max|ref|)``.

Pinocchio orders joints depth-first through the tree and gives continuous
joints two coordinates (cos q, sin q); :class:`StateMap` maps our vectors (our
order, one coordinate per joint) onto a Pinocchio model by joint name. Our body
frame of joint i has the origin of Pinocchio's joint frame; the two differ by a
fixed rotation when the URDF axis is not z (:func:`pin_fext` converts forces).
"""

from __future__ import annotations

import importlib

import numpy as np
import pinocchio as pin
import pytest

RTOL = 1e-9


def dynamics():
    """``manipcad.dynamics``, or a skip while the lead's module does not exist yet."""
    try:
        return importlib.import_module("manipcad.dynamics")
    except ImportError as exc:  # pragma: no cover - only before the module lands
        pytest.skip(f"manipcad.dynamics not importable yet: {exc}")


def close(ours: np.ndarray, ref: np.ndarray, rtol: float = RTOL) -> None:
    """Assert ``max|ours - ref| <= rtol · max(1, max|ref|)``, with a readable report."""
    ours, ref = np.asarray(ours, float), np.asarray(ref, float)
    assert ours.shape == ref.shape, f"shape {ours.shape} != {ref.shape}"
    scale = max(1.0, float(np.abs(ref).max(initial=0.0)))
    err = float(np.abs(ours - ref).max(initial=0.0))
    assert err <= rtol * scale, f"max error {err:.3e} > {rtol:g} x {scale:.3e}"


def pin_from_robot(robot) -> pin.Model:
    """Our robot rebuilt as a Pinocchio model: RZ/PZ joints with our placements.

    Joints are added depth first, as Pinocchio's CRBA needs each subtree's
    velocities contiguous; states are mapped by name (:class:`StateMap`)."""
    children: list[list[int]] = [[] for _ in range(robot.n + 1)]
    for i in range(robot.n):
        children[int(robot.parent[i]) + 1].append(i)
    model = pin.Model()
    pin_id = {-1: 0}
    stack = list(reversed(children[0]))
    while stack:
        i = stack.pop()
        jm = pin.JointModelRZ() if robot.joint_types[i] == "revolute" else pin.JointModelPZ()
        M = pin.SE3(robot.placement_R[i], robot.placement_p[i])
        jid = model.addJoint(pin_id[int(robot.parent[i])], jm, M, robot.joint_names[i])
        pin_id[i] = jid
        model.appendBodyToJoint(
            jid, pin.Inertia(robot.mass[i], robot.com[i], robot.inertia[i]), pin.SE3.Identity())
        stack.extend(reversed(children[i + 1]))
    model.gravity.linear = np.asarray(robot.gravity, float)
    return model


class StateMap:
    """Maps our joint vectors (our order, one coordinate per joint) to Pinocchio's."""

    def __init__(self, robot, model: pin.Model) -> None:
        self.model = model
        self.jid = [model.getJointId(name) for name in robot.joint_names]
        assert all(j < model.njoints for j in self.jid), "a joint is missing in Pinocchio"
        self.iq = [model.joints[j].idx_q for j in self.jid]
        self.nq = [model.joints[j].nq for j in self.jid]
        self.iv = np.array([model.joints[j].idx_v for j in self.jid])

    def q(self, q: np.ndarray) -> np.ndarray:
        out = np.zeros(self.model.nq)
        for k, (i, nq) in enumerate(zip(self.iq, self.nq, strict=True)):
            if nq == 2:  # continuous: (cos q, sin q)
                out[i:i + 2] = np.cos(q[k]), np.sin(q[k])
            else:
                out[i] = q[k]
        return out

    def v(self, v: np.ndarray) -> np.ndarray:
        out = np.zeros(self.model.nv)
        out[self.iv] = v
        return out

    def back(self, v: np.ndarray) -> np.ndarray:
        """A Pinocchio velocity-sized vector in our order."""
        return np.asarray(v)[self.iv]

    def back_matrix(self, M: np.ndarray) -> np.ndarray:
        return np.asarray(M)[np.ix_(self.iv, self.iv)]


def body_rotations(robot, q: np.ndarray) -> np.ndarray:
    """World orientation of each of our body frames at q (a plain loop, no manipcad code)."""
    R = np.zeros((robot.n, 3, 3))
    for i in range(robot.n):
        Ri = robot.placement_R[i].copy()
        if robot.joint_types[i] == "revolute":
            c, s = np.cos(q[i] + robot.offset[i]), np.sin(q[i] + robot.offset[i])
            Ri = Ri @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        R[i] = Ri if robot.parent[i] < 0 else R[robot.parent[i]] @ Ri
    return R


def pin_fext(robot, model: pin.Model, smap: StateMap, q: np.ndarray, f_ext: np.ndarray):
    """Our f_ext (n, 6) [force, moment] in our body frames, as Pinocchio joint-frame
    forces. Our body frame and Pinocchio's joint frame share the origin; they
    differ by a fixed rotation when the URDF axis is not z (found here from the
    two models' kinematics at q)."""
    data = model.createData()
    pin.forwardKinematics(model, data, smap.q(q))
    R_ours = body_rotations(robot, q)
    forces = [pin.Force.Zero() for _ in range(model.njoints)]
    for k, j in enumerate(smap.jid):
        R_rel = data.oMi[j].rotation.T @ R_ours[k]  # pin joint frame <- our body frame
        forces[j] = pin.Force(R_rel @ f_ext[k, :3], R_rel @ f_ext[k, 3:])
    return forces


def pin_reference(robot, model, q, qd, qdd, tau, f_ext=None, gravity=None):
    """Pinocchio's (inverse dynamics, mass matrix, forward dynamics) in our order."""
    model = model.copy()
    if gravity is not None:
        model.gravity.linear = np.asarray(gravity, float)
    data = model.createData()
    smap = StateMap(robot, model)
    pq, pv, pa, pt = smap.q(q), smap.v(qd), smap.v(qdd), smap.v(tau)
    if f_ext is None:
        rnea = pin.rnea(model, data, pq, pv, pa)
        aba = pin.aba(model, data, pq, pv, pt)
    else:
        fx = pin_fext(robot, model, smap, q, f_ext)
        rnea = pin.rnea(model, data, pq, pv, pa, fx)
        aba = pin.aba(model, data, pq, pv, pt, fx)
    tau_ref = smap.back(rnea.copy())
    qdd_ref = smap.back(aba.copy())
    H = pin.crba(model, data, pq)
    H = np.triu(H) + np.triu(H, 1).T
    return tau_ref, smap.back_matrix(H), qdd_ref


def random_state(robot, rng: np.random.Generator, batch: int | None = None):
    shape = (robot.n,) if batch is None else (batch, robot.n)
    return tuple(rng.uniform(-1.5, 1.5, shape) for _ in range(4))
