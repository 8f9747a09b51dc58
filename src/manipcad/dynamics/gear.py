"""Gear losses: the efficiency η of a gear, motoring and braking, written once.

The sizing (:mod:`manipcad.sizing.motor`), the simulated plant
(:mod:`manipcad.sim.events`), the regulators that model the gear, and the payload
identification (:mod:`manipcad.dynamics.identification`) all call :func:`gear_factor`.
It lives in ``dynamics/`` beside the other drive terms referred to the joint (rotor
inertia J·i_r², viscous and dry friction, :mod:`manipcad.dynamics.rnea`), so that every
layer that needs the law, the identification included, imports it from here. With the load torque
P (N·m, or N for a prismatic joint: the torque the gear's output passes to the
joint) and the joint speed q̇, the motor side has to supply

    P·f / i_r,   f = 1/η while the motor drives or holds the load (P·q̇ >= 0),
                 f = η   while the load drives the motor back (P·q̇ < 0),

so the loss (1/η − 1)·P·q̇ or (1 − η)·|P·q̇| is always taken from the motion:
a load-dependent Coulomb friction. Read the other way, the simulator's gear
passes P = g·T to the joint, g = 1/f, of the joint-referred torque T that
reaches the gear's input (the motor torque less the rotor's inertia and the
motor's own friction).

At rest the same law gives a band of loads the gear holds without moving
(:func:`holding_band`): with η < 1 a gear holds some load back by its own
losses, as a stuck dry friction does.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def gear_factor(eta: float, load: float, speed: float) -> float:
    """The factor f on the load torque: 1/η while the motor drives or holds the load
    (``load·speed >= 0``), η while the load drives it back.

    Args:
        eta: gear efficiency η in (0, 1], -.
        load: the load torque the gear passes P, N·m (N), or anything of its sign.
        speed: the joint speed q̇, rad/s (m/s), or anything of its sign.

    Returns:
        f, -.

    Example:
        >>> from manipcad.dynamics.gear import gear_factor
        >>> gear_factor(0.8, 10.0, 1.0), gear_factor(0.8, 10.0, -1.0)
        (1.25, 0.8)
    """
    if load * speed >= 0.0:
        return 1.0 / eta
    return eta


@numba.njit(cache=True)
def gear_factors(eta: np.ndarray, load: np.ndarray, speed: np.ndarray,
                 out: np.ndarray) -> None:
    """:func:`gear_factor` of each element of three 1-D arrays of one length into ``out``.

    Example:
        >>> import numpy as np
        >>> from manipcad.dynamics.gear import gear_factors
        >>> out = np.empty(2)
        >>> gear_factors(np.array([0.5, 0.5]), np.array([1.0, 1.0]), np.array([0.0, -2.0]), out)
        >>> out.tolist()
        [2.0, 0.5]
    """
    for k in range(out.shape[0]):
        out[k] = gear_factor(eta[k], load[k], speed[k])


def gear_factor_array(eta, load, speed) -> np.ndarray:
    """:func:`gear_factor` of arrays of any shapes that broadcast against each other.

    Args:
        eta: gear efficiencies η in (0, 1], -.
        load: load torques P, N·m (N), or anything of their sign.
        speed: joint speeds q̇, rad/s (m/s), or anything of their sign.

    Returns:
        f of each element, the broadcast shape, -.

    Example:
        >>> import numpy as np
        >>> from manipcad.dynamics.gear import gear_factor_array
        >>> gear_factor_array(0.5, np.array([[1.0], [-1.0]]), np.array([1.0, -1.0])).tolist()
        [[2.0, 0.5], [0.5, 2.0]]
    """
    eta, load, speed = (np.ascontiguousarray(a, dtype=float) for a in np.broadcast_arrays(
        np.asarray(eta, dtype=float), np.asarray(load, dtype=float),
        np.asarray(speed, dtype=float)))
    out = np.empty(load.shape)
    gear_factors(eta.reshape(-1), load.reshape(-1), speed.reshape(-1), out.reshape(-1))
    return out


@numba.njit(cache=True)
def holding_band(eta: float, torque: float, f_pos: float, f_neg: float) -> tuple[float, float]:
    """The loads a drive holds at rest: (lowest, highest) torque P its gear can pass
    to a joint standing still, N·m (N).

    The joint-referred torque at the gear's input is T = torque − f with the motor's
    static friction f anywhere in [−f_neg, f_pos]; the gear passes g·T with g
    anywhere between η and 1/η (the loss opposes whichever way the joint would move),
    so the band is [min g·T, max g·T] over both ranges.

    Args:
        eta: gear efficiency η in (0, 1], -.
        torque: the motor torque referred to the joint, i_r·k_m·i, N·m (N).
        f_pos, f_neg: the static dry friction referred to the joint against positive
            and negative motion, >= 0, N·m (N).

    Returns:
        (lowest, highest), N·m (N).

    Example:
        >>> from manipcad.dynamics.gear import holding_band
        >>> holding_band(1.0, 5.0, 1.0, 2.0)
        (4.0, 7.0)
        >>> holding_band(0.5, 5.0, 1.0, 2.0)
        (2.0, 14.0)
    """
    lo = torque - f_pos
    hi = torque + f_neg
    return (lo * eta if lo > 0.0 else lo / eta), (hi / eta if hi > 0.0 else hi * eta)
