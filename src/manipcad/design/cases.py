"""The operating cases a design is verified in: payloads × parameter uncertainty × trajectories.

Payloads: the gripped mass m_g at the tool point (the robot's tool frame origin, on the
last link), added to whatever the robot file carries: both ends and the middle of the
range (one value when the range is a point). The middle one is the *nominal* arm the
regulators are synthesized for.

Uncertainty: each sample is a set of factors 1 + x·σ on the link and drive parameters,
x the relative uncertainty and σ in [-1, 1] per parameter and joint:

- ``mass``: each link's mass and inertia tensor (one factor per link);
- ``k_m``: the motor's torque constant and back-EMF constant (one constant in SI units);
- ``R``: the armature resistance;
- ``J``: the rotor (and gear) inertia;
- ``friction``: the viscous and dry friction of the drive.

Sample 0 is the nominal arm (σ = 0). Samples 1..4 are the corners that matter for a
tracking loop: 1 the *heavy, weak* plant (links, rotor, friction and resistance up, torque
constant down: the slowest drive), 2 its opposite (the fastest), 3 every parameter up,
4 every parameter down. Samples from 5 on draw σ uniformly in [-1, 1]
(``numpy.random.default_rng([seed, sample])``: sample k is the same whatever else runs).
The regulators keep their nominal design; the adaptive methods' signals (H_ii, h_i, Q_i)
are the simulated arm's.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from manipcad.errors import InputError
from manipcad.model.payload import apply_payload
from manipcad.model.robot import Robot

#: the parameter groups perturbed, in the order of :func:`signs`
GROUPS = ("mass", "k_m", "R", "J", "friction")
#: the heavy, weak plant: the direction of each group that slows the drive down
HEAVY = {"mass": 1.0, "k_m": -1.0, "R": 1.0, "J": 1.0, "friction": 1.0}
#: what each deterministic sample is
SAMPLE_NAMES = {0: "nominal", 1: "heavy, weak drive", 2: "light, strong drive",
                3: "all parameters +x", 4: "all parameters -x"}


def payload_points(lo: float, hi: float) -> list[float]:
    """Both ends and the middle of the payload range, kg (one value for a point range).

    Example:
        >>> payload_points(0.0, 2.0), payload_points(1.0, 1.0)
        ([0.0, 1.0, 2.0], [1.0])
    """
    for name, v in (("low", lo), ("high", hi)):
        if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
            raise InputError("--payload-range", name, f"must be a mass >= 0 kg, got {v!r}")
    if hi < lo:
        raise InputError("--payload-range", "", f"the high end {hi:g} kg is below the low "
                         f"end {lo:g} kg")
    if hi == lo:
        return [float(lo)]
    return [float(lo), 0.5 * (float(lo) + float(hi)), float(hi)]


def nominal_payload(lo: float, hi: float) -> float:
    """The payload the regulators are designed for: the middle of the range, kg."""
    return 0.5 * (float(lo) + float(hi))


def with_payload(robot: Robot, mass: float) -> Robot:
    """The robot gripping ``mass`` kg (a point mass) at its tool point on the last link.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> round(float(with_payload(arm, 2.0).mass[-1] - arm.mass[-1]), 9)
        2.0
    """
    return robot if mass <= 0 else apply_payload(robot, float(mass))[0]


def signs(robot: Robot, sample: int, seed: int = 0) -> dict[str, np.ndarray]:
    """σ of each parameter group per joint for one sample (see the module docstring).

    Returns:
        {group: (n,) array in [-1, 1]}.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> s = signs(arm, 1)
        >>> s["mass"].tolist(), s["k_m"].tolist()
        ([1.0, 1.0, 1.0], [-1.0, -1.0, -1.0])
    """
    n = robot.n
    if sample < 0:
        raise InputError("sample", "", f"must be >= 0, got {sample}")
    if sample == 0:
        return {g: np.zeros(n) for g in GROUPS}
    if sample in (1, 2):
        d = 1.0 if sample == 1 else -1.0
        return {g: np.full(n, d * HEAVY[g]) for g in GROUPS}
    if sample in (3, 4):
        return {g: np.full(n, 1.0 if sample == 3 else -1.0) for g in GROUPS}
    rng = np.random.default_rng([int(seed), int(sample)])
    u = rng.uniform(-1.0, 1.0, size=(len(GROUPS), n))
    return {g: u[k] for k, g in enumerate(GROUPS)}


def perturbed(robot: Robot, uncertainty: float, sample: int, seed: int = 0
              ) -> tuple[Robot, dict[str, Any]]:
    """The robot with its parameters off by ``uncertainty``·σ (see the module docstring).

    Args:
        robot: the nominal robot (drives, payload and counterweights included).
        uncertainty: x, the largest relative error, in [0, 1).
        sample: which sample (0 nominal, 1..4 corners, >= 5 random).
        seed: the random stream of the random samples.

    Returns:
        (robot, {group: [factor per joint]}).

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> heavy, f = perturbed(arm, 0.1, 1)
        >>> f["mass"][0], round(float(heavy.drives[0].k_m / arm.drives[0].k_m), 12)
        (1.1, 0.9)
    """
    if not (isinstance(uncertainty, int | float) and math.isfinite(uncertainty)
            and 0 <= uncertainty < 1):
        raise InputError("--uncertainty", "", f"must be a fraction in [0, 1) (a percentage "
                         f"in [0, 100) on the command line), got {uncertainty!r}")
    s = signs(robot, sample, seed)
    f = {g: 1.0 + float(uncertainty) * s[g] for g in GROUPS}
    drives = []
    for j, d in enumerate(robot.drives):
        if d is None:
            drives.append(None)
            continue
        drives.append(d.replace(k_m=d.k_m * f["k_m"][j], k_w=d.k_w * f["k_m"][j],
                                R=d.R * f["R"][j], J=d.J * f["J"][j],
                                k_v=d.k_v * f["friction"][j],
                                M_f=tuple(m * f["friction"][j] for m in d.M_f),
                                M_s=None if d.M_s is None
                                else tuple(m * f["friction"][j] for m in d.M_s)))
    new = robot.replace(mass=np.asarray(robot.mass, dtype=float) * f["mass"],
                        inertia=np.asarray(robot.inertia, dtype=float)
                        * f["mass"][:, None, None],
                        drives=tuple(drives))
    return new, {g: [float(v) for v in f[g]] for g in GROUPS}


def sample_name(sample: int) -> str:
    """A short description of an uncertainty sample.

    Example:
        >>> sample_name(1), sample_name(7)
        ('heavy, weak drive', 'random 7')
    """
    return SAMPLE_NAMES.get(sample, f"random {sample}")


__all__ = ["GROUPS", "HEAVY", "payload_points", "nominal_payload", "with_payload", "signs",
           "perturbed", "sample_name"]
