"""Gripper paths in Cartesian space, followed through the numerical inverse kinematics.

A path x(t) of the tool frame origin (m, base frame) with its analytic
derivatives ẋ (m/s) and ẍ (m/s²) is turned into joint motion as follows.

1. The first point is reached from the guess ``q0`` by
   :func:`manipcad.kinematics.inverse_kinematics` (with ``orientation="fixed"``
   the tool keeps the orientation it has at ``q0`` all along the path).
2. Joint positions follow the resolved-rate equation q̇ = J⁺(q)·ẋ(t) (J the
   task rows of the geometric Jacobian, J⁺ its pseudo-inverse), integrated
   once with SciPy's DOP853 at tight tolerances (rtol 1e-10) and kept as a
   dense output. For a robot with as many joints as task coordinates this is
   the unique continuous IK branch; for a redundant one it picks the
   minimum-norm joint rates.
3. At every sample the dense output is projected exactly onto the path by
   Newton iterations with J⁺, so the tool is on the path to about 1e-12 m, and
   the rates are exact functions of that q (no finite differences):

       qd  = J⁺ ẋ
       qdd = J⁺ (ẍ - J̇ qd) + (I - J⁺J) J̇ᵀ (J Jᵀ)⁻¹ ẋ,

   the exact time derivative of J⁺ẋ (the second term vanishes unless the
   robot is redundant), with J̇ from :func:`manipcad.kinematics.jacobian_dot`.

The task has 3 coordinates (position, ``orientation="free"``) or 6 (position
and a fixed orientation, ``orientation="fixed"``). A path that meets a
singularity or leaves the joint limits raises
:class:`manipcad.kinematics.KinematicsError` when the trajectory is built.

The timing along the path is a normalised profile s(τ), τ = t/T, from 0 to 1:
"quintic" (zero end velocities and accelerations), "cubic" (zero end
velocities) or "linear" (constant speed; the speed jumps at both ends).
"""

from __future__ import annotations

import warnings
from abc import abstractmethod
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.errors import InputError, require_choice
from manipcad.kinematics.forward import frames, resolve_point
from manipcad.kinematics.inverse import KinematicsError, inverse_kinematics
from manipcad.kinematics.jacobian import _jacobian_from_frames, jacobian_dot
from manipcad.kinematics.rotations import rotation_vector
from manipcad.model.load import catalog_names, load_robot
from manipcad.model.robot import Robot
from manipcad.trajectories.base import Trajectory, floats, positive, vector
from manipcad.trajectories.quintic import quintic_profile

PROFILES = ("quintic", "cubic", "linear")
ORIENTATIONS = ("free", "fixed")

_RTOL, _ATOL = 1e-10, 1e-12  # resolved-rate integration tolerances (rad or m)
_PROJ_TOL = 1e-12  # Newton projection target, m (and rad)
_PROJ_ACCEPT = 1e-9  # the largest residual accepted, m (and rad)
_SINGULAR = 1e-8  # smallest allowed singular value ratio of the task Jacobian
#: work budget of following a path: evaluations of the resolved rates (a few ms each); a
#: path that needs more (a circle of hundreds of turns) is refused instead of taking
#: minutes or hours (one full turn of a circle takes about 800)
MAX_RATE_EVALUATIONS = 20_000


class _OverBudget(Exception):
    """Ends the resolved-rate integration of a path over :data:`MAX_RATE_EVALUATIONS`."""


def path_profile(kind: str, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Normalised timing s(τ) with ds/dτ and d²s/dτ² for τ in [0, 1].

    Args:
        kind: "quintic", "cubic" or "linear".
        tau: normalised times t / T.

    Example:
        >>> import numpy as np
        >>> [float(v[0]) for v in path_profile("cubic", np.array([0.5]))]
        [0.5, 1.5, 0.0]
    """
    tau = np.asarray(tau, dtype=float)
    if kind == "quintic":
        return quintic_profile(tau)
    if kind == "cubic":
        return tau * tau * (3.0 - 2.0 * tau), 6.0 * tau * (1.0 - tau), 6.0 - 12.0 * tau
    return tau.copy(), np.ones_like(tau), np.zeros_like(tau)


def _robot_and_ref(robot: Robot | str | Path) -> tuple[Robot, str | None]:
    """The robot and the name a file should use for it (None: find it when saving)."""

    if isinstance(robot, Robot):
        return robot, None
    return load_robot(robot), str(robot)


def _same_kinematics(a: Robot, b: Robot) -> bool:
    return (a.joint_types == b.joint_types and np.array_equal(a.parent, b.parent)
            and all(np.allclose(getattr(a, f), getattr(b, f), rtol=0, atol=1e-12) for f in
                    ("placement_R", "placement_p", "offset", "tool_R", "tool_p")))


def catalog_name_of(robot: Robot) -> str:
    """The catalog name of a robot with the same name and kinematics, else ``robot.name``.

    Example:
        >>> import manipcad
        >>> catalog_name_of(manipcad.load_robot("puma560"))
        'puma560'
    """

    try:
        names = catalog_names()
    except OSError:
        return robot.name
    for name in names:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                entry = load_robot(name)
        except Exception:  # noqa: BLE001 - a broken catalog entry is simply not a match
            continue
        if entry.name == robot.name and _same_kinematics(entry, robot):
            return name
    return robot.name


class CartesianTrajectory(Trajectory):
    """A tool path x(t) followed through inverse kinematics (see the module docstring).

    Subclasses define :meth:`path`. Build one with :func:`line` or :func:`circle`.

    Attributes:
        robot: the robot.
        robot_ref: how the YAML file names the robot: the name or path it was
            given by, or for a :class:`Robot` object the catalog name of the
            same robot (else its ``name``, which loading then needs ``robot=`` for).
        q0: (n,) the IK guess for the first point, rad or m.
        q_start: (n,) the joint position at t = 0 (on the path), rad or m.
        profile: the timing profile name.
        orientation: "free" or "fixed".

    Example:
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> traj = line(robot, [0.5, 0.0, 1.2], [0.5, -0.3, 1.2], 1.0, q0=[0, 0.8, -1.2, 0, 0.5, 0])
        >>> q, qd, qdd = traj.sample([0.0, 0.5, 1.0])
        >>> q.shape
        (3, 6)
    """

    #: the Newton projection iterates over all the rows sampled together until the worst
    #: is on the path, so a row's last bits depend on the batch
    rows_independent = False

    def __init__(self, robot: Robot | str | Path, duration: float, q0: Sequence[float],
                 profile: str, orientation: str, source: str) -> None:
        self.robot, self._robot_ref = _robot_and_ref(robot)
        n = self.robot.n
        self._duration = positive(duration, "duration", source)
        self.q0 = vector(q0, "q0", source, n)
        require_choice(source, "profile", profile, PROFILES)
        require_choice(source, "orientation", orientation, ORIENTATIONS)
        self.profile, self.orientation = profile, orientation
        self._m = 3 if orientation == "free" else 6
        if n < self._m:
            raise InputError(source, "robot", f"{self.robot.name!r} has {n} joints; a path "
                             f"with {orientation} orientation needs at least {self._m}")
        self._k, self._c = resolve_point(self.robot, -1, None)
        self._tool_R = self.robot.tool_R
        self._source = source

    def _start(self) -> None:
        """Reach the first point from q0, then integrate the resolved rates (called once)."""
        x0 = self.path(np.zeros(1))[0][0]
        R, p = frames(self.robot, self.q0[None, :])
        if self._m == 6:
            self._R_goal = R[0, self._k] @ self._tool_R
            target = np.eye(4)
            target[:3, :3], target[:3, 3] = self._R_goal, x0
        else:
            self._R_goal = None
            target = x0
        self.q_start = inverse_kinematics(self.robot, target, self.q0)
        T = self._duration

        calls = [0]

        def rates(t: float, q: np.ndarray) -> np.ndarray:
            calls[0] += 1
            if calls[0] > MAX_RATE_EVALUATIONS:
                raise _OverBudget(t)
            J = self._task_jacobian(q[None, :])[0]
            xd = self._task_rate(np.array([t]))[0]
            qd, _, _, s = np.linalg.lstsq(J, xd, rcond=None)  # minimum-norm rates
            if s[-1] < _SINGULAR * max(1.0, s[0]):
                raise KinematicsError(
                    f"the {self.kind} path of {self.robot.name!r} meets a singularity at "
                    f"t = {t:.4g} s (q = {np.array2string(q, precision=4)})", q=q.copy())
            return qd

        # deferred: start-up cost: scipy.integrate, 1-3 s of import, rarely needed
        from scipy.integrate import solve_ivp

        try:
            sol = solve_ivp(rates, (0.0, T), self.q_start, method="DOP853", rtol=_RTOL,
                            atol=_ATOL, dense_output=True, max_step=T / 50.0)
        except _OverBudget as exc:
            raise InputError(self._source, "", f"the {self.kind} path of "
                             f"{self.robot.name!r} is too long to follow: more than "
                             f"{MAX_RATE_EVALUATIONS:,} steps of the joint rates by t = "
                             f"{exc.args[0]:.4g} s of {T:g} s (the limit of the work "
                             "spent on one path); shorten it (fewer turns)") from None
        if not sol.success:
            raise KinematicsError(f"the {self.kind} path of {self.robot.name!r} cannot be "
                                  f"followed: {sol.message} (at t = {sol.t[-1]:.4g} s)")
        self._dense = sol.sol
        lo, hi = self.robot.limits[:, 0], self.robot.limits[:, 1]
        grid = np.unique(np.concatenate([sol.t, np.linspace(0.0, T, 401)]))
        Qg = sol.sol(grid).T
        out = (Qg < lo - 1e-9) | (Qg > hi + 1e-9)
        if out.any():
            k, j = np.argwhere(out)[0]
            raise KinematicsError(
                f"the {self.kind} path of {self.robot.name!r} takes joint "
                f"{self.robot.joint_names[j]!r} to {Qg[k, j]:.6g}, outside its limits "
                f"[{lo[j]:g}, {hi[j]:g}], at t = {grid[k]:.4g} s", q=Qg[k].copy())

    @property
    def robot_ref(self) -> str:
        """How a YAML file names the robot (catalog name, file path or robot name)."""
        if self._robot_ref is None:
            self._robot_ref = catalog_name_of(self.robot)
        return self._robot_ref

    # -------------------------------------------------------------- the path
    @abstractmethod
    def path(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tool position x (m), velocity (m/s), acceleration (m/s²), each (len(t), 3),
        for times 0 <= t <= duration (s)."""

    def _timing(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        T = self._duration
        s, sd, sdd = path_profile(self.profile, t / T)
        return s, sd / T, sdd / T**2

    def _task_rate(self, t: np.ndarray) -> np.ndarray:
        _, xd, _ = self.path(t)
        return xd if self._m == 3 else np.concatenate([xd, np.zeros_like(xd)], axis=1)

    def _task_jacobian(self, Q: np.ndarray) -> np.ndarray:
        R, p = frames(self.robot, Q)
        return _jacobian_from_frames(self.robot, R, p, self._k, self._c)[:, :self._m]

    # ----------------------------------------------------------- Trajectory
    @property
    def n(self) -> int:
        """Number of joints."""
        return self.robot.n

    @property
    def duration(self) -> float:
        """Length of the motion along the path, s."""
        return self._duration

    def _evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x, xd, xdd = self.path(t)
        Q = self._project(self._dense(t).T, x, t)
        R, p = frames(self.robot, Q)
        J = _jacobian_from_frames(self.robot, R, p, self._k, self._c)[:, :self._m]
        if self._m == 6:
            xd = np.concatenate([xd, np.zeros_like(xd)], axis=1)
            xdd = np.concatenate([xdd, np.zeros_like(xdd)], axis=1)
        JT = np.swapaxes(J, 1, 2)
        G = np.linalg.inv(J @ JT)  # (J Jᵀ)⁻¹, (N, m, m)
        Jp = JT @ G  # J⁺ for full row rank
        Qd = np.einsum("kij,kj->ki", Jp, xd)
        Jd = jacobian_dot(self.robot, Q, Qd)[:, :self._m]
        bias = np.einsum("kij,kj->ki", Jd, Qd)
        Qdd = np.einsum("kij,kj->ki", Jp, xdd - bias)
        if self.n > self._m:  # redundant: d/dt of J⁺ has a null-space part
            Nul = np.eye(self.n)[None] - Jp @ J
            Qdd += np.einsum("kij,kj->ki", Nul @ np.swapaxes(Jd, 1, 2) @ G, xd)
        return Q, Qd, Qdd

    def _project(self, Q: np.ndarray, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Newton projection of joint positions onto the path points x (m)."""
        Q = Q.copy()
        for _ in range(12):
            R, p = frames(self.robot, Q)
            xt = p[:, self._k] + R[:, self._k] @ self._c
            e = x - xt
            if self._m == 6:
                Rt = R[:, self._k] @ self._tool_R
                e = np.concatenate([e, rotation_vector(self._R_goal @ np.swapaxes(Rt, 1, 2))],
                                   axis=1)
            err = np.max(np.abs(e))
            if err <= _PROJ_TOL:
                return Q
            J = _jacobian_from_frames(self.robot, R, p, self._k, self._c)[:, :self._m]
            JT = np.swapaxes(J, 1, 2)
            Q += np.einsum("kij,kj->ki", JT, np.linalg.solve(J @ JT, e[..., None])[..., 0])
        if err > _PROJ_ACCEPT:
            k = int(np.argmax(np.max(np.abs(e), axis=1)))
            raise KinematicsError(f"the {self.kind} path of {self.robot.name!r}: the inverse "
                                  f"kinematics at t = {t[k]:.4g} s is {err:.3g} off the path",
                                  q=Q[k].copy(), position_error=err)
        return Q

    def _common_dict(self) -> dict[str, Any]:
        return {"duration": float(self._duration), "q0": floats(self.q0),
                "profile": self.profile, "orientation": self.orientation}


class LineTrajectory(CartesianTrajectory):
    """The tool origin moves on a straight segment; build it with :func:`line`.

    Attributes:
        p_start, p_end: (3,) end points in the base frame, m.

    Example:
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> traj = line(robot, [0.5, 0.0, 1.2], [0.5, -0.3, 1.2], 1.0, q0=[0, 0.8, -1.2, 0, 0.5, 0])
        >>> traj.path([0.5])[0]  # the midpoint, m
        array([[ 0.5 , -0.15,  1.2 ]])
    """

    kind = "line"

    def __init__(self, robot: Robot | str | Path, p_start: Sequence[float],
                 p_end: Sequence[float], duration: float, q0: Sequence[float],
                 profile: str = "quintic", orientation: str = "free") -> None:
        super().__init__(robot, duration, q0, profile, orientation, "line")
        self.p_start = vector(p_start, "p_start", "line", 3)
        self.p_end = vector(p_end, "p_end", "line", 3)
        self._start()

    def path(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position (m), velocity (m/s), acceleration (m/s²) on the segment, (len(t), 3) each."""
        s, sd, sdd = self._timing(np.asarray(t, dtype=float))
        D = self.p_end - self.p_start
        return (self.p_start + s[:, None] * D, sd[:, None] * D, sdd[:, None] * D)

    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping: type, robot, p_start, p_end (m), duration (s), q0, profile,
        orientation."""
        return {"type": self.kind, "robot": self.robot_ref, "p_start": floats(self.p_start),
                "p_end": floats(self.p_end)} | self._common_dict()


class CircleTrajectory(CartesianTrajectory):
    """The tool origin moves on a circular arc; build it with :func:`circle`.

    Attributes:
        center: (3,) centre in the base frame, m.
        radius: m.
        normal: (3,) unit normal of the circle's plane; the motion turns about it
            by the right-hand rule.
        start: (3,) unit vector from the centre to the first point.
        angle: the angle travelled, rad (2π for a full circle).

    Example:
        >>> import manipcad
        >>> traj = circle(manipcad.load_robot("puma560"), [0.5, -0.15, 1.2], 0.1, [1, 0, 0],
        ...               2.0, q0=[0, 0.8, -1.2, 0, 0.5, 0])
        >>> traj.path([1.0])[0].round(3)  # half way round, m
        array([[ 0.5 , -0.15,  1.1 ]])
    """

    kind = "circle"

    def __init__(self, robot: Robot | str | Path, center: Sequence[float], radius: float,
                 normal: Sequence[float], duration: float, q0: Sequence[float], *,
                 angle: float = 2.0 * np.pi, start: Sequence[float] | None = None,
                 profile: str = "quintic", orientation: str = "free") -> None:
        src = "circle"
        super().__init__(robot, duration, q0, profile, orientation, src)
        self.center = vector(center, "center", src, 3)
        self.radius = positive(radius, "radius", src)
        nrm = vector(normal, "normal", src, 3)
        if np.linalg.norm(nrm) < 1e-12:
            raise InputError(src, "normal", "must not be the zero vector")
        self.normal = nrm / np.linalg.norm(nrm)
        try:
            self.angle = float(angle)
        except (TypeError, ValueError):
            raise InputError(src, "angle", f"expected a number in rad, got {angle!r}") from None
        if not np.isfinite(self.angle) or self.angle == 0:
            raise InputError(src, "angle", f"must be a finite non-zero angle in rad, got {angle}")
        if start is None:
            R, p = frames(self.robot, self.q0[None, :])
            u = p[0, self._k] + R[0, self._k] @ self._c - self.center
            field = "center"
        else:
            u = vector(start, "start", src, 3)
            field = "start"
        u = u - (u @ self.normal) * self.normal
        if np.linalg.norm(u) < 1e-9:
            if start is not None:
                raise InputError(src, field, "is parallel to the normal")
            # the tool at q0 is on the axis: any direction in the plane
            u = np.cross(self.normal, np.eye(3)[np.argmin(np.abs(self.normal))])
        self.start = u / np.linalg.norm(u)
        self._v = np.cross(self.normal, self.start)
        self._start()

    def path(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position (m), velocity (m/s), acceleration (m/s²) on the arc, (len(t), 3) each."""
        s, sd, sdd = self._timing(np.asarray(t, dtype=float))
        phi, phid, phidd = self.angle * s, self.angle * sd, self.angle * sdd
        c, si = np.cos(phi)[:, None], np.sin(phi)[:, None]
        u, v, r = self.start, self._v, self.radius
        radial = c * u + si * v
        tangent = -si * u + c * v
        x = self.center + r * radial
        xd = r * phid[:, None] * tangent
        xdd = r * phidd[:, None] * tangent - r * (phid**2)[:, None] * radial
        return x, xd, xdd

    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping: type, robot, center (m), radius (m), normal, start, angle (rad),
        duration (s), q0, profile, orientation."""
        return {"type": self.kind, "robot": self.robot_ref, "center": floats(self.center),
                "radius": float(self.radius), "normal": floats(self.normal),
                "start": floats(self.start), "angle": float(self.angle)} | self._common_dict()


def line(robot: Robot | str | Path, p_start: Sequence[float], p_end: Sequence[float],
         duration: float, q0: Sequence[float], profile: str = "quintic", *,
         orientation: str = "free") -> LineTrajectory:
    """A straight-line move of the tool (gripper) origin, through inverse kinematics.

    Args:
        robot: a :class:`Robot`, a catalog name or a robot file path.
        p_start: (3,) first point in the base frame, m.
        p_end: (3,) last point in the base frame, m.
        duration: time of the move, s, > 0.
        q0: (n,) the inverse-kinematics guess for the first point, rad or m; the
            trajectory starts at the solution found from it.
        profile: timing along the segment: "quintic", "cubic" or "linear".
        orientation: "free" (position only) or "fixed" (keep the tool
            orientation it has at q0; needs at least 6 joints).

    Returns:
        A :class:`LineTrajectory`.

    Raises:
        InputError: bad arguments (naming the field).
        KinematicsError: the first point is out of reach, or the segment meets a
            singularity or leaves the joint limits.

    Example:
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> traj = line(robot, [0.5, 0.0, 1.2], [0.5, -0.3, 1.2], 1.0,
        ...             q0=[0, 0.8, -1.2, 0, 0.5, 0])
        >>> traj.n
        6
    """
    return LineTrajectory(robot, p_start, p_end, duration, q0, profile, orientation)


def circle(robot: Robot | str | Path, center: Sequence[float], radius: float,
           normal: Sequence[float], duration: float, q0: Sequence[float], *,
           angle: float = 2.0 * np.pi, start: Sequence[float] | None = None,
           profile: str = "quintic", orientation: str = "free") -> CircleTrajectory:
    """A circular move of the tool (gripper) origin, through inverse kinematics.

    Args:
        center: (3,) circle centre in the base frame, m.
        radius: circle radius, m, > 0.
        normal: (3,) normal of the circle's plane (any length); the tool turns
            about it by the right-hand rule (a negative ``angle`` turns back).
        angle: the angle travelled, rad (default 2π, one full turn).
        start: (3,) direction from the centre to the first point (projected on
            the plane); default the direction of the tool position at q0.
        robot, duration, q0, profile, orientation: as in :func:`line` (``profile``
            times the arc).

    Returns:
        A :class:`CircleTrajectory`.

    Raises:
        InputError, KinematicsError: as :func:`line`, for the arc.

    Example:
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> traj = circle(robot, [0.5, -0.15, 1.2], 0.1, [1, 0, 0], 2.0,
        ...               q0=[0, 0.8, -1.2, 0, 0.5, 0])
        >>> traj.duration
        2.0
    """
    return CircleTrajectory(robot, center, radius, normal, duration, q0, angle=angle,
                            start=start, profile=profile, orientation=orientation)
