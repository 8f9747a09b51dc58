"""The parts library: every imported motor and gear as SI tables, indexed once.

Sources (all in ``manipcad/catalog/data``, copied unchanged; docs/catalog.md):

- ``mgdb/``: the Motor-Gearbox Database (github.com/ekrimsk/MGDB at commit
  :data:`MGDB_COMMIT`): maxon, Faulhaber, Allied Motion and T-motor motors and
  gearboxes, with the maxon, Faulhaber and T-motor compatibility tables;
- ``gears.yaml`` / ``motors.yaml``: Harmonic Drive CSG/CSF rating rows and
  single motors, each with its source, quote and confidence;
- ``parts/motors`` and ``parts/gears``: the built-in part files (the names robot
  files have always used, e.g. ``maxon_ec90flat_323772``, ``harmonic_csg20_100``).

Each part is one row: its ``name`` (the MGDB key such as ``MM_597974``, a
slug of the data-file id, or the part file's name), ``maker``, ``model``,
``origin`` ("mgdb", "sheet", "file", "workspace"), ``source`` (database and
commit and key, or the file's source text), ``confidence``, the fields of
:class:`~manipcad.catalog.files.MotorSpec` / :class:`~manipcad.catalog.files.GearSpec`
in SI units (nan where the source prints none), and ``assumed`` / ``derived``
notes naming every value that is not printed as it stands.

Mapping rules (the tests check every row against its source with them):

- MGDB motors: J = inertia, R, L, k_m = k_t, k_w = k_e where printed (T-motor AK)
  else k_t (derived: the SI identity of an ideal motor), rated_voltage = V,
  rated_current = I_nom, rated_torque = k_t·I_nom (derived: MGDB has no nominal
  torque column), peak_torque = max_int_torque, max_speed = max_int_speed,
  no_load_speed = omega_nl, no_load_current = I_nl, M_f = coulomb_friction, or
  k_t·I_nl (derived) where that is not printed, k_v = viscous_friction, mass,
  Rth1, Rth2, max_cont_speed, max_cont_power. MGDB's inf ("no limit printed")
  becomes nan: a rating nobody printed is unknown, never unlimited.
- MGDB gearboxes: ratio, direction, stages, J = inertia (input side),
  efficiency (the maximum printed, ``efficiency_basis`` "printed maximum"),
  max_continuous_torque = max_cont_torque, max_intermittent_torque =
  max_int_torque, mass; inf becomes nan.

The tables are built on first use and kept in ``~/.cache/manipcad`` keyed by
the hash of the data and of this package's code (:func:`tables`); later
lookups read that pickle (milliseconds).
"""

from __future__ import annotations

import csv
import dataclasses
import fnmatch
import hashlib
import math
import os
import pickle
import re
from collections.abc import Iterable
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from manipcad import fileio
from manipcad.catalog.files import (
    PARTS,
    GearSpec,
    MotorSpec,
    _load_spec,
    _resolve,
    _unknown,
    part_names,
)
from manipcad.errors import InputError

if TYPE_CHECKING:
    import pandas as pd

DATA = PARTS.parent
#: the Motor-Gearbox Database commit the mgdb/ files were copied from
MGDB_COMMIT = "215caccec6e05a58fdcdce14956d658853bf5128"
MGDB_REPO = "github.com/ekrimsk/MGDB"
#: (motor file, gearbox file, compatibility file) per maker; None where MGDB has none
MGDB_FILES: dict[str, tuple[str | None, str | None, str | None]] = {
    "maxon": ("maxon_motors.csv", "maxon_gearboxes.csv", "maxon_compatibility.csv"),
    "faulhaber": ("faulhaber_motors.csv", "faulhaber_gearboxes.csv",
                  "faulhaber_compatibility.csv"),
    "allied_motion": ("allied_motion_motors.csv", None, None),
    "tmotor_ak": ("Tmotor_AK_motors.csv", "Tmotor_AK_gearboxes.csv",
                  "Tmotor_AK_compatibility.csv"),
    "tmotor_g": ("Tmotor_G_motors.csv", None, None),
}

#: the motor table's numeric columns and their SI units
MOTOR_UNITS: dict[str, str] = {
    "J": "kg·m²", "R": "Ω", "L": "H", "k_m": "N·m/A", "k_w": "V·s/rad",
    "k_v": "N·m·s/rad", "M_f": "N·m", "rated_torque": "N·m", "peak_torque": "N·m",
    "max_speed": "rad/s", "rated_voltage": "V", "rated_current": "A",
    "no_load_speed": "rad/s", "no_load_current": "A", "stall_current": "A", "mass": "kg",
    "max_cont_speed": "rad/s", "max_cont_power": "W", "Rth1": "K/W", "Rth2": "K/W",
}
#: the gear table's numeric columns and their SI units (N, rad/m for linear ones)
GEAR_UNITS: dict[str, str] = {
    "ratio": "rad/rad (rad/m linear)", "direction": "±1", "stages": "1",
    "J": "kg·m² (input)", "efficiency": "1", "max_continuous_torque": "N·m (output)",
    "max_average_torque": "N·m (output)", "max_intermittent_torque": "N·m (output)",
    "max_momentary_torque": "N·m (output)", "max_input_speed": "rad/s (input)",
    "max_average_input_speed": "rad/s (input)", "rated_input_speed": "rad/s (input)",
    "stiffness": "N·m/rad (output)", "mass": "kg",
}
#: the text columns of both tables
TEXT_COLUMNS = ("name", "kind", "maker", "model", "type", "origin", "key", "source",
                "confidence", "assumed", "derived")
_RPM = 2.0 * math.pi / 60.0


@dataclasses.dataclass(frozen=True)
class Tables:
    """The library's tables: ``motors`` and ``gears`` (one row per part, index the
    name), ``pairs`` (motor, gear, rule) from the makers' compatibility tables."""

    motors: pd.DataFrame
    gears: pd.DataFrame
    pairs: pd.DataFrame


# --------------------------------------------------------------------------- MGDB


def mgdb_source(maker_file: str, key: str) -> str:
    """The source of an MGDB part: database, commit, file and key."""
    return (f"Motor-Gearbox Database ({MGDB_REPO}@{MGDB_COMMIT}), {maker_file}, key {key}; "
            f"the manufacturer's data-sheet values as that database transcribed them")


def _num(text: str) -> float:
    """A CSV cell as a float: "", NaN and a cell that is no number (one Allied Motion
    inductance reads "0.85-3") are nan, Inf/inf is inf."""
    t = text.strip()
    try:
        return math.nan if t == "" else float(t)
    except ValueError:
        return math.nan


def _unreadable(row: dict[str, str]) -> str:
    """The cells of an MGDB row that are no number, for the part's source."""
    bad = []
    for k, v in row.items():
        if k in ("key", "manufacturer", "ID", "type") or not v.strip():
            continue
        try:
            float(v)
        except ValueError:
            bad.append(f"{k} {v!r}")
    return f"; cells that are no number, left unknown: {', '.join(bad)}" if bad else ""


def read_csv(name: str) -> list[dict[str, str]]:
    """The rows of an MGDB CSV file (``data/mgdb/NAME``) as dicts of text."""
    with (DATA / "mgdb" / name).open(encoding="utf-8", newline="") as f:
        return list(csv.DictReader(f))


def _rating(x: float) -> float:
    """A rating as the library keeps it: MGDB's inf (no limit printed) is unknown."""
    return math.nan if math.isinf(x) else x


def _stall(row: dict[str, Any]) -> None:
    """Where the source prints no peak torque: the stall torque k_m·U_N/R and the stall
    current U_N/R at the nominal voltage (what maxon's and Faulhaber's sheets print in
    their place), marked derived; a motor lacking k_m, U_N or R keeps both unknown."""
    stall_i = row["rated_voltage"] / row["R"] if row["R"] > 0 else math.nan
    if math.isnan(row["stall_current"]) and not math.isnan(stall_i):
        row["stall_current"] = stall_i
        row["derived"]["stall_current"] = "U_N/R (the current at stall, nominal voltage)"
    if math.isnan(row["peak_torque"]) and not math.isnan(row["k_m"] * stall_i):
        row["peak_torque"] = row["k_m"] * stall_i
        row["derived"]["peak_torque"] = ("stall torque k_m·U_N/R: the source prints no peak "
                                         "torque; the motor gives no more at U_N")


def _mgdb_motor(row: dict[str, str], file: str) -> dict[str, Any]:
    key = row["key"]
    k_t = _num(row["k_t"])
    derived: dict[str, str] = {}
    if "k_e" in row and row["k_e"].strip():
        k_w = _num(row["k_e"])
    else:
        k_w = k_t
        derived["k_w"] = "k_t (SI: an ideal motor's back-EMF constant equals its torque " \
                         "constant; MGDB gives no speed constant)"
    i_nom = _rating(_num(row["I_nom"]))
    rated = k_t * i_nom
    if not math.isnan(rated):
        derived["rated_torque"] = "k_t·I_nom (MGDB has no nominal-torque column)"
    m_f, i_nl = _num(row["coulomb_friction"]), _num(row["I_nl"])
    k_v = _num(row["viscous_friction"])
    if math.isnan(m_f) and not math.isnan(i_nl):
        m_f = k_t * i_nl
        derived["M_f"] = "k_t·I_nl (dry friction from the no-load current)"
        if math.isnan(k_v):
            k_v = 0.0
            derived["k_v"] = "0: the no-load friction k_t·I_nl is all taken as dry friction M_f"
    assumed: dict[str, str] = {}
    if math.isnan(m_f):
        m_f = 0.0
        assumed["M_f"] = "not printed; taken as 0"
    if math.isnan(k_v):
        k_v = 0.0
        assumed["k_v"] = "not printed; taken as 0"
    return {
        "name": key, "kind": "motor", "maker": row["manufacturer"], "model": row["ID"],
        "type": row["type"], "origin": "mgdb", "key": key,
        "source": mgdb_source(file, key) + _unreadable(row),
        "confidence": "", "J": _num(row["inertia"]), "R": _num(row["R"]), "L": _num(row["L"]),
        "k_m": k_t, "k_w": k_w, "k_v": k_v, "M_f": m_f, "rated_torque": rated,
        "peak_torque": _rating(_num(row["max_int_torque"])),
        "max_speed": _rating(_num(row["max_int_speed"])), "rated_voltage": _num(row["V"]),
        "rated_current": i_nom, "no_load_speed": _rating(_num(row["omega_nl"])),
        "no_load_current": i_nl, "stall_current": math.nan, "mass": _num(row["mass"]),
        "max_cont_speed": _rating(_num(row["max_cont_speed"])),
        "max_cont_power": _rating(_num(row["max_cont_power"])),
        "Rth1": _num(row["Rth1"]), "Rth2": _num(row["Rth2"]),
        "assumed": assumed, "derived": derived,
    }


def _mgdb_gear(row: dict[str, str], file: str) -> dict[str, Any]:
    key = row["key"]
    return {
        "name": key, "kind": "gear", "maker": row["manufacturer"], "model": row["ID"],
        "type": row["type"], "origin": "mgdb", "key": key,
        "source": mgdb_source(file, key) + _unreadable(row), "confidence": "",
        "ratio": _num(row["ratio"]), "direction": _num(row["direction"]),
        "stages": _num(row["stages"]), "J": _num(row["inertia"]),
        "efficiency": _num(row["efficiency"]),
        "max_continuous_torque": _rating(_num(row["max_cont_torque"])),
        "max_intermittent_torque": _rating(_num(row["max_int_torque"])),
        "mass": _num(row["mass"]), "assumed": {}, "derived": {},
    }


def _mgdb_pairs(file: str, gear_keys: list[str], maker: str) -> list[tuple[str, str, str]]:
    """The (motor, gear, rule) pairs of a compatibility file: one line per motor key,
    then its gearbox keys; a key ending in ``*`` (Faulhaber) stands for every gearbox
    key it begins."""
    out = []
    rule = f"{maker} compatibility table (MGDB {file})"
    with (DATA / "mgdb" / file).open(encoding="utf-8", newline="") as f:
        for line in csv.reader(f):
            if not line:
                continue
            motor, *gears = (x.strip() for x in line)
            for g in gears:
                if not g:
                    continue
                hits = fnmatch.filter(gear_keys, g) if "*" in g else [g]
                out.extend((motor, h, rule) for h in hits)
    return out


# --------------------------------------------------------------------------- data files


def slug(text: str) -> str:
    """A part name from a data-file id: lower case, words joined by ``_``.

    Example:
        >>> slug("Siemens 1FT7044-AK7")
        'siemens_1ft7044_ak7'
    """
    return re.sub(r"[^a-z0-9.]+", "_", text.lower()).strip("_")


_UNIT = {"N*m": 1.0, "N*m/A": 1.0, "N*m/A rms": 1.0, "kg": 1.0, "A": 1.0, "A rms": 1.0,
         "V": 1.0, "ohm": 1.0, "rpm": _RPM, "mH": 1e-3, "g*cm^2": 1e-7, "kg*cm^2": 1e-4,
         "kg*m^2": 1.0, "V*s/rad": 1.0, "V/krpm": 1.0 / (1000.0 * _RPM), "N*m/rad": 1.0,
         "1": 1.0, "K/W": 1.0}


def sheet_value(entry: dict[str, Any], key: str, units: Iterable[str] | None = None) -> float:
    """A ``{value, unit}`` field of a data-file entry in SI (nan when absent, null or
    in a unit outside ``units``)."""
    v = entry.get(key)
    if not isinstance(v, dict) or v.get("value") is None:
        return math.nan
    unit = str(v.get("unit"))
    if unit not in _UNIT or (units is not None and unit not in units):
        return math.nan
    return float(v["value"]) * _UNIT[unit]


def _footnoted_momentary(entry: dict[str, Any]) -> float | None:
    """The lower of two momentary-peak values an earlier transcription printed with a
    catalogue footnote, ``"395 (382)3)"`` -> 382 (data README: use the lower)."""
    quote = str(entry.get("footnote_in_earlier_commit", {}).get("quote", ""))
    m = re.search(r'"(\d+(?:\.\d+)?)\s*\((\d+(?:\.\d+)?)\)\d\)"', quote)
    return min(float(m.group(1)), float(m.group(2))) if m else None


def _sheet_gears() -> list[dict[str, Any]]:
    data = fileio.read_yaml(DATA / "gears.yaml")
    rows = []
    for e in data["parts"]:
        ident = str(e["id"])
        if "cross-check" in ident:
            continue        # a second source's reading of a part listed already
        name = ident.split(" ")[0]
        derived: dict[str, str] = {}
        momentary = sheet_value(e, "momentary_peak_torque")
        low = _footnoted_momentary(e)
        if low is not None and low < momentary:
            derived["max_momentary_torque"] = (
                f"the lower of the two values the earlier transcription printed "
                f"({momentary:g} and {low:g} N·m, catalogue footnote)")
            momentary = low
        rated_speed = math.nan
        note = str((e.get("rated_torque") or {}).get("note", ""))
        m = re.search(r"rated input speed (\d+) rpm", note)
        if m:
            rated_speed = float(m.group(1)) * _RPM
        eta = e.get("efficiency_at_rated_torque")
        efficiency = math.nan if not isinstance(eta, dict) else float(eta["value"])
        stages = 1.0
        derived["stages"] = "1: a strain-wave gear is one stage (wave generator, flexspline)"
        rows.append({
            "name": name, "kind": "gear", "maker": "Harmonic Drive",
            "model": ident, "type": "harmonic", "origin": "sheet", "key": ident,
            "source": f"manipcad/catalog/data/gears.yaml, part {ident!r}: {e['source']} "
                      f"({e.get('provenance', '')})",
            "confidence": str(e.get("confidence", "")),
            "ratio": float(e["ratio"]), "direction": -1.0, "stages": stages,
            "J": sheet_value(e, "input_inertia"), "efficiency": efficiency,
            "max_continuous_torque": sheet_value(e, "rated_torque"),
            "max_average_torque": sheet_value(e, "average_torque_limit"),
            "max_intermittent_torque": sheet_value(e, "repeated_peak_torque"),
            "max_momentary_torque": momentary,
            "max_input_speed": sheet_value(e, "max_input_speed"),
            "max_average_input_speed": sheet_value(e, "average_input_speed_limit"),
            "rated_input_speed": rated_speed,
            "stiffness": sheet_value(e, "torsional_stiffness_K3"),
            "mass": sheet_value(e, "mass"),
            "assumed": {"direction": "-1: circular spline fixed, flexspline output (the "
                                     "catalogue's standard arrangement; not in the data)"},
            "derived": derived,
        })
    return rows


def _sheet_motor_records(e: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """(name, fields) per winding of a motors.yaml entry (one when it lists none): the
    maker and the part number (``maxon_500267``), else the maker and the winding
    (``maxon_244879_48v``), else a slug of the id (``siemens_1ft7044_ak7``)."""
    maker = slug(str(e.get("manufacturer", "")))
    part = str(e.get("part_number") or "")
    windings = e.get("windings")
    if isinstance(windings, dict) and windings:
        return [(f"{maker}_{slug(w)}", {**e, **fields}) for w, fields in windings.items()]
    if part:
        return [(f"{maker}_{slug(part)}", e)]
    return [(slug(re.sub(r"\(.*?\)", "", str(e["id"]))), e)]


def _sheet_motors() -> list[dict[str, Any]]:
    data = fileio.read_yaml(DATA / "motors.yaml")
    rows = []
    for e in data["motors"]:
        for name, f in _sheet_motor_records(e):
            derived = {k: str(v.get("note", "derived")) for k, v in f.items()
                       if isinstance(v, dict) and v.get("derived")}
            voltage = sheet_value(f, "nominal_voltage", units=("V",))
            if math.isnan(voltage):
                voltage = sheet_value(f, "rated_voltage", units=("V",))
            k_w = sheet_value(f, "back_emf_constant")
            if math.isnan(k_w) and isinstance(f.get("speed_constant"), dict):
                k_w = 1.0 / (float(f["speed_constant"]["value"]) * _RPM)   # rpm/V
                derived["k_w"] = "1/speed constant"
            conventions = "; ".join(f"{k}: {v['convention']}" for k, v in f.items()
                                    if isinstance(v, dict) and "convention" in v)
            rows.append({
                "name": name, "kind": "motor", "maker": maker_name(str(e.get("manufacturer", ""))),
                "model": str(e["id"]), "type": str(e.get("type", "")), "origin": "sheet",
                "key": str(e["id"]),
                "source": f"manipcad/catalog/data/motors.yaml, entry {e['id']!r}: {e['source']}"
                          f" ({e.get('provenance', '')})"
                          + (f"; conventions: {conventions}" if conventions else ""),
                "confidence": str(e.get("confidence", "")),
                "J": sheet_value(f, "rotor_inertia"), "R": sheet_value(f, "winding_resistance"),
                "L": sheet_value(f, "winding_inductance"),
                "k_m": sheet_value(f, "torque_constant_kt"), "k_w": k_w,
                "k_v": 0.0, "M_f": 0.0,
                "rated_torque": sheet_value(f, "rated_torque"),
                "peak_torque": sheet_value(f, "peak_torque"),
                "max_speed": sheet_value(f, "max_speed"), "rated_voltage": voltage,
                "rated_current": sheet_value(f, "rated_current"),
                "no_load_speed": sheet_value(f, "no_load_speed"),
                "no_load_current": sheet_value(f, "no_load_current"),
                "stall_current": math.nan, "mass": sheet_value(f, "mass"),
                "max_cont_speed": math.nan, "max_cont_power": math.nan,
                "Rth1": sheet_value(f, "thermal_resistance_winding_housing"),
                "Rth2": sheet_value(f, "thermal_resistance_housing_ambient"),
                "assumed": {"M_f": "not printed; taken as 0", "k_v": "not printed; taken as 0"},
                "derived": derived,
            })
    return rows


# --------------------------------------------------------------------------- part files


#: canonical maker names, by a lower-case name or a part-file name's first word
MAKERS = {"maxon": "Maxon", "harmonic": "Harmonic Drive", "beckhoff": "Beckhoff",
          "wittenstein": "Wittenstein", "faulhaber": "Faulhaber", "siemens": "Siemens",
          "yaskawa": "Yaskawa", "allied motion": "Allied_Motion", "allied_motion": "Allied_Motion",
          "tmotor": "Tmotor", "harmonic drive": "Harmonic Drive"}


def maker_name(text: str) -> str:
    """A maker's canonical name (MGDB's spelling where it has one).

    Example:
        >>> maker_name("maxon"), maker_name("Allied Motion")
        ('Maxon', 'Allied_Motion')
    """
    return MAKERS.get(text.strip().lower(), text.strip())


def spec_row(spec: MotorSpec | GearSpec, name: str, origin: str) -> dict[str, Any]:
    """A part file's spec as a library row (None -> nan; M_f the positive-motion value)."""
    motor = isinstance(spec, MotorSpec)
    units = MOTOR_UNITS if motor else GEAR_UNITS
    row: dict[str, Any] = {
        "name": name, "kind": "motor" if motor else "gear",
        "maker": maker_name(spec.maker) if spec.maker
        else MAKERS.get(name.split("_")[0], "(generic)"),
        "model": spec.description or name,
        "type": "" if motor else spec.type, "origin": origin, "key": spec.key or name,
        "source": spec.source, "confidence": spec.confidence,
        "assumed": dict(spec.assumed), "derived": dict(spec.derived),
    }
    for col in units:
        v = getattr(spec, col, None)
        if col == "M_f" and v is not None:
            v = v[0]
        if col == "efficiency":
            v = spec.efficiency_value
        row[col] = math.nan if v is None else float(v)
    return row


def _file_rows() -> list[dict[str, Any]]:
    rows = [spec_row(load_motor(n), n, "file") for n in part_names("motors")]
    rows += [spec_row(load_gear(n), n, "file") for n in part_names("gears")]
    return rows


# --------------------------------------------------------------------------- tables


def _frame(rows: list[dict[str, Any]], units: dict[str, str]) -> pd.DataFrame:
    # deferred: start-up cost: pandas is 0.3-0.6 s of every command's start
    import pandas as pd

    cols = ["name", "kind", "maker", "model", "type", *units, "origin", "key", "source",
            "confidence", "assumed", "derived"]
    df = pd.DataFrame.from_records(rows, columns=cols)
    for c in units:
        df[c] = df[c].astype(float)
    dup = df["name"][df["name"].duplicated()]
    if len(dup):
        raise InputError("catalog", "name", f"duplicate part names: {sorted(set(dup))}")
    return df.set_index("name", drop=False)


def build() -> Tables:
    """Build the tables from the data files (seconds; :func:`tables` caches them)."""
    # deferred: start-up cost: pandas is 0.3-0.6 s of every command's start
    import pandas as pd

    motors: list[dict[str, Any]] = []
    gears: list[dict[str, Any]] = []
    pairs: list[tuple[str, str, str]] = []
    for maker, (mfile, gfile, cfile) in MGDB_FILES.items():
        if mfile:
            motors += [_mgdb_motor(r, mfile) for r in read_csv(mfile)]
        keys = []
        if gfile:
            rows = read_csv(gfile)
            gears += [_mgdb_gear(r, gfile) for r in rows]
            keys = [r["key"] for r in rows]
        if cfile:
            pairs += _mgdb_pairs(cfile, keys, maker)
    motors += _sheet_motors()
    gears += _sheet_gears()
    for row in _file_rows():
        (motors if row["kind"] == "motor" else gears).append(row)
    for g in gears:
        _assume_efficiency(g)
    for m in motors:
        if m["origin"] in ("mgdb", "sheet"):
            _stall(m)
    m, g = _frame(motors, MOTOR_UNITS), _frame(gears, GEAR_UNITS)
    p = pd.DataFrame(pairs, columns=["motor", "gear", "rule"]).drop_duplicates(
        ["motor", "gear"], ignore_index=True)
    return Tables(m, g, p)


def _assume_efficiency(row: dict[str, Any]) -> None:
    """A strain-wave gear row without a printed efficiency takes the stated assumption."""
    if row["type"] == "harmonic" and math.isnan(row["efficiency"]) \
            and "efficiency" not in row["assumed"]:
        # deferred: start-up cost: keeps manipcad.catalog.efficiency out of import manipcad
        from manipcad.catalog.efficiency import strain_wave_assumption

        eta, why = strain_wave_assumption()
        row["efficiency"] = eta
        row["assumed"] = {**row["assumed"], "efficiency": why}


def data_hash() -> str:
    """The hash of the library's data files and of this package's code (hex, 16)."""
    h = hashlib.sha256()
    pkg = Path(str(PARTS)).parent.parent
    files = sorted(p for p in Path(str(DATA)).rglob("*") if p.is_file())
    files += sorted(pkg.glob("*.py"))
    for p in files:
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _cache_dir() -> Path:
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "manipcad"


@lru_cache(maxsize=1)
def tables() -> Tables:
    """The library's tables, built once per data version and kept in the cache folder
    (``~/.cache/manipcad/catalog-HASH.pkl``); a cache that cannot be written is skipped."""
    path = _cache_dir() / f"catalog-{data_hash()}.pkl"
    try:
        with path.open("rb") as f:
            out = pickle.load(f)
        if isinstance(out, Tables):
            return out
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError):
        pass
    out = build()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fileio.atomic_write_bytes(path, pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL))
        for old in path.parent.glob("catalog-*.pkl"):
            if old != path:
                old.unlink(missing_ok=True)
    except OSError:
        pass
    return out


# --------------------------------------------------------------------------- parts


def _none(v: Any) -> Any:
    return None if isinstance(v, float) and math.isnan(v) else v


def row_spec(row: pd.Series) -> MotorSpec | GearSpec:
    """A library row as a part object (:class:`MotorSpec` or :class:`GearSpec`; unknown
    ratings None, unknown electrical data nan)."""
    common = {k: row[k] for k in ("name", "maker", "key", "source", "confidence")}
    common["description"] = str(row["model"])
    common["assumed"] = dict(row["assumed"])
    common["derived"] = dict(row["derived"])
    if row["kind"] == "motor":
        f = {k: float(row[k]) for k in ("J", "R", "L", "k_m", "k_w", "k_v")}
        f["M_f"] = (float(row["M_f"]), float(row["M_f"]))
        for k in ("rated_torque", "peak_torque", "max_speed", "rated_voltage",
                  "rated_current", "no_load_speed", "no_load_current", "stall_current",
                  "mass"):
            f[k] = _none(float(row[k]))
        return MotorSpec.model_construct(**common, **f, order_number="")
    g: dict[str, Any] = {k: _none(float(row[k])) for k in GEAR_UNITS
                         if k not in ("direction", "stages", "ratio", "J")}
    g["ratio"] = float(row["ratio"])
    g["J"] = float(row["J"])
    g["direction"] = int(row["direction"])
    g["stages"] = None if math.isnan(row["stages"]) else int(row["stages"])
    return GearSpec.model_construct(**common, **g, type=row["type"], order_number="")


def library_part(name: str) -> MotorSpec | GearSpec | None:
    """The part of a library name (MGDB key, data-file slug), or None."""
    t = tables()
    for df in (t.motors, t.gears):
        if name in df.index:
            row = df.loc[name]
            if row["origin"] == "file":
                return load_motor(name) if row["kind"] == "motor" else load_gear(name)
            return row_spec(row)
    return None


def load_motor(name: str, base_dir: Path | None = None) -> MotorSpec:
    """A motor by name (a built-in file, ``manipcad robots list``, or any motor of
    ``manipcad catalog list``) or by a .yaml path (relative to ``base_dir``).
    Raises :class:`InputError`.

    Example:
        >>> load_motor("MM_597974").k_m   # N·m/A, maxon 597974 from the MGDB
        0.136
    """
    return _load_part("motors", MotorSpec, name, base_dir)


def load_gear(name: str, base_dir: Path | None = None) -> GearSpec:
    """A gear (transmission) by name (built-in file or any gear of ``manipcad
    catalog list``) or .yaml path. Raises :class:`InputError`."""
    return _load_part("gears", GearSpec, name, base_dir)


def _load_part(kind: str, cls: type, name: str, base_dir: Path | None):
    """A part of ``kind`` ("motors" or "gears", of class ``cls``) by file name or path,
    else by library name; :class:`InputError` when it is neither."""
    path = _resolve(kind, name, base_dir)
    if path is None:
        spec = None if name.endswith((".yaml", ".yml")) else library_part(name)
        if not isinstance(spec, cls):
            raise _unknown(kind, name)
        return spec
    spec = _load_spec(kind, str(path))
    assert isinstance(spec, cls)
    return spec


# --------------------------------------------------------------------------- gear chains


__all__ = ["tables", "build", "Tables", "library_part", "load_motor", "load_gear", "row_spec",
           "spec_row", "MOTOR_UNITS",
           "GEAR_UNITS", "MGDB_COMMIT", "MGDB_FILES", "read_csv", "mgdb_source", "slug",
           "data_hash"]
