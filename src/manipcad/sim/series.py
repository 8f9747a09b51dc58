"""The quantities a simulation result holds, their SI units, and its table columns.

One place for what a :class:`~manipcad.sim.SimulationResult` is as a table: the stored
series, the unit of each (by joint type, and whether the run had drives), and the column
names ``"JOINT.QUANTITY [UNIT]"`` the CSV export, the DataFrame and the workspace use.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from manipcad.errors import InputError

#: the arrays of a result kept in the store, in column order per joint
SERIES = ("q", "qd", "q_ref", "qd_ref", "error", "u", "current", "tau")


def series_units(joint_type: str | None, drives: bool) -> dict[str, str]:
    """SI unit of each stored quantity of one joint.

    Args:
        joint_type: "revolute", "prismatic" or None (unknown: "rad|m" etc.).
        drives: whether the run had drive models (then u is a voltage).

    Example:
        >>> series_units("prismatic", True)["tau"]
        'N'
    """
    pos, vel, force = {"revolute": ("rad", "rad/s", "N·m"),
                       "prismatic": ("m", "m/s", "N")}.get(
        joint_type or "", ("rad|m", "rad/s|m/s", "N·m|N"))
    return {"q": pos, "qd": vel, "q_ref": pos, "qd_ref": vel, "error": pos,
            "u": "V" if drives else force, "current": "A", "tau": force}


def result_arrays(result) -> dict[str, np.ndarray]:
    """The stored arrays of a result: ``t`` (K,) s and each of :data:`SERIES` (K, n), float64."""
    arrays = {"t": np.asarray(result.t, dtype=float)}
    for name in SERIES:
        arrays[name] = np.asarray(getattr(result, name), dtype=float)
    return arrays


def series_columns(result, joint_types: Sequence[str] | None = None
                   ) -> list[tuple[str, np.ndarray]]:
    """The columns of a result's table: ("t [s]", t), then per joint each of
    :data:`SERIES` as ("JOINT.QUANTITY [UNIT]", (K,) array); the CSV and the
    DataFrame (:func:`manipcad.workspace.results_dataframe`) use these.

    Args:
        result: a :class:`manipcad.sim.SimulationResult`.
        joint_types: "revolute"/"prismatic" per joint for the units; None: "rad|m".
    """
    drives = bool(result.settings.get("drives", True))
    names = list(result.joint_names)
    types = list(joint_types) if joint_types is not None else [None] * len(names)
    if len(types) != len(names):
        raise InputError("joint_types", "", f"{len(types)} entries for {len(names)} joints")
    arrays = result_arrays(result)
    cols = [("t [s]", arrays["t"])]
    for j, (name, jt) in enumerate(zip(names, types, strict=True)):
        units = series_units(jt, drives)
        cols += [(f"{name}.{s} [{units[s]}]", arrays[s][:, j]) for s in SERIES]
    return cols
