"""Inverse, mass-matrix and forward dynamics against Pinocchio on random trees."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import random_tree, rel_err

import manipcad
from manipcad.model.to_pinocchio import to_pinocchio

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


def test_fast_path_and_checked_path_agree():
    """One-state calls of plain float64 vectors take a compiled fast path; any other
    input (lists, ints, strided or readonly arrays) the checked path: same results."""
    robot = random_tree(4, n=5, drives=True)
    rng = np.random.default_rng(2)
    q, qd, x = rng.normal(size=(3, robot.n))
    ref = {
        "tau": manipcad.inverse_dynamics(robot, q, qd, x),
        "H": manipcad.mass_matrix(robot, q),
        "aba": manipcad.forward_dynamics(robot, q, qd, x),
        "crba": manipcad.forward_dynamics(robot, q, qd, x, method="crba"),
    }
    readonly = q.copy()
    readonly.setflags(write=False)
    strided = np.repeat(q, 2)[::2]
    for qq in (list(q), readonly, strided):
        assert np.array_equal(manipcad.inverse_dynamics(robot, qq, qd, x), ref["tau"])
        assert np.array_equal(manipcad.mass_matrix(robot, qq), ref["H"])
        assert np.array_equal(manipcad.forward_dynamics(robot, qq, qd, x), ref["aba"])
        assert np.array_equal(manipcad.forward_dynamics(robot, qq, qd, x, method="crba"),
                              ref["crba"])
    ints = np.arange(robot.n)
    assert np.array_equal(manipcad.inverse_dynamics(robot, ints, ints, ints),
                          manipcad.inverse_dynamics(robot, ints * 1.0, ints * 1.0, ints * 1.0))
    # the given gravity and external forces go the checked way too
    assert np.array_equal(manipcad.inverse_dynamics(robot, q, qd, x, gravity=robot.gravity),
                          ref["tau"])
    assert np.array_equal(manipcad.inverse_dynamics(robot, q, qd, x, f_ext=np.zeros((5, 6))),
                          ref["tau"])
    # wrong lengths leave the fast path and get the message naming the argument
    short = np.zeros(robot.n - 1)
    with pytest.raises(manipcad.ManipcadError, match="qdd"):
        manipcad.inverse_dynamics(robot, q, qd, short)
    with pytest.raises(manipcad.ManipcadError, match="q must have"):
        manipcad.mass_matrix(robot, short)
    for method in ("aba", "crba"):
        with pytest.raises(manipcad.ManipcadError, match="tau"):
            manipcad.forward_dynamics(robot, q, qd, short, method=method)


def test_parallel_batches_equal_serial_ones(monkeypatch):
    """Large batches run in chunks on numba's threads: the same numbers as one by one."""
    from manipcad.dynamics import _inputs
    from manipcad.dynamics.aba import aba_batch, aba_batch_parallel
    from manipcad.dynamics.crba import crba_batch, crba_batch_parallel
    from manipcad.dynamics.forward_crba import crba_fd_batch, crba_fd_batch_parallel
    from manipcad.dynamics.rnea import rnea_batch, rnea_batch_parallel

    robot = random_tree(5, n=6, drives=True)
    rng = np.random.default_rng(3)
    N, n = 45, robot.n
    Q, QD, X = rng.normal(size=(3, N, n))
    F = rng.normal(size=(N, n, 6))
    T, g = robot.table, robot.gravity
    for use_f, FF in ((False, _inputs.NO_FEXT), (True, F)):
        for serial, parallel, args, shape in (
                (rnea_batch, rnea_batch_parallel, (T, g, Q, QD, X, FF, use_f, True), (N, n)),
                (aba_batch, aba_batch_parallel, (T, g, Q, QD, X, FF, use_f, True), (N, n)),
                (crba_fd_batch, crba_fd_batch_parallel, (T, g, Q, QD, X, FF, use_f, True),
                 (N, n)),
                (crba_batch, crba_batch_parallel, (T, Q, True), (N, n, n))):
            a, b = np.empty(shape), np.empty(shape)
            ra = serial(*args, a)
            for chunks in (1, 4, 7):
                rb = parallel(*args, b, chunks)
                assert ra == rb and np.array_equal(a, b)
    # through the public functions, with the threshold lowered
    monkeypatch.setattr(_inputs, "PARALLEL_MIN_WORK", 0)
    tau = manipcad.inverse_dynamics(robot, Q, QD, X, f_ext=F)
    for k in (0, 22, 44):
        assert np.array_equal(tau[k], manipcad.inverse_dynamics(robot, Q[k], QD[k], X[k],
                                                                 f_ext=F[k]))
    assert rel_err(manipcad.forward_dynamics(robot, Q, QD, tau, f_ext=F), X) < TOL
    assert rel_err(manipcad.forward_dynamics(robot, Q, QD, tau, f_ext=F, method="crba"), X) < TOL
    assert np.array_equal(manipcad.mass_matrix(robot, Q)[30], manipcad.mass_matrix(robot, Q[30]))


def test_singular_mass_matrix_names_the_state():
    """A joint that moves no mass makes H singular: the Cholesky path says at which state."""
    robot = random_tree(6, n=3, chain=True).replace(mass=np.zeros(3),
                                                     inertia=np.zeros((3, 3, 3)))
    Q = np.zeros((5, 3))
    with pytest.raises(manipcad.ManipcadError, match="state 0"):
        manipcad.forward_dynamics(robot, Q[0], Q[0], Q[0], method="crba", drives=False)
    with pytest.raises(manipcad.ManipcadError, match="state 0"):
        manipcad.forward_dynamics(robot, Q, Q, Q, method="crba", drives=False)
