"""Robots from the Robotics Toolbox for Python (``pip install roboticstoolbox-python``).

``robot_from_rtb(r)`` maps a ``DHRobot`` (standard or modified DH) or an
``ERobot``/``Robot`` (elementary transform sequences, e.g. from URDF) with its
link dynamics (m, r, I) and motor parameters (Jm, G, B, Tc) onto a
:class:`~manipcad.model.Robot`; the inverse dynamics and mass matrix equal
rtb's ``rne`` and ``inertia`` (tests/test_model_import.py).

Motor terms (Corke's convention, referred to the link by the gear ratio G):
rotor inertia Jm·G², viscous friction B·G²·q̇ and Coulomb friction |G|·Tc
(Tc = [Tc+, Tc-], Tc- ≤ 0) become a :class:`~manipcad.model.robot.Drive` with
J = Jm kg·m², ratio = G, k_v = B N·m·s/rad, M_f = (Tc+, |Tc-|) N·m; the
electrical data are unknown (nan).
"""

from __future__ import annotations

import math

import numpy as np

from manipcad.errors import InputError
from manipcad.model.convert import SourceBody, homogeneous, joints_from_bodies, robot_from_joints
from manipcad.model.convert import robot_from_joints as _build
from manipcad.model.robot import PRISMATIC, REVOLUTE, Drive, Robot


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return homogeneous(np.array([[1, 0, 0], [0, c, -s], [0, s, c]]))


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return homogeneous(np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]))


def _drive(link) -> Drive | None:
    Jm, G, B = (float(getattr(link, k, 0.0) or 0.0) for k in ("Jm", "G", "B"))
    Tc = np.asarray(getattr(link, "Tc", (0.0, 0.0)), dtype=float).reshape(-1)
    Tc = np.array([Tc[0], Tc[0]]) if Tc.size == 1 else Tc[:2]
    if Jm == 0.0 and B == 0.0 and not Tc.any():
        return None
    if G == 0.0:
        raise InputError(f"link {link.name!r}", "G", "gear ratio 0 with motor terms set")
    return Drive(J=Jm, ratio=G, k_v=B, M_f=(float(Tc[0]), float(Tc[1])))


def _limits(link) -> tuple[float, float]:
    ql = getattr(link, "qlim", None)
    if ql is None:
        return (-math.inf, math.inf)
    ql = np.asarray(ql, dtype=float).reshape(-1)
    return (float(ql[0]), float(ql[1])) if ql.size == 2 else (-math.inf, math.inf)


def _dh_bodies(r) -> list[SourceBody]:
    bodies = []
    for i, L in enumerate(r.links):
        kind = PRISMATIC if L.isprismatic else REVOLUTE
        a, alpha, d, theta = float(L.a), float(L.alpha), float(L.d), float(L.theta)
        tz, tx = homogeneous(p=[0, 0, d]), homogeneous(p=[a, 0, 0])
        if r.mdh:  # modified: Rx(alpha) Tx(a) Rz(theta) Tz(d), joint on theta or d
            A = _rx(alpha) @ tx
            A, B = (A, tz) if kind == REVOLUTE else (A @ _rz(theta), np.eye(4))
        else:  # standard: Rz(theta) Tz(d) Tx(a) Rx(alpha)
            B = tx @ _rx(alpha)
            A, B = (np.eye(4), tz @ B) if kind == REVOLUTE else (_rz(theta), B)
        name = L.name or f"q{i + 1}"
        bodies.append(SourceBody(
            name=f"link{i + 1}", parent=i - 1, T=A,
            joint=(name, kind, np.array([0.0, 0.0, 1.0]), B,
                   float(L.offset), _limits(L), _drive(L)),
            mass=float(L.m or 0.0), com=np.asarray(L.r, float).reshape(3),
            inertia=np.asarray(L.I, float).reshape(3, 3)))
    return bodies


_AXES = {"Rx": (REVOLUTE, 0), "Ry": (REVOLUTE, 1), "Rz": (REVOLUTE, 2),
         "tx": (PRISMATIC, 0), "ty": (PRISMATIC, 1), "tz": (PRISMATIC, 2)}


def _ets_bodies(r) -> list[SourceBody]:
    links = list(r.links)
    index = {id(L): k for k, L in enumerate(links)}
    bodies = []
    for L in links:
        parent = -1 if L.parent is None else index[id(L.parent)]
        before, after, joint = np.eye(4), np.eye(4), None
        for et in L.ets:
            if et.isjoint:
                if joint is not None:
                    raise InputError(f"link {L.name!r}", "ets", "more than one joint")
                which = getattr(et, "kind", None) or et.axis  # .axis before rtb 1.4
                if which not in _AXES:
                    raise InputError(f"link {L.name!r}", "ets", f"joint axis {which!r}")
                kind, k = _AXES[which]
                axis = np.zeros(3)
                axis[k] = -1.0 if et.isflip else 1.0
                joint = (kind, axis)
            elif joint is None:
                before = before @ np.asarray(et.A(), dtype=float)
            else:
                after = after @ np.asarray(et.A(), dtype=float)
        if joint is None:
            spec = None
            T = before @ after
        else:
            jname = getattr(L, "joint_name", None) or L.name
            spec = (jname, joint[0], joint[1], after, 0.0, _limits(L), _drive(L))
            T = before
        bodies.append(SourceBody(name=L.name, parent=parent, T=T, joint=spec,
                                 mass=float(L.m or 0.0), com=np.asarray(L.r, float).reshape(3),
                                 inertia=np.asarray(L.I, float).reshape(3, 3)))
    return bodies


def robot_from_rtb(r, name: str | None = None) -> Robot:
    """A :class:`~manipcad.model.Robot` from a Robotics Toolbox robot.

    Args:
        r: a ``roboticstoolbox`` ``DHRobot`` or ``ERobot``/``Robot`` (link
            masses m kg, centres r m, inertias I kg·m² about the centre in
            link axes; motor Jm kg·m², G, B N·m·s/rad, Tc N·m).
        name: the robot's name (default ``r.name``).

    Returns:
        The robot, its base and tool frames and gravity included.

    Raises:
        InputError: a link with more than one joint variable or no dynamics.

    Example:
        >>> import roboticstoolbox as rtb
        >>> robot_from_rtb(rtb.models.DH.Puma560()).n
        6
    """

    is_dh = hasattr(r, "mdh")
    bodies = _dh_bodies(r) if is_dh else _ets_bodies(r)
    joints = joints_from_bodies(bodies)
    if len(joints) != r.n:
        raise InputError(f"rtb robot {r.name!r}", "", f"{len(joints)} joints found, rtb says "
                         f"{r.n}")
    base = np.asarray(r.base.A, dtype=float) if getattr(r, "base", None) is not None else None
    tool = np.asarray(r.tool.A, dtype=float) if getattr(r, "tool", None) is not None else None
    gravity = np.asarray(getattr(r, "gravity", (0.0, 0.0, -9.81)), dtype=float).reshape(3)
    return _build(name or r.name or "rtb robot", joints, base=base, gravity=gravity,
                  tool=tool if is_dh else None, source=f"roboticstoolbox {type(r).__name__}")


__all__ = ["robot_from_rtb", "robot_from_joints"]
