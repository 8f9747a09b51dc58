"""The parts library: thousands of data-sheet motors and gears, SI units, with sources.

What is in it (docs/catalog.md): the Motor-Gearbox Database's maxon, Faulhaber,
Allied Motion and T-motor motors and gearboxes (with the makers' compatibility
tables), Harmonic Drive CSG/CSF rating rows and single industrial motors from
the data files, and the built-in part files robot files have always named
(``maxon_ec90flat_323772``, ``harmonic_csg20_100``, ...). A workspace's own
motor and gear files extend it (``ws=``). Read-only; indexed once per data
version (:func:`manipcad.catalog.library.tables`), so every call below is fast.

The API (vectorizable: one table row per part, SI columns, nan = unknown):

- :func:`motors` -> DataFrame, index the part name. Columns: ``name, kind,
  maker, model, type`` (DC/BLDC), ``J`` kg·m² rotor inertia, ``R`` Ω and ``L`` H
  (terminal), ``k_m`` N·m/A, ``k_w`` V·s/rad, ``k_v`` N·m·s/rad, ``M_f`` N·m,
  ``rated_torque`` N·m (continuous), ``peak_torque`` N·m, ``max_speed`` rad/s,
  ``rated_voltage`` V, ``rated_current`` A, ``no_load_speed`` rad/s,
  ``no_load_current`` A, ``stall_current`` A, ``mass`` kg, ``max_cont_speed``
  rad/s, ``max_cont_power`` W, ``Rth1``/``Rth2`` K/W, then ``origin`` (mgdb,
  sheet, file, workspace), ``key`` (e.g. ``MM_597974``), ``source``,
  ``confidence``, ``assumed`` and ``derived`` (dicts field -> why).
- :func:`gears` -> DataFrame: ``type`` (planetary, spur, harmonic, koaxdrive,
  ball_screw, rack_pinion, belt), ``ratio`` (input/output, > 0), ``direction``
  ±1, ``stages``, ``J`` kg·m² at the input, ``efficiency`` (0..1) and
  ``efficiency_basis`` (printed maximum / printed / assumed / unknown),
  output torque ratings ``max_continuous_torque``, ``max_average_torque``,
  ``max_intermittent_torque`` (repeated peak), ``max_momentary_torque`` N·m,
  input speeds ``max_input_speed``, ``max_average_input_speed``,
  ``rated_input_speed`` rad/s, ``stiffness`` N·m/rad, ``mass`` kg, ``linear``
  (a screw, rack or belt: ratio rad/m, ratings N), and the text columns.
- :func:`compatible_pairs` -> DataFrame (motor, gear, rule): which gear mounts
  on which motor (the makers' tables, and :data:`ADAPTER_RULE` for gears that
  have none, such as strain-wave component sets).
- :func:`part` -> :class:`MotorSpec` / :class:`GearSpec` of a name;
  :func:`drive_fields` -> the keyword arguments of
  :class:`manipcad.model.robot.Drive` for a motor and a gear (chain):
  ``Drive(**drive_fields("MM_597974", "MM_223080"))``.
- :func:`describe` -> (field, value, unit) rows of one part (``catalog show``).

Example:
    >>> m = motors(makers=["maxon"])
    >>> int((m.origin == "mgdb").sum()), float(m.loc["MM_597974", "k_m"])
    (640, 0.136)
    >>> g = gears(types=["harmonic"])
    >>> g.loc["harmonic_csg20_100", ["ratio", "max_continuous_torque"]].tolist()
    [100.0, 52.0]
    >>> g.loc["harmonic_csg20_100", "efficiency_basis"]
    'assumed'
    >>> pairs = compatible_pairs(motors(makers=["maxon"]), gears(makers=["maxon"]))
    >>> bool(((pairs.motor == "MM_606793") & (pairs.gear == "MM_223080")).any())
    True
"""

from __future__ import annotations

import ast
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

from manipcad.catalog.files import GearSpec, MotorSpec, compose_gears, part_names
from manipcad.catalog.library import (
    GEAR_UNITS,
    MOTOR_UNITS,
    load_gear,
    load_motor,
    spec_row,
    tables,
)
from manipcad.errors import InputError

#: the documented rule for gears without a maker's compatibility table (docs/catalog.md)
ADAPTER_RULE = ("adapter rule: a gear without a maker's compatibility table (a strain-wave "
                "component set, a servo planetary, a screw) mounts on any motor through an "
                "adapter, kept when the motor cannot overload it: motor peak torque (printed, "
                "else the stall torque k_m·U_N/R) × ratio × efficiency <= the gear's momentary "
                "peak torque (else its repeated peak); a pair with an unknown side is kept")
#: names usable in a ``where`` expression for columns of another name
ALIASES = {"k_t": "k_m", "k_e": "k_w", "inertia": "J", "kt": "k_m"}
_MAKERS = {"maxon": "Maxon", "faulhaber": "Faulhaber", "allied_motion": "Allied_Motion",
           "allied": "Allied_Motion", "tmotor": "Tmotor", "t-motor": "Tmotor",
           "harmonic": "Harmonic Drive", "harmonic_drive": "Harmonic Drive"}
_LINEAR = ("ball_screw", "rack_pinion", "belt")


def _workspace_rows(ws: str | Path | None) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The motor and gear files of a workspace folder (``WS/motors/*.yaml``,
    ``WS/gears/*.yaml``) as library rows, origin "workspace"."""
    if ws is None:
        return [], []
    root = Path(ws)
    if not root.is_dir():
        raise InputError(str(ws), "", "no such workspace folder")
    m = [spec_row(load_motor(str(p.resolve())), p.stem, "workspace")
         for p in sorted((root / "motors").glob("*.yaml"))]
    g = [spec_row(load_gear(str(p.resolve())), p.stem, "workspace")
         for p in sorted((root / "gears").glob("*.yaml"))]
    return m, g


def _extend(df: pd.DataFrame, rows: list[dict[str, Any]]) -> pd.DataFrame:
    # deferred: start-up cost: pandas is 0.3-0.6 s of every command's start
    import pandas as pd

    if not rows:
        return df
    extra = pd.DataFrame.from_records(rows).set_index("name", drop=False)
    clash = sorted(set(extra.index) & set(df.index))
    if clash:
        raise InputError("workspace", "", f"part names {clash} are library names already; "
                         "rename the workspace files")
    return pd.concat([df, extra[[c for c in df.columns if c in extra.columns]]])


def _maker_filter(df: pd.DataFrame, makers: Iterable[str] | None) -> pd.DataFrame:
    if makers is None:
        return df
    want = {_MAKERS.get(m.strip().lower(), m.strip()).lower() for m in makers}
    return df[df["maker"].str.lower().isin(want)]


def where_expression(where: str, columns: Sequence[str]) -> str:
    """A ``--where`` filter checked and rewritten for :meth:`pandas.DataFrame.query`:
    comparisons of columns (or :data:`ALIASES`) with numbers or text, joined by
    ``and``/``or``/``not`` and arithmetic. Raises :class:`InputError` otherwise.

    Example:
        >>> where_expression("k_t > 0.1 and mass < 1", ["k_m", "mass"])
        'k_m > 0.1 and mass < 1'
    """
    try:
        tree = ast.parse(where.strip(), mode="eval")
    except SyntaxError as exc:
        raise InputError("--where", "", f"{where!r} is not an expression: {exc.msg}") from None
    allowed = (ast.Expression, ast.BoolOp, ast.And, ast.Or, ast.UnaryOp, ast.Not, ast.USub,
               ast.UAdd, ast.Compare, ast.Eq, ast.NotEq, ast.Lt, ast.LtE, ast.Gt, ast.GtE,
               ast.BinOp, ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.Constant,
               ast.Name, ast.Load)
    for node in ast.walk(tree):
        if not isinstance(node, allowed):
            raise InputError("--where", "", f"{where!r}: only comparisons of columns with "
                             "numbers or quoted text, and/or/not and + - * / are allowed")
        if isinstance(node, ast.Name):
            node.id = ALIASES.get(node.id, node.id)
            if node.id not in columns:
                raise InputError("--where", "", f"unknown column {node.id!r}; columns: "
                                 + ", ".join(columns))
        if isinstance(node, ast.Constant) and not isinstance(node.value, int | float | str):
            raise InputError("--where", "", f"{where!r}: {node.value!r} is not a number or text")
    return ast.unparse(tree)


def _query(df: pd.DataFrame, where: str | None) -> pd.DataFrame:
    if not where:
        return df
    expr = where_expression(where, list(df.columns))
    try:
        return df.query(expr, engine="python")
    except Exception as exc:  # a comparison of text with a number, ...
        raise InputError("--where", "", f"{where!r}: {exc}") from None


def motors(makers: Iterable[str] | None = None, where: str | None = None,
           ws: str | Path | None = None) -> pd.DataFrame:
    """Every motor of the library as one table (SI units, nan unknown).

    Args:
        makers: keep these makers only (case-insensitive: maxon, faulhaber,
            allied_motion, tmotor, Siemens, ...); None: all.
        where: a filter over the columns, e.g. ``"k_t > 0.1 and mass < 1"``
            (:func:`where_expression`).
        ws: a workspace folder whose ``motors/*.yaml`` join the table.

    Returns:
        A new DataFrame indexed by part name (columns in the module docstring).

    Example:
        >>> motors(makers=["maxon"], where="k_t > 0.2 and mass < 1").index.tolist()[:2]
        ['MM_500267', 'MM_580047']
    """
    df = _extend(tables().motors, _workspace_rows(ws)[0])
    return _query(_maker_filter(df, makers), where).copy()


def gears(makers: Iterable[str] | None = None, types: Iterable[str] | None = None,
          where: str | None = None, ws: str | Path | None = None) -> pd.DataFrame:
    """Every gear of the library as one table (SI units, nan unknown).

    Args:
        makers: keep these makers only (maxon, faulhaber, tmotor, "Harmonic
            Drive", ...); None: all.
        types: keep these types only (planetary, spur, harmonic, koaxdrive,
            ball_screw, rack_pinion, belt); None: all.
        where: a filter over the columns (:func:`where_expression`).
        ws: a workspace folder whose ``gears/*.yaml`` join the table.

    Returns:
        A new DataFrame indexed by part name, with ``efficiency_basis`` and
        ``linear`` besides the table's columns.

    Example:
        >>> g = gears(types=["harmonic"], where="ratio == 100 and max_continuous_torque > 50")
        >>> sorted(g.index)[:2]
        ['CSG-20-100-2UH', 'CSG-25-100-2UH']
    """
    df = _extend(tables().gears, _workspace_rows(ws)[1]).copy()
    df["efficiency_basis"] = _efficiency_basis(df)
    df["linear"] = df["type"].isin(_LINEAR)
    if types is not None:
        df = df[df["type"].isin([t.strip().lower() for t in types])]
    return _query(_maker_filter(df, makers), where).copy()


def _efficiency_basis(df: pd.DataFrame) -> pd.Series:
    # deferred: start-up cost: pandas is 0.3-0.6 s of every command's start
    import pandas as pd

    assumed = df["assumed"].map(lambda a: "efficiency" in a)
    out = np.where(assumed, "assumed", np.where(
        df["efficiency"].isna(), "unknown",
        np.where(df["origin"] == "mgdb", "printed maximum", "printed")))
    return pd.Series(out, index=df.index)


def compatible_pairs(motor_table: pd.DataFrame | None = None,
                     gear_table: pd.DataFrame | None = None) -> pd.DataFrame:
    """Which gear mounts on which motor, among the given tables.

    A pair comes from the maker's compatibility table (MGDB: maxon, Faulhaber,
    T-motor) where the gear has one; a gear without one (strain-wave component
    sets, the built-in and workspace gears) pairs by :data:`ADAPTER_RULE`.

    Args:
        motor_table: rows of :func:`motors` (None: all).
        gear_table: rows of :func:`gears` (None: all).

    Returns:
        DataFrame with columns ``motor``, ``gear`` (part names) and ``rule`` (the
        table or rule that pairs them), in table order.

    Example:
        >>> p = compatible_pairs(motors(makers=["maxon"]), gears(types=["harmonic"]))
        >>> bool(p["rule"].str.startswith("adapter rule").all())
        True
    """
    # deferred: start-up cost: pandas is 0.3-0.6 s of every command's start
    import pandas as pd

    m = tables().motors if motor_table is None else motor_table
    g = gears() if gear_table is None else gear_table
    t = tables().pairs
    table = t[t["motor"].isin(m.index) & t["gear"].isin(g.index)]
    free = g[g["origin"] != "mgdb"]
    if len(free) == 0 or len(m) == 0:
        return table.reset_index(drop=True)
    peak = m["peak_torque"].to_numpy(float)
    stall = m["k_m"].to_numpy(float) * m["rated_voltage"].to_numpy(float) / m["R"].to_numpy(float)
    peak = np.where(np.isnan(peak), stall, peak)
    limit = free["max_momentary_torque"].to_numpy(float)
    limit = np.where(np.isnan(limit), free["max_intermittent_torque"].to_numpy(float), limit)
    eta = np.nan_to_num(free["efficiency"].to_numpy(float), nan=1.0)
    out_torque = peak[:, None] * (free["ratio"].to_numpy(float) * eta)[None, :]
    too_strong = out_torque > limit[None, :]          # nan on either side: kept
    mi, gi = np.nonzero(~too_strong)
    adapter = pd.DataFrame({"motor": m.index.to_numpy()[mi], "gear": free.index.to_numpy()[gi],
                            "rule": ADAPTER_RULE})
    return pd.concat([table, adapter], ignore_index=True)


def part(name: str, ws: str | Path | None = None) -> MotorSpec | GearSpec:
    """A motor or gear by name (library name, or a workspace part's name with ``ws``).

    Returns:
        Its :class:`MotorSpec` or :class:`GearSpec` (SI units; unknown ratings None).

    Raises:
        InputError: no such part.

    Example:
        >>> part("MM_223080").ratio
        3.5
    """
    if ws is not None:
        for kind, load in (("motors", load_motor), ("gears", load_gear)):
            p = Path(ws) / kind / f"{name}.yaml"
            if p.is_file():
                return load(str(p.resolve()))
    t = tables()
    if name in t.motors.index:
        return load_motor(name)
    if name in t.gears.index:
        return load_gear(name)
    raise InputError(name, "", "no such part in the catalog (manipcad catalog list)")


def drive_fields(motor: str | MotorSpec | None = None,
                 gear: str | GearSpec | Sequence[str | GearSpec] = ()) -> dict[str, Any]:
    """The keyword arguments of :class:`manipcad.model.robot.Drive` for a motor and a
    gear (or a chain of gears from the motor outwards), composed as a robot file's
    ``drive: {motor: ..., gear: ...}`` is (:func:`compose_drive`).

    Example:
        >>> f = drive_fields("MM_597974", "harmonic_csg20_100")
        >>> f["ratio"], f["name"], f["assumed"][0][0]
        (-100.0, 'MM_597974', 'efficiency')
    """
    m = load_motor(motor) if isinstance(motor, str) else motor
    chain = [gear] if isinstance(gear, str | GearSpec) else list(gear)
    gs = [load_gear(g) if isinstance(g, str) else g for g in chain]
    fields, _ = compose_drive(m, gs)
    fields["name"] = motor if isinstance(motor, str) else (m.name if m else "")
    fields["gear"] = " + ".join(g if isinstance(g, str) else g.name for g in chain)
    return fields


def compose_drive(motor: MotorSpec | None, gear_chain: Sequence[GearSpec]
                  ) -> tuple[dict[str, Any], float | None]:
    """The Drive fields of a motor and a gear chain: the motor's
    (:meth:`MotorSpec.drive_fields`) with the chain's (:func:`compose_gears`: J added
    on the motor shaft, ratio, efficiency, ratings), assumptions of both joined.

    Returns:
        (fields, stiffness): the fields, and the chain's joint-side torsional
        stiffness N·m/rad (None unless every gear gives one).
    """
    fields: dict[str, Any] = motor.drive_fields() if motor is not None else {}
    stiffness = None
    if gear_chain:
        composed, stiffness = compose_gears(list(gear_chain))
        fields["J"] = fields.get("J", 0.0) + composed.pop("J")
        assumed = dict(fields.get("assumed", ())) | dict(composed.pop("assumed", ()))
        fields.update(composed)
        if assumed:
            fields["assumed"] = tuple(sorted(assumed.items()))
    return fields, stiffness


def describe(name: str, ws: str | Path | None = None) -> dict[str, Any]:
    """One part's every field with its unit and its source, for ``catalog show``.

    Returns:
        {"name", "kind", "source", "fields": [{"field", "value", "unit", "note"}]}:
        value nan when unknown; note "assumed: ..." or "derived: ..." where so.
    """
    table = motors(ws=ws) if _is_motor(name, ws) else gears(ws=ws)
    if name not in table.index:
        raise InputError(name, "", "no such part in the catalog (manipcad catalog list)")
    row = table.loc[name]
    units = MOTOR_UNITS if row["kind"] == "motor" else GEAR_UNITS
    fields = []
    for col in units:
        note = ""
        if col in row["assumed"]:
            note = f"assumed: {row['assumed'][col]}"
        elif col in row["derived"]:
            note = f"derived: {row['derived'][col]}"
        elif col == "efficiency" and not math.isnan(row[col]):
            note = str(row["efficiency_basis"])
        fields.append({"field": col, "value": float(row[col]), "unit": units[col],
                       "note": note})
    for k in ("M_f", "k_v", "direction"):
        if k in row["assumed"] and k not in units:
            fields.append({"field": k, "value": math.nan, "unit": "", "note": row["assumed"][k]})
    text = {k: row[k] for k in ("name", "kind", "maker", "model", "type", "origin", "key",
                                "source", "confidence")}
    return {**text, "fields": fields}


def _is_motor(name: str, ws: str | Path | None) -> bool:
    if ws is not None and (Path(ws) / "motors" / f"{name}.yaml").is_file():
        return True
    return name in tables().motors.index


def counts() -> dict[str, dict[str, int]]:
    """Parts per maker: {"motors": {maker: n}, "gears": {maker: n}, "pairs": {rule: n}}."""
    t = tables()
    return {"motors": t.motors["maker"].value_counts().to_dict(),
            "gears": t.gears["maker"].value_counts().to_dict(),
            "pairs": t.pairs["rule"].value_counts().to_dict()}


__all__ = ["motors", "gears", "compatible_pairs", "part", "drive_fields", "compose_drive",
           "describe", "counts", "where_expression", "MotorSpec", "GearSpec", "load_motor",
           "load_gear", "compose_gears", "part_names", "ADAPTER_RULE", "MOTOR_UNITS",
           "GEAR_UNITS"]
