"""Inverse, mass-matrix and forward dynamics against Pinocchio on random trees."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import random_tree, rel_err

import manipcad
from manipcad.interop.pinocchio import to_pinocchio

TOL = 1e-9


def _pin_forces(fext, order):
    return [pin.Force.Zero()] + [pin.Force(fext[i, :3], fext[i, 3:]) for i in order]


def test_rnea_crba_aba_match_pinocchio(tree):
    model, order = to_pinocchio(tree)
    data = model.createData()
    rng = np.random.default_rng(42)
    for _ in range(5):
        q, qd, qdd = rng.normal(size=(3, tree.n))
        fext = rng.normal(size=(tree.n, 6))
        qp = (q + tree.offset)[order]
        tau = manipcad.inverse_dynamics(tree, q, qd, qdd, drives=False)
        assert rel_err(tau[order], pin.rnea(model, data, qp, qd[order], qdd[order])) < TOL
        tau_f = manipcad.inverse_dynamics(tree, q, qd, qdd, drives=False, f_ext=fext)
        ref = pin.rnea(model, data, qp, qd[order], qdd[order], _pin_forces(fext, order))
        assert rel_err(tau_f[order], ref) < TOL
        H = manipcad.mass_matrix(tree, q, drives=False)
        Hp = pin.crba(model, data, qp)
        Hp = np.triu(Hp) + np.triu(Hp, 1).T
        assert rel_err(H[np.ix_(order, order)], Hp) < TOL
        for method in ("aba", "crba"):
            a = manipcad.forward_dynamics(tree, q, qd, tau, method=method, drives=False)
            ref = pin.aba(model, data, qp, qd[order], tau[order])
            assert rel_err(a[order], ref) < TOL
            a = manipcad.forward_dynamics(tree, q, qd, tau_f, method=method, drives=False,
                                          f_ext=fext)
            assert rel_err(a, qdd) < TOL


def test_drive_terms_match_pinocchio_armature_and_closed_form():
    robot = random_tree(11, n=6, drives=True)
    model, order = to_pinocchio(robot, armature=True)
    data = model.createData()
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.normal(size=(3, robot.n))
    qp = (q + robot.offset)[order]
    friction = np.array([d.k_v * d.ratio**2 * v + abs(d.ratio) * (d.M_f[0] if v > 0 else -d.M_f[1])
                         for d, v in zip(robot.drives, qd, strict=True)])
    tau = manipcad.inverse_dynamics(robot, q, qd, qdd)
    ref = pin.rnea(model, data, qp, qd[order], qdd[order]) + friction[order]
    assert rel_err(tau[order], ref) < TOL
    H = manipcad.mass_matrix(robot, q)
    Hp = pin.crba(model, data, qp)
    assert rel_err(H[np.ix_(order, order)], np.triu(Hp) + np.triu(Hp, 1).T) < TOL
    for method in ("aba", "crba"):
        assert rel_err(manipcad.forward_dynamics(robot, q, qd, tau, method=method), qdd) < TOL


def test_batches_match_single_states(tree):
    rng = np.random.default_rng(5)
    N = 17
    Q, QD, QDD = rng.normal(size=(3, N, tree.n))
    F = rng.normal(size=(N, tree.n, 6))
    tau = manipcad.inverse_dynamics(tree, Q, QD, QDD, f_ext=F)
    H = manipcad.mass_matrix(tree, Q)
    a = manipcad.forward_dynamics(tree, Q, QD, tau, f_ext=F)
    assert tau.shape == (N, tree.n) and H.shape == (N, tree.n, tree.n) and a.shape == (N, tree.n)
    for k in (0, 7, 16):
        assert np.array_equal(tau[k], manipcad.inverse_dynamics(tree, Q[k], QD[k], QDD[k],
                                                                 f_ext=F[k]))
        assert np.array_equal(H[k], manipcad.mass_matrix(tree, Q[k]))
    assert rel_err(a, QDD) < TOL


@pytest.mark.parametrize("seed", range(4))
def test_mass_matrix_symmetric_positive_definite(seed):
    robot = random_tree(seed, n=8)
    Q = np.random.default_rng(seed).normal(size=(20, robot.n))
    H = manipcad.mass_matrix(robot, Q, drives=False)
    assert np.array_equal(H, H.transpose(0, 2, 1))
    assert np.linalg.eigvalsh(H).min() > 0


def test_passive_motion_conserves_energy():
    """A passive tree (no drives, no friction) keeps kinetic + potential energy."""
    robot = random_tree(3, n=5, chain=True)
    model, order = to_pinocchio(robot)
    data = model.createData()
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.normal(size=robot.n), rng.normal(size=robot.n)])
    n = robot.n

    def f(x):
        q, qd = x[:n], x[n:]
        return np.concatenate([qd, manipcad.forward_dynamics(robot, q, qd, np.zeros(n),
                                                             drives=False)])

    def energy(x):
        q, qd = x[:n], x[n:]
        H = manipcad.mass_matrix(robot, q, drives=False)
        # potential from Pinocchio's own kinematics (independent of our code)
        qp = (q + robot.offset)[order]
        return 0.5 * qd @ H @ qd + pin.computePotentialEnergy(model, data, qp)

    e0, dt = energy(x), 1e-4
    for _ in range(2000):
        k1 = f(x)
        k2 = f(x + dt / 2 * k1)
        k3 = f(x + dt / 2 * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert abs(energy(x) - e0) < 1e-8 * max(1.0, abs(e0))


def test_bad_shapes_name_the_argument():
    robot = random_tree(0, n=3)
    with pytest.raises(manipcad.ManipcadError, match="qd"):
        manipcad.inverse_dynamics(robot, np.zeros(3), np.zeros(4), np.zeros(3))
    with pytest.raises(manipcad.ManipcadError, match="q must have"):
        manipcad.mass_matrix(robot, np.zeros((2, 2, 3)))
    with pytest.raises(manipcad.ManipcadError, match="f_ext"):
        manipcad.inverse_dynamics(robot, np.zeros(3), np.zeros(3), np.zeros(3),
                                  f_ext=np.zeros((3, 3)))
    with pytest.raises(manipcad.ManipcadError, match="method"):
        manipcad.forward_dynamics(robot, np.zeros(3), np.zeros(3), np.zeros(3), method="x")
