"""A sampled regulator: plain data.

A :class:`Regulator` is which method (a name in the registry), which joints, its
period, its packed parameter vector and what its design was. It declares the signals
it reads (``needs``); the simulator runs it through the registry's compiled dispatch
and knows no method by name (:mod:`manipcad.control.registry`). What is done with a
regulator is a function of the module that owns it: its file
(:func:`~manipcad.control.files.save_regulators`), its realization complexity
(:func:`~manipcad.control.complexity.realization_complexity`), its python-control
system (:func:`~manipcad.control.export.to_control`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from html import escape

import numpy as np

from manipcad.control.signals import NPARAM, NSTATE


@dataclass
class Regulator:
    """A sampled regulator of one joint (or, for a spanning method, of several).

    Attributes:
        method: the registry name of its method ("pid", "ace_de", ...).
        joints: the joint indices it controls (one, unless the method spans joints).
        period: sampling period, s (zero-order hold between samples).
        params: the packed parameter vector (length ``NPARAM``), layout set by the method.
        needs: the signals it reads (names of :data:`manipcad.control.signals.SIGNALS`).
        law: the control law with its numbers.
        spec: the spec it was designed for.
        options: the synthesis options given (period, load range, realization ...).
        design: design numbers (load range, gains, poles ...), JSON-safe where saved.
        linear: linear parts as python-control objects (not saved).
        joint_names: names of ``joints``; robot: the robot's name; robot_hash: the
            content hash of the robot model it was designed for ("" if not known).

    Example:
        >>> from manipcad.control import pid
        >>> reg = pid("q1", kp=200.0, kd=5.0, period=1e-3)
        >>> reg.method, reg.needs
        ('pid', ('q', 'q_dot', 'q_ref', 'q_dot_ref'))
    """

    method: str
    joints: tuple
    period: float
    params: np.ndarray = field(default_factory=lambda: np.zeros(NPARAM))
    needs: tuple[str, ...] = ()
    law: str = ""
    spec: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    design: dict = field(default_factory=dict)
    linear: dict = field(default_factory=dict)
    joint_names: tuple[str, ...] = ()
    robot: str = ""
    robot_hash: str = ""

    @property
    def joint(self):
        """The (first) joint, index or name."""
        return self.joints[0]

    def describe(self) -> str:
        """The law with its numbers filled in."""
        return self.law or f"{self.method}: period {self.period:g} s"

    def initial_state(self) -> np.ndarray:
        """The regulator's state at t = 0 (length ``NSTATE``)."""
        return np.zeros(NSTATE)

    def _repr_html_(self) -> str:
        """The regulator in a notebook: method, joints, period, law."""
        names = ", ".join(self.joint_names) or ", ".join(str(j) for j in self.joints)
        return (f"<p><b>{escape(self.method)}</b> on {escape(names)}, period "
                f"{self.period:g} s</p><p>{escape(self.describe())}</p>"
                f"<p>signals read: {escape(', '.join(self.needs))}</p>")

    def __repr__(self) -> str:
        names = ", ".join(self.joint_names) or ", ".join(str(j) for j in self.joints)
        return f"Regulator({self.method!r}, joints=[{names}], period={self.period:g} s)"


def u_limit(drive) -> float:
    """The voltage bound of every method's output: the amplifier's input limit, V (inf: none).

    min(u_max, rated_voltage)/k_u: the amplifier's output limit u_max, and not above the
    motor's rated voltage where the data give one (a motor on a larger amplifier).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> u_limit(Drive(u_max=48.0, rated_voltage=24.0, k_u=2.0))
        12.0
    """
    u = float(drive.u_max)
    if math.isfinite(float(drive.rated_voltage)) and drive.rated_voltage > 0:
        u = min(u, float(drive.rated_voltage))
    return u / drive.k_u if math.isfinite(u) else math.inf


def current_limit(drive) -> float:
    """The largest armature current a synthesis may plan for, A (inf: unknown).

    The motor's peak current (peak_torque/k_m), and not above 10× its rated current;
    where neither rating is known, the stall current of the voltage bound,
    k_u·u_limit/R (what the amplifier can drive through the winding at rest).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> am8122 = Drive(R=1.5, k_m=0.1633, k_w=0.1633, u_max=48.0, peak_torque=4.06,
        ...                rated_current=4.9)
        >>> round(current_limit(am8122), 1)
        24.9
    """
    rated = float(drive.rated_current)
    lim = [drive.peak_current, 10.0 * rated if rated > 0 else math.nan]
    lim = [v for v in lim if math.isfinite(v) and v > 0]
    if lim:
        return min(lim)
    stall = stall_current(drive)
    return stall if math.isfinite(stall) else math.inf


def stall_current(drive) -> float:
    """The current the voltage bound drives through the winding at rest, k_u·u_limit/R, A
    (nan without a resistance, inf without a voltage bound).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> round(stall_current(Drive(R=1.5, k_u=1.0, u_max=48.0)), 1)
        32.0
    """
    return drive.k_u * u_limit(drive) / drive.R if drive.R > 0 else math.nan
