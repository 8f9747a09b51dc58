"""A sampled regulator and the description of a synthesis method.

A :class:`Regulator` is data: which method (a name in the registry), which joints,
its period, its packed parameter vector and what its design was. It declares the
signals it reads (``needs``) and gives the amplifier input(s) U of its joints; the
simulator runs it through the registry's compiled dispatch and knows no method by
name (:mod:`manipcad.control.registry`).

A :class:`Method` is one registry entry: the synthesis function, the compiled update,
the file layout of its parameters and its paper section.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from manipcad.control.signals import NPARAM, NSTATE


@dataclass(frozen=True)
class TableLayout:
    """A gain table held in a method's parameter vector (e.g. the LQR-GS table).

    Attributes:
        to_file: ``f(p) -> dict``: the table's regulator-file mapping.
        from_file: ``f(t, p, robot, joint, source, where) -> None``: check a file's
            mapping ``t`` (one InputError naming ``source``, field and reason) and
            write it into ``p``.
        entries: ``f(p) -> range``: the parameter indices the table occupies (stored
            whole, whatever one period reads).
    """

    to_file: Callable
    from_file: Callable
    entries: Callable


@dataclass(frozen=True)
class Method:
    """One synthesis method of the registry.

    Attributes:
        name: the method's name (``manipcad synthesize --method NAME``).
        synthesize: ``f(robot, joint, *, spec=None, **options) -> Regulator`` (or, for a
            method that ``spans`` joints, ``f(robot, joints, ...)`` with a list).
        update: the compiled control-period update. Single-joint methods:
            ``law(p, s, sig, j, Ts) -> U``; spanning methods:
            ``law(p, s, sig, H, joints, nj, Ts, U) -> None`` writing ``U[joints[k]]``.
        section: the paper's section (or "baseline").
        summary: one line for ``--list``.
        fields: file layout of the method's own parameters: key (with its unit) -> index
            in the parameter vector.
        spans: one regulator controls several joints (needs the whole H(q)).
        table: the parameters hold a gain table: its :class:`TableLayout` (the file
            mapping and the parameter entries it occupies), or None.
        export: ``f(reg, robot=None) -> python-control system`` (see :meth:`Regulator.to_control`).
        drive_blocks: packed drives the parameters hold: 1 at index 0 (single-joint
            methods), or ``"per_joint"`` (spanning methods, see the method), or 0.
        joint_fields: per-joint entries of a spanning method: key -> index of its first
            joint (joint k at index + k).
        drive_base: index of the first packed drive (joint k's at drive_base + k·NPAR).
        linear: the law is linear in its signals at a frozen load, so its sampled loop
            can be checked by eigenvalues (:mod:`manipcad.control.sampled`).
        dynamic_states: the state entries that are the law's own dynamics (integrators,
            filters), as opposed to histories of measured signals.
    """

    name: str
    synthesize: Callable
    update: Callable
    section: str
    summary: str
    fields: dict[str, int]
    spans: bool = False
    table: TableLayout | None = None
    export: Callable | None = None
    drive_blocks: int | str = 1
    joint_fields: dict[str, int] = field(default_factory=dict)
    drive_base: int = 0
    linear: bool = False
    dynamic_states: tuple[int, ...] = ()


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

    # ---- what the simulator and the old single-joint interface read
    @property
    def joint(self):
        """The (first) joint, index or name."""
        return self.joints[0]

    @property
    def name(self) -> str:
        """The method's name (alias of ``method``)."""
        return self.method

    @property
    def kind(self) -> int:
        """The method's code in the registry's compiled dispatch."""
        from manipcad.control.registry import kind_of

        return kind_of(self.method)

    def describe(self) -> str:
        """The law with its numbers filled in."""
        return self.law or f"{self.method}: period {self.period:g} s"

    def initial_state(self) -> np.ndarray:
        """The regulator's state at t = 0 (length ``NSTATE``)."""
        return np.zeros(NSTATE)

    def realization_complexity(self) -> dict:
        """Operations per control period, numbers stored and signals read, counted by
        running the compiled update's own source (:mod:`manipcad.control.complexity`)."""
        from manipcad.control.complexity import count

        return count(self)

    @property
    def complexity(self) -> dict:
        """Alias of :meth:`realization_complexity`."""
        return self.realization_complexity()

    # ---- files and exports
    def to_dict(self) -> dict:
        """The regulator as a file group (see :mod:`manipcad.control.files`)."""
        from manipcad.control.files import regulator_to_dict

        return regulator_to_dict(self)

    def save(self, path: str | Path) -> Path:
        """Write this regulator to a YAML regulator file (atomically). Returns the path."""
        from manipcad.control.files import save_regulators

        return save_regulators([self], path)

    def to_control(self):
        """This regulator as a python-control system (input: the signals it reads,
        output U in V); see :mod:`manipcad.control.export`."""
        from manipcad.control.export import to_control

        return to_control(self)

    def _repr_html_(self) -> str:
        """The regulator in a notebook: method, joints, period, law, counted complexity."""
        from html import escape

        c = self.realization_complexity()
        names = ", ".join(self.joint_names) or ", ".join(str(j) for j in self.joints)
        return (f"<p><b>{escape(self.method)}</b> on {escape(names)}, period "
                f"{self.period:g} s</p><p>{escape(self.describe())}</p>"
                f"<p>{c['ops_per_period']} operations per period, {c['gains_stored']} numbers "
                f"stored; signals: {escape(', '.join(c['signals']))}</p>")

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
    ulim = u_limit(drive)
    if math.isfinite(ulim) and drive.R > 0:
        return drive.k_u * ulim / drive.R
    return math.inf
