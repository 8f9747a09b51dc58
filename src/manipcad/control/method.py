"""A synthesis method as the registry holds it: its functions, its file layout, its
paper section (:class:`Method`), and the layout of a gain table it keeps in its
parameters (:class:`TableLayout`). Plain data: this module imports nothing of the
package, so every method module and the registry can import it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

#: the field a file made before the laws modelled the gear's losses lacks: key -> (the
#: value taken, what it means); see :attr:`Method.optional_fields`
GEAR_EFFICIENCY_OPTIONAL = {
    "gear_efficiency": (1.0, "η = 1 assumed: the law does not model the gear's losses (a file "
                             "made before the laws modelled them); to model them, "
                             "re-synthesize, or add gear_efficiency: η of the gear, -, in "
                             "(0, 1] (the drive's efficiency)")}


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
        optional_fields: keys of ``fields`` or ``joint_fields`` a file may lack (made by an
            older version): key -> (the value taken, what that means; the loader warns
            with it and adds it to the regulator's law).
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
    optional_fields: dict[str, tuple[float, str]] = field(default_factory=dict)
