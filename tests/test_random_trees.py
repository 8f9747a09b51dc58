"""Random URDF trees read by our loader and by Pinocchio's: same dynamics.

Each tree is made from one integer seed (numpy's generator): revolute,
continuous and prismatic joints on random parents, fixed joints sprinkled in
(with or without mass), random axes (unit, axis-aligned or negative), random
origins (xyz, rpy), random masses, centres and full inertia tensors with an
inertial rpy, a mimic tag now and then, and, for half of the seeds, the joint
and link elements shuffled in the file (children before parents). Hypothesis
draws the seeds (and shrinks a failure to a small one); a fixed list of seeds
always runs as well.

Checked to 1e-9 relative (see urdf_pinref.py): our robot rebuilt in Pinocchio
equals the URDF-built model (the loader alone), and ``manipcad.dynamics``
(drives=False) gives Pinocchio's RNEA, CRBA and ABA, both forward methods, with
gravity and external forces, one state and batches of states.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from urdf_pinref import close, dynamics, pin_from_robot, pin_reference

from manipcad.model.urdf import robot_from_urdf_string

AXES = ("1 0 0", "0 1 0", "0 0 1", "-1 0 0", "0 -1 0", "0 0 -1")


def _f(x: float) -> str:
    return repr(float(x))


def _vec(v) -> str:
    return " ".join(_f(x) for x in v)


def random_urdf(seed: int) -> str:
    """A random URDF tree (see the module docstring); SI units."""
    rng = np.random.default_rng(seed)
    n_mov = int(rng.integers(1, 11))
    n_fix = int(rng.integers(0, 4))
    kinds = ["movable"] * n_mov + ["fixed"] * n_fix
    rng.shuffle(kinds)
    links = ["base"]
    link_xml = ['<link name="base"><inertial><mass value="3"/>'
                '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>']
    joint_xml = []
    movable: list[str] = []
    for k, kind in enumerate(kinds):
        parent = links[int(rng.integers(len(links)))]
        child = f"l{k}"
        name = f"j{k}"
        origin = (f'<origin xyz="{_vec(rng.uniform(-0.4, 0.4, 3))}" '
                  f'rpy="{_vec(rng.uniform(-np.pi, np.pi, 3))}"/>')
        if kind == "fixed":
            jtype = "fixed"
            extra = ""
        else:
            jtype = str(rng.choice(["revolute", "continuous", "prismatic"], p=[0.45, 0.15, 0.4]))
            if rng.random() < 0.35:
                axis = AXES[int(rng.integers(len(AXES)))]
            else:
                a = rng.normal(size=3)
                axis = _vec(a / np.linalg.norm(a))
            extra = f'<axis xyz="{axis}"/>'
            if jtype != "continuous":
                lo = -rng.uniform(0.1, 3.0)
                extra += (f'<limit lower="{_f(lo)}" upper="{_f(rng.uniform(0.1, 3.0))}" '
                          'effort="10" velocity="2"/>')
            if movable and rng.random() < 0.15:
                extra += f'<mimic joint="{movable[int(rng.integers(len(movable)))]}"/>'
            movable.append(name)
        joint_xml.append(f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/>'
                         f'<child link="{child}"/>{origin}{extra}</joint>')
        # a movable joint's own link always has mass and a positive definite inertia,
        # so H is positive definite; a fixed child may be massless or have no inertial
        if kind == "fixed" and rng.random() < 0.3:
            link_xml.append(f'<link name="{child}"/>')
        else:
            m = 0.0 if kind == "fixed" and rng.random() < 0.3 else rng.uniform(0.2, 3.0)
            abc = rng.uniform(0.002, 0.05, 3) * max(m, 0.1)
            principal = np.array([abc[1] + abc[2], abc[0] + abc[2], abc[0] + abc[1]])
            R0 = pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))
            I = R0 @ np.diag(principal) @ R0.T
            link_xml.append(
                f'<link name="{child}"><inertial>'
                f'<origin xyz="{_vec(rng.uniform(-0.3, 0.3, 3))}" '
                f'rpy="{_vec(rng.uniform(-np.pi, np.pi, 3))}"/><mass value="{_f(m)}"/>'
                f'<inertia ixx="{_f(I[0, 0])}" ixy="{_f(I[0, 1])}" ixz="{_f(I[0, 2])}" '
                f'iyy="{_f(I[1, 1])}" iyz="{_f(I[1, 2])}" izz="{_f(I[2, 2])}"/>'
                '</inertial></link>')
        links.append(child)
    if rng.random() < 0.5:  # file order need not be tree order
        rng.shuffle(joint_xml)
        rng.shuffle(link_xml)
    return f'<robot name="tree{seed}">' + "".join(link_xml + joint_xml) + "</robot>"


def load_both(seed: int):
    text = random_urdf(seed)
    robot = robot_from_urdf_string(text, source=f"tree{seed}")
    model = pin.buildModelFromXML(text)
    assert robot.n == model.nv
    assert robot.mass.sum() == pytest.approx(pin.computeTotalMass(model), rel=1e-12)
    return robot, model


def states(robot, rng: np.random.Generator, batch: int | None = None):
    shape = (robot.n,) if batch is None else (batch, robot.n)
    q = rng.uniform(-np.pi, np.pi, shape)
    qd, qdd = rng.normal(0.0, 2.0, shape), rng.normal(0.0, 3.0, shape)
    tau = rng.normal(0.0, 5.0, shape)
    f_ext = rng.normal(0.0, 5.0, (*shape, 6))
    g = rng.normal(0.0, 5.0, 3)
    return q, qd, qdd, tau, f_ext, g


def check_loader(seed: int) -> None:
    """The loader alone: our robot rebuilt in Pinocchio equals Pinocchio's URDF model."""
    robot, model = load_both(seed)
    mine = pin_from_robot(robot)
    rng = np.random.default_rng(seed + 1)
    for _ in range(2):
        q, qd, qdd, tau, f_ext, g = states(robot, rng)
        ref = pin_reference(robot, model, q, qd, qdd, tau, f_ext=f_ext, gravity=g)
        got = pin_reference(robot, mine, q, qd, qdd, tau, f_ext=f_ext, gravity=g)
        for a, b in zip(got, ref, strict=True):
            close(a, b)


def check_dynamics(seed: int) -> None:
    """manipcad.dynamics (drives=False) against Pinocchio on one state."""
    dyn = dynamics()
    robot, model = load_both(seed)
    rng = np.random.default_rng(seed + 2)
    q, qd, qdd, tau, f_ext, g = states(robot, rng)
    for fx in (None, f_ext):
        tau_ref, H_ref, qdd_ref = pin_reference(robot, model, q, qd, qdd, tau, f_ext=fx,
                                                gravity=g)
        close(dyn.inverse_dynamics(robot, q, qd, qdd, gravity=g, f_ext=fx, drives=False),
              tau_ref)
        close(dyn.mass_matrix(robot, q, drives=False), H_ref)
        for method in ("aba", "crba"):
            close(dyn.forward_dynamics(robot, q, qd, tau, method=method, gravity=g, f_ext=fx,
                                       drives=False), qdd_ref)


SEEDS = list(range(40))


@pytest.mark.parametrize("seed", SEEDS)
def test_loader_matches_pinocchio(seed):
    check_loader(seed)


@pytest.mark.parametrize("seed", SEEDS)
def test_dynamics_match_pinocchio(seed):
    check_dynamics(seed)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1))
def test_random_seeds_match_pinocchio(seed):
    check_loader(seed)
    check_dynamics(seed)


@pytest.mark.parametrize("seed", [3, 17, 101, 2024])
def test_batched_dynamics_match_pinocchio(seed):
    """(N, n) inputs give the per-state Pinocchio answers, with gravity and f_ext (N, n, 6)."""
    dyn = dynamics()
    robot, model = load_both(seed)
    rng = np.random.default_rng(seed + 3)
    N = 6
    q, qd, qdd, tau, f_ext, g = states(robot, rng, batch=N)
    tau_b = dyn.inverse_dynamics(robot, q, qd, qdd, gravity=g, f_ext=f_ext, drives=False)
    H_b = dyn.mass_matrix(robot, q, drives=False)
    fd = {m: dyn.forward_dynamics(robot, q, qd, tau, method=m, gravity=g, f_ext=f_ext,
                                  drives=False) for m in ("aba", "crba")}
    assert tau_b.shape == (N, robot.n) and H_b.shape == (N, robot.n, robot.n)
    for k in range(N):
        tau_ref, H_ref, qdd_ref = pin_reference(robot, model, q[k], qd[k], qdd[k], tau[k],
                                                f_ext=f_ext[k], gravity=g)
        close(tau_b[k], tau_ref)
        close(H_b[k], H_ref)
        for m in fd:
            assert fd[m].shape == (N, robot.n)
            close(fd[m][k], qdd_ref)


def test_generator_covers_the_cases():
    """The seeds above do exercise shuffled files, fixed joints, odd axes and all types."""
    texts = [random_urdf(s) for s in SEEDS]
    joined = "".join(texts)
    for fragment in ('type="fixed"', 'type="continuous"', 'type="prismatic"',
                     'type="revolute"', "<mimic", 'xyz="0 0 -1"', 'mass value="0.0"'):
        assert fragment in joined, fragment
    robots = [robot_from_urdf_string(t) for t in texts]
    assert max(r.n for r in robots) >= 8
    assert any(any(p >= 0 for p in r.parent) and len(set(r.parent)) < r.n for r in robots)
    # some file lists a joint before the joint that carries its parent link
    assert any(_child_first(t) for t in texts)


def _child_first(text: str) -> bool:
    joints = ET.fromstring(text).findall("joint")
    seen_children: set[str] = set()
    later = {j.find("child").get("link") for j in joints}
    for j in joints:
        parent = j.find("parent").get("link")
        if parent in later and parent not in seen_children:
            return True
        seen_children.add(j.find("child").get("link"))
    return False
