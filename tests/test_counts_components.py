"""Operation counts (counted by running the kernels) and the torque constituents."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import random_tree, rel_err

import manipcad
from manipcad.dynamics.counts import _plain
from manipcad.dynamics.rnea import RNEA_WORK, rnea_one
from manipcad.model.to_pinocchio import to_pinocchio


@pytest.mark.parametrize("algorithm", ["rnea", "aba"])
def test_recursive_algorithms_count_linear_in_n(algorithm):
    counts = [manipcad.operation_counts(algorithm, n) for n in range(2, 7)]
    for key in ("mul", "add"):
        steps = np.diff([c[key] for c in counts])
        assert steps.min() == steps.max() > 0, steps


def test_mass_matrix_count_quadratic_in_n():
    muls = [manipcad.operation_counts("crba", n)["mul"] for n in range(2, 8)]
    second = np.diff(muls, 2)
    assert second.min() == second.max() > 0


def test_counted_source_is_the_compiled_algorithm():
    """The plain-Python twin that is counted gives the compiled kernel's torques."""
    robot = random_tree(2, n=5)
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.normal(size=(3, robot.n))
    tau = np.empty(robot.n)
    _plain(rnea_one)(robot.table, robot.gravity, q, qd, qdd, np.zeros((robot.n, 6)), False,
                     True, np.empty((robot.n, RNEA_WORK)), tau)
    assert rel_err(tau, manipcad.inverse_dynamics(robot, q, qd, qdd)) < 1e-12


def test_bad_count_request():
    with pytest.raises(manipcad.ManipcadError):
        manipcad.operation_counts("newton", 3)


def test_components_sum_to_inverse_dynamics_and_match_pinocchio():
    robot = random_tree(7, n=6, drives=True)
    model, order = to_pinocchio(robot)
    data = model.createData()
    rng = np.random.default_rng(3)
    Q, QD, QDD = rng.normal(size=(3, 4, robot.n))
    F = rng.normal(size=(4, robot.n, 6))
    parts = manipcad.torque_components(robot, Q, QD, QDD, f_ext=F)
    assert rel_err(parts.total, manipcad.inverse_dynamics(robot, Q, QD, QDD, f_ext=F)) < 1e-12
    for k in range(4):
        qp = (Q[k] + robot.offset)[order]
        H = pin.crba(model, data, qp)
        H = np.triu(H) + np.triu(H, 1).T
        g = pin.computeGeneralizedGravity(model, data, qp)
        nle = pin.nonLinearEffects(model, data, qp, QD[k][order])
        assert rel_err(parts.H_ii[k][order], np.diag(H)) < 1e-9
        assert rel_err(parts.gravity[k][order], g) < 1e-9
        assert rel_err(parts.velocity[k][order], nle - g) < 1e-9
        own = np.diag(H) * QDD[k][order]
        assert rel_err(parts.coupling[k][order], H @ QDD[k][order] - own) < 1e-9
        J = [d.J * d.ratio**2 for d in robot.drives]
        assert rel_err(parts.rotor[k], np.array(J) * QDD[k]) < 1e-12
