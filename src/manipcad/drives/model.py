"""A standalone single-drive model: one DC servo drive driving a frozen load.

:class:`DriveModel` is the drive of one joint with the rest of the robot
replaced by a load of inertia ``H_ii``, velocity coefficient ``h_i`` and a
constant torque ``τ_l`` (all joint side). It integrates the nonlinear
equations (amplifier limit, dry friction, backlash) with a compiled RK4 and
linearizes them for the synthesis methods.

State order:

- rigid gear, order 3: ``(q, q̇, i)``; order 2: ``(q, q̇)``
- elastic gear, order 3: ``(q, q̇, θ_m, ω_m, i)``; order 2: ``(q, q̇, θ_m, ω_m)``

(rad, rad/s, rad, rad/s, A).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numba
import numpy as np

from manipcad.drives.dc import rigid_current, rigid_current_for, rigid_rhs, static_current
from manipcad.drives.linear import DriveLinearization, linearize
from manipcad.drives.params import (
    KIND_ELASTIC,
    KIND_ELASTIC_STATIC,
    KIND_RIGID,
    P_GAP,
    P_KIND,
    P_KS,
    P_RATIO,
    Transmission,
    as_transmission,
    pack_drive,
)
from manipcad.drives.transmission import elastic_rhs
from manipcad.errors import ModelError
from manipcad.model.robot import Drive
from manipcad.rk4 import rk4_stage, rk4_update


@numba.njit(cache=True)
def standalone_rhs(x: np.ndarray, U: float, H_ii: float, h_i: float, tau_load: float,
                   p: np.ndarray, dx: np.ndarray) -> None:
    """Right-hand side of one drive with its load, any kind (dispatch on p).

    Args:
        x: state (see the module docstring for the order).
        U: amplifier input, V.
        H_ii: joint-side load inertia, kg·m².
        h_i: joint-side velocity coefficient, N·m·s/rad.
        tau_load: joint-side load torque, N·m.
        p: packed drive parameters.
        dx: output, shape of x.
    """
    kind = int(p[P_KIND])
    if kind == KIND_ELASTIC or kind == KIND_ELASTIC_STATIC:
        elastic_rhs(x, U, H_ii, h_i, tau_load, p, dx)
    else:
        rigid_rhs(x, U, H_ii, h_i, tau_load, p, dx)


@numba.njit(cache=True)
def rk4_drive(x0: np.ndarray, u: np.ndarray, dt: float, H_ii: float, h_i: float,
              tau_load: float, p: np.ndarray) -> np.ndarray:
    """Fixed-step RK4 (:mod:`manipcad.rk4`) of one drive; U held constant over each step.

    Args:
        x0: initial state.
        u: (N,) amplifier input per step, V.
        dt: step, s.
        H_ii, h_i, tau_load: frozen joint-side load (kg·m², N·m·s/rad, N·m).
        p: packed drive parameters.

    Returns:
        (N + 1, nx) states at t = 0, dt, ..., N·dt.
    """
    n = u.shape[0]
    nx = x0.shape[0]
    X = np.empty((n + 1, nx))
    X[0] = x0
    K = np.empty((4, nx))
    xs = np.empty(nx)
    for s in range(n):
        x = X[s]
        U = u[s]
        for st in range(4):
            rk4_stage(x, K, st, dt, xs)
            standalone_rhs(xs, U, H_ii, h_i, tau_load, p, K[st])
        rk4_update(x, K, dt, X[s + 1])
    return X


@dataclass(frozen=True)
class DriveResponse:
    """A simulated drive response.

    Attributes:
        t: (N+1,) time, s.
        x: (N+1, nx) states.
        u: (N+1,) amplifier input, V (the last value repeated at the end).
        states: state names.
        current: (N+1,) armature current, A.
    """

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    states: tuple[str, ...]
    current: np.ndarray

    @property
    def q(self) -> np.ndarray:
        """Joint angle, rad."""
        return self.x[:, 0]

    @property
    def qd(self) -> np.ndarray:
        """Joint velocity, rad/s."""
        return self.x[:, 1]


@dataclass(frozen=True)
class DriveModel:
    """One DC servo drive with a frozen load (paper 3.1), nonlinear and linearized.

    Attributes:
        drive: the drive (motor, amplifier, gear).
        H_ii: joint-side load inertia, kg·m² (kg for a prismatic joint).
        h_i: joint-side velocity coefficient, N·m·s/rad.
        tau_load: constant joint-side load torque, N·m.
        transmission: elastic/backlash transmission, or None for a rigid gear.
        order: 3 (armature inductance kept) or 2 (neglected).
        friction_eps: dry-friction linear zone on the motor speed, rad/s.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.model import DriveModel
        >>> d = Drive(J=2e-4, ratio=62.6, k_v=1.5e-3, R=2.1, L=1e-3, k_m=.228, k_w=.228, k_u=10)
        >>> m = DriveModel(d, H_ii=2.0)
        >>> r = m.simulate(0.4, 1e-5, U=1.0)
        >>> r.x.shape, round(float(r.qd[-1]), 4)        # steady speed k_u·k_p/i_r
        ((40001, 3), 0.6606)
    """

    drive: Drive
    H_ii: float = 0.0
    h_i: float = 0.0
    tau_load: float = 0.0
    transmission: Transmission | None = None
    order: int = 3
    friction_eps: float = 0.0
    p: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        tr = as_transmission(self.transmission)
        object.__setattr__(self, "transmission", tr)
        for name in ("H_ii", "h_i", "tau_load"):
            v = float(getattr(self, name))
            if not math.isfinite(v):
                raise ModelError(f"DriveModel {name} must be finite, got {v}")
            object.__setattr__(self, name, v)
        if self.H_ii < 0:
            raise ModelError(f"DriveModel H_ii must be >= 0, got {self.H_ii}")
        p = pack_drive(self.drive, tr, order=self.order, friction_eps=self.friction_eps)
        if tr is not None and (self.H_ii <= 0 or self.drive.J <= 0):
            raise ModelError("an elastic transmission needs H_ii > 0 and J > 0")
        if tr is None and self.H_ii + self.drive.reflected_inertia <= 0:
            raise ModelError("H_ii + J·i_r² must be > 0")
        p.setflags(write=False)
        object.__setattr__(self, "p", p)

    # ------------------------------------------------------------ states
    @property
    def kind(self) -> int:
        """The packed drive kind (KIND_* of :mod:`manipcad.drives.params`)."""
        return int(self.p[P_KIND])

    @property
    def states(self) -> tuple[str, ...]:
        """State names in order."""
        mech = ("q", "qd") if self.transmission is None else ("q", "qd", "theta_m", "omega_m")
        return mech + (("i",) if self.kind in (KIND_RIGID, KIND_ELASTIC) else ())

    def rest_state(self, q0: float = 0.0) -> np.ndarray:
        """The state at rest at q = q0 with the load torque held by the motor.

        Current ``τ_l/(i_r·k_m)`` (order 3; :func:`~manipcad.drives.dc.rigid_current_for`);
        for an elastic gear the spring is pre-loaded to carry τ_l
        (``θ_m = i_r·(q0 + δ0)``). At rest the dry friction is not needed to hold the load.

        Args:
            q0: joint angle, rad.

        Returns:
            State vector.
        """
        d = self.drive
        i0 = rigid_current_for(self.tau_load, self.p)
        x = [q0, 0.0]
        if self.transmission is not None:
            ks, b = self.p[P_KS], self.p[P_GAP]
            delta = self.tau_load / ks
            delta += math.copysign(b, delta) if delta != 0 else 0.0
            x += [d.ratio * (q0 + delta), 0.0]
        if self.kind in (KIND_RIGID, KIND_ELASTIC):
            x.append(i0)
        return np.array(x, dtype=float)

    def rhs(self, x: np.ndarray, U: float) -> np.ndarray:
        """dx/dt at state x and amplifier input U (V)."""
        x = np.asarray(x, dtype=float)
        dx = np.empty_like(x)
        standalone_rhs(x, float(U), self.H_ii, self.h_i, self.tau_load, self.p, dx)
        return dx

    def current(self, x: np.ndarray, U: float | np.ndarray) -> np.ndarray:
        """Armature current, A: shape (N,) for states x of shape (N, nx), (1,) for one state.

        Args:
            x: states (N, nx) or (nx,).
            U: amplifier input(s), V (the current is algebraic at order 2).
        """
        X = np.atleast_2d(np.asarray(x, dtype=float))
        Us = np.broadcast_to(np.asarray(U, dtype=float), (X.shape[0],))
        if self.transmission is None:
            out = np.array([rigid_current(X[k], Us[k], self.p) for k in range(X.shape[0])])
        elif self.kind == KIND_ELASTIC:
            out = X[:, 4].copy()
        else:
            out = np.array([static_current(Us[k], X[k, 3], self.p) for k in range(X.shape[0])])
        return out if np.ndim(x) == 2 else out[:1]

    # ------------------------------------------------------------ simulate
    def simulate(self, t_end: float, dt: float,
                 U: float | np.ndarray | Callable[[np.ndarray], np.ndarray] = 1.0,
                 x0: np.ndarray | None = None) -> DriveResponse:
        """Integrate the nonlinear drive with fixed-step RK4.

        Args:
            t_end: duration, s.
            dt: step, s (keep it well below T_e and 1/ω_s of an elastic gear).
            U: amplifier input, V: a constant, an array of one value per step
                (held over the step) or a function of the step start times.
            x0: initial state (default :meth:`rest_state`).

        Returns:
            :class:`DriveResponse`.
        """
        if not (dt > 0 and t_end > 0 and math.isfinite(t_end)):
            raise ModelError(f"need t_end > 0 and dt > 0, got t_end={t_end}, dt={dt}")
        n = int(round(t_end / dt))
        t = np.arange(n + 1) * dt
        if callable(U):
            u = np.asarray(U(t[:-1]), dtype=float).reshape(n)
        else:
            u = np.broadcast_to(np.asarray(U, dtype=float), (n,)).astype(float)
        x0 = self.rest_state() if x0 is None else np.asarray(x0, dtype=float)
        if x0.shape != (len(self.states),):
            raise ModelError(f"x0 must have {len(self.states)} entries {self.states}")
        X = rk4_drive(x0, np.ascontiguousarray(u), float(dt), self.H_ii, self.h_i,
                      self.tau_load, np.asarray(self.p))
        uu = np.append(u, u[-1] if n else 0.0)
        return DriveResponse(t=t, x=X, u=uu, states=self.states, current=self.current(X, uu))

    # ------------------------------------------------------------ linear
    def linearize(self, order: int | None = None) -> DriveLinearization:
        """Linear model U → q at this load (:func:`manipcad.drives.linear.linearize`).

        Args:
            order: 3 or 2 (default: the model's order).
        """
        return linearize(self.drive, self.H_ii, self.h_i, order=order or self.order,
                         elasticity=self.transmission)

    @property
    def ratio(self) -> float:
        """Gear ratio i_r."""
        return float(self.p[P_RATIO])
