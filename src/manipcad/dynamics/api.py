"""The public dynamics functions: one state (n,) or a batch (N, n) in, matching shape out.

Each function has a fast path for the common call, one state given as 1-D
float64 arrays with the robot's own gravity and no external forces: a compiled
kernel with fixed argument types checks the lengths itself, and any other
input (lists, other dtypes, wrong lengths) falls back to the checked path of
:mod:`manipcad.dynamics._inputs`, which converts it or raises the error that
names the argument. Large batches run on numba's threads (see
:func:`manipcad.dynamics._inputs.batch_runner`).
"""

from __future__ import annotations

import numpy as np

from manipcad.dynamics._inputs import (
    NO_FEXT,
    as_fext,
    as_gravity,
    as_states,
    batch_runner,
    vector_kernel,
)
from manipcad.dynamics.aba import aba_batch, aba_batch_parallel
from manipcad.dynamics.crba import crba_batch, crba_batch_parallel
from manipcad.dynamics.forward_crba import crba_fd_batch, crba_fd_batch_parallel
from manipcad.dynamics.generated import attached
from manipcad.dynamics.rnea import rnea_batch, rnea_batch_parallel
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot, require_robot

_run_rnea = batch_runner(rnea_batch, rnea_batch_parallel, 2)
_run_crba = batch_runner(crba_batch, crba_batch_parallel, 1)
_run_aba = batch_runner(aba_batch, aba_batch_parallel, 2)
_run_crba_fd = batch_runner(crba_fd_batch, crba_fd_batch_parallel, 2)
_vectors: dict = {}  # name -> compiled one-state kernel, made on first use


def not_positive_definite(state: int) -> ManipcadError:
    """The error of a state whose mass matrix H is not positive definite: a joint that
    moves no mass (nor a rotor), so no torque accelerates it.

    Args:
        state: the state's index in the batch (0 for one state).

    Returns:
        the :class:`~manipcad.errors.ManipcadError` to raise, naming the state.

    Example:
        >>> print(not_positive_definite(3))  # doctest: +ELLIPSIS
        the mass matrix is not positive definite at state 3: a joint moves no mass ...
    """
    return ManipcadError(f"the mass matrix is not positive definite at state {state}: "
                         "a joint moves no mass (add inertia or a drive)")


#: the gravity of :func:`moves_mass`'s inverse dynamics: none (m/s²)
_NO_GRAVITY = np.zeros(3)


def moves_mass(robot: Robot, q: np.ndarray, drives: bool) -> bool:
    """Whether every joint moves some mass (or a rotor) at q: the mass matrix H(q) is
    positive definite, so the arm can accelerate from there (a simulation checks its
    initial state so; the error to give otherwise is :func:`not_positive_definite`).

    H comes from the batched inverse dynamics (column j: the torques of q̈ = e_j at rest
    without gravity, a batch of n states) and numpy's Cholesky: the kernel a run's checks
    use anyway, so a first simulation compiles no kernel of its own for this (the
    one-state forward dynamics by Cholesky inlines the inverse dynamics and the mass
    matrix once more: about 5 s of compile on a cold cache). About 10 µs.

    Args:
        robot: the robot.
        q: (n,) float64 joint positions, rad or m.
        drives: with the rotors' inertias J·i_r² on H's diagonal.

    Returns:
        True when H(q) is positive definite.

    Example:
        >>> import numpy as np, manipcad
        >>> moves_mass(manipcad.load_robot("puma560"), np.zeros(6), drives=False)
        True
    """
    n = robot.n
    Q, H = np.empty((n, n)), np.empty((n, n))
    Q[:] = q
    _run_rnea(robot.table, _NO_GRAVITY, Q, np.zeros((n, n)), np.eye(n), NO_FEXT, False,
              bool(drives), H)
    try:
        np.linalg.cholesky(H)
    except np.linalg.LinAlgError:
        return False
    return True


def _generated(robot: Robot, use: bool, source: str):
    """The customized kernels :func:`manipcad.codegen.generate` attached to this robot
    (:mod:`manipcad.dynamics.generated`), or None; anything but a Robot refused naming
    ``source``'s ``robot`` argument."""
    if type(robot) is not Robot:
        require_robot(robot, source)
    return attached(robot) if use else None


def inverse_dynamics(robot: Robot, q, qd, qdd, *, gravity=None, f_ext=None,
                     drives: bool = True, use_generated: bool = True) -> np.ndarray:
    """Joint torques that produce a motion: the recursive algorithm of paper 4.1.

    Args:
        robot: the manipulator.
        q: joint positions, rad or m, shape (n,) or (N, n).
        qd: joint velocities, rad/s or m/s, same shape.
        qdd: joint accelerations, rad/s² or m/s², same shape.
        gravity: gravity vector in the base frame, m/s², shape (3,); default the robot's.
        f_ext: external wrenches on the links, [force (N), moment (N·m) about the
            body-frame origin] in each link's body axes, shape (n, 6) or (N, n, 6).
            They act on the robot, so they lower the torques needed.
        drives: add the drive terms J·i_r²·q̈ + k_v·i_r²·q̇ + |i_r|·M_f·sign(q̇)
            (False: the pure rigid body).
        use_generated: call the robot's customized kernels when
            :func:`manipcad.codegen.generate` made them for this robot object (and
            gravity and f_ext are not given); False: always the general kernels.

    Returns:
        Joint torques P (N·m, or N for prismatic joints), shape like q.

    Example:
        >>> import numpy as np, manipcad
        >>> puma = manipcad.load_robot("puma560")
        >>> tau = manipcad.inverse_dynamics(puma, np.zeros(6), np.zeros(6), np.zeros(6))
        >>> tau.shape
        (6,)
    """
    gen = _generated(robot, use_generated, "inverse_dynamics")
    if gen is not None and gravity is None and f_ext is None:
        return gen.inverse_dynamics(q, qd, qdd, drives)
    if gravity is None and f_ext is None and type(q) is np.ndarray and q.ndim == 1:
        tau = np.empty(q.shape[0])
        try:
            (_vectors.get("rnea") or vector_kernel(_vectors, "rnea"))(
                robot.table, robot.gravity, q, qd, qdd, drives, tau, NO_FEXT, False)
            return tau
        except (TypeError, ValueError):
            pass  # not float64 vectors of length n: the checked path converts or explains
    (Q, QD, QDD), single = as_states(robot.n, q=q, qd=qd, qdd=qdd)
    F, use_f = as_fext(robot.n, Q.shape[0], single, f_ext)
    tau = np.empty(Q.shape)
    _run_rnea(robot.table, as_gravity(robot, gravity), Q, QD, QDD, F, use_f, drives, tau)
    return tau[0] if single else tau


def mass_matrix(robot: Robot, q, *, drives: bool = True,
                use_generated: bool = True) -> np.ndarray:
    """Joint-space inertia matrix H(q): the composite algorithm of paper 4.2 (method 1).

    Args:
        robot: the manipulator.
        q: joint positions, rad or m, shape (n,) or (N, n).
        drives: add the rotor inertias J·i_r² on the diagonal.
        use_generated: as in :func:`inverse_dynamics`.

    Returns:
        H, shape (n, n) or (N, n, n); kg·m² between revolute joints, kg between
        prismatic ones, kg·m for mixed pairs.

    Example:
        >>> import numpy as np, manipcad
        >>> H = manipcad.mass_matrix(manipcad.load_robot("puma560"), np.zeros(6))
    """
    gen = _generated(robot, use_generated, "mass_matrix")
    if gen is not None:
        return gen.mass_matrix(q, drives)
    if type(q) is np.ndarray and q.ndim == 1:
        H = np.empty((robot.n, robot.n))
        try:
            (_vectors.get("mass") or vector_kernel(_vectors, "mass"))(robot.table, q, drives, H)
            return H
        except (TypeError, ValueError):
            pass  # not a float64 vector of length n: the checked path converts or explains
    (Q,), single = as_states(robot.n, q=q)
    H = np.empty((Q.shape[0], robot.n, robot.n))
    _run_crba(robot.table, Q, drives, H)
    return H[0] if single else H


def forward_dynamics(robot: Robot, q, qd, tau, *, method: str = "aba", gravity=None,
                     f_ext=None, drives: bool = True, use_generated: bool = True) -> np.ndarray:
    """Joint accelerations under given joint torques (paper 4.2).

    Args:
        robot: the manipulator.
        q, qd: joint positions (rad or m) and velocities (rad/s or m/s), (n,) or (N, n).
        tau: joint torques, N·m or N, same shape.
        method: "aba", the O(n) articulated-body ("pursuit") method, or "crba",
            the mass matrix with Cholesky, O(n³).
        gravity, f_ext, drives, use_generated: as in :func:`inverse_dynamics`; the
            customized kernels solve with the generated mass matrix and Cholesky
            whatever ``method`` says (the same accelerations).

    Returns:
        q̈, rad/s² or m/s², shape like q.

    Example:
        >>> import numpy as np, manipcad
        >>> puma = manipcad.load_robot("puma560")
        >>> qdd = manipcad.forward_dynamics(puma, np.zeros(6), np.zeros(6), np.zeros(6))
    """
    gen = _generated(robot, use_generated, "forward_dynamics")
    if gen is not None and gravity is None and f_ext is None and method in ("aba", "crba"):
        return gen.forward_dynamics(q, qd, tau, drives)
    if (gravity is None and f_ext is None and type(q) is np.ndarray and q.ndim == 1
            and (method == "aba" or method == "crba")):
        qdd = np.empty(q.shape[0])
        try:
            bad = (_vectors.get(method) or vector_kernel(_vectors, method))(
                robot.table, robot.gravity, q, qd, tau, drives, qdd, NO_FEXT, False)
        except (TypeError, ValueError):
            pass  # not float64 vectors of length n: the checked path converts or explains
        else:
            if bad is not None and bad >= 0:
                raise not_positive_definite(bad)
            return qdd
    (Q, QD, T), single = as_states(robot.n, q=q, qd=qd, tau=tau)
    F, use_f = as_fext(robot.n, Q.shape[0], single, f_ext)
    g = as_gravity(robot, gravity)
    qdd = np.empty(Q.shape)
    if method not in ("aba", "crba"):
        raise ManipcadError(f"method must be 'aba' or 'crba', got {method!r}")
    run = _run_aba if method == "aba" else _run_crba_fd
    bad = run(robot.table, g, Q, QD, T, F, use_f, drives, qdd)
    if bad >= 0:  # both methods find a joint that moves no mass the same way
        raise not_positive_definite(bad)
    return qdd[0] if single else qdd
