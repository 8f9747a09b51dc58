"""Real-time moment components: H_ii, h_i and Q_i of a state in one compiled call.

The adaptive regulators of paper section 3 read, every control period, the
current inertial (H_ii), velocity (h_i) and gravity (Q_i) constituents of
their drive (paper 4.1: "the problem of determination in real time components
of moment actions has been solved"). :func:`manipcad.torque_components` gives
those and more (the whole split of P_i, in five calls); this module gives just
the three, for one state or a batch, in one call of one compiled kernel:

- H_ii: the diagonal of the composite-rigid-body inertia matrix (links only;
  the drive's J·i_r² is constant and can be added by the caller), kg·m² or kg;
- h_i: inverse dynamics at (q, q̇, q̈ = 0) without gravity and drive terms, N·m or N;
- Q_i: inverse dynamics at (q, 0, 0) with gravity, N·m or N.

:func:`components_one` is the per-state kernel itself (numba); a compiled
regulator or simulator can call it directly inside its own loop with
preallocated scratch (see :func:`scratch`). ``benchmarks/bench_components.py``
measures the time per sample against a 1 ms control period
(docs/identification.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from manipcad.dynamics._inputs import as_gravity, as_states
from manipcad.dynamics.crba import CRBA_WORK, crba_one
from manipcad.dynamics.rnea import RNEA_WORK, rnea_one
from manipcad.model.robot import Robot


@dataclass(frozen=True)
class MomentComponents:
    """The constituents an adaptive regulator reads, each shaped like q ((n,) or (N, n)).

    Attributes:
        H_ii: diagonal of the links' inertia matrix, kg·m² (kg for prismatic joints).
        velocity: h_i, Coriolis and centrifugal constituent, N·m (N).
        gravity: Q_i, gravity constituent, N·m (N).
    """

    H_ii: np.ndarray
    velocity: np.ndarray
    gravity: np.ndarray


@nb.njit(cache=True, nogil=True)
def components_one(table, g, q, qd, zero, rwork, cwork, tmp, H, H_ii, h, Qg):
    """H_ii, h_i, Q_i of one state into H_ii, h, Qg (each (n,)).

    Scratch: zero (n,) zeros, rwork (n, RNEA_WORK), cwork (n, CRBA_WORK), tmp (8, 3),
    H (n, n); g is the gravity vector (3,), m/s².
    """
    n = table.shape[0]
    crba_one(table, q, False, cwork, tmp, H)
    for i in range(n):
        H_ii[i] = H[i, i]
    nog = np.zeros(3)
    # the drive terms off by a run-time flag, not the literal False: rnea_one compiles
    # once for these calls and the payload estimator's (its flag a run-time one), not
    # twice (2-4 s of CPU on a cold cache)
    links = bool(0)
    rnea_one(table, nog, q, qd, zero, rwork, False, links, rwork, h)
    rnea_one(table, g, q, zero, zero, rwork, False, links, rwork, Qg)


@nb.njit(cache=True, nogil=True)
def components_batch(table, g, Q, QD, HII, HV, QG):
    """H_ii, h_i, Q_i of N states: rows of Q, QD (N, n) into HII, HV, QG (N, n)."""
    n = table.shape[0]
    zero = np.zeros(n)
    rwork = np.empty((n, RNEA_WORK))
    cwork = np.empty((n, CRBA_WORK))
    tmp = np.zeros((8, 3))
    H = np.empty((n, n))
    for k in range(Q.shape[0]):
        components_one(table, g, Q[k], QD[k], zero, rwork, cwork, tmp, H, HII[k], HV[k], QG[k])


def scratch(n: int) -> tuple[np.ndarray, ...]:
    """Scratch arrays for :func:`components_one`: (zero, rwork, cwork, tmp, H)."""
    return (np.zeros(n), np.empty((n, RNEA_WORK)), np.empty((n, CRBA_WORK)),
            np.zeros((8, 3)), np.empty((n, n)))


def moment_components(robot: Robot, q, qd, *, gravity=None) -> MomentComponents:
    """H_ii, h_i and Q_i along states, in one compiled call.

    Args:
        robot: the manipulator.
        q: joint positions, rad or m, shape (n,) or (N, n).
        qd: joint velocities, rad/s or m/s, same shape.
        gravity: gravity in the base frame, m/s², shape (3,); default the robot's.

    Returns:
        :class:`MomentComponents`; equal to ``torque_components``'s ``H_ii``,
        ``velocity`` and ``gravity`` (which do not depend on q̈).

    Example:
        >>> import numpy as np, manipcad
        >>> from manipcad.analysis import moment_components
        >>> arm = manipcad.load_robot("cylindrical")
        >>> mc = moment_components(arm, np.array([0.0, 0.2, 0.5]), np.array([1.0, 0.0, 0.0]))
        >>> round(float(mc.velocity[2]), 3)  # centrifugal force on the reach, N
        -0.391
    """
    (Q, QD), single = as_states(robot.n, q=q, qd=qd)
    g = as_gravity(robot, gravity)
    HII = np.empty(Q.shape)
    HV = np.empty(Q.shape)
    QG = np.empty(Q.shape)
    components_batch(robot.table, g, Q, QD, HII, HV, QG)
    if single:
        return MomentComponents(HII[0], HV[0], QG[0])
    return MomentComponents(HII, HV, QG)
