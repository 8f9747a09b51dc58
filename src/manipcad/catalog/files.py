"""Motor and gear files: their schema, loading by name or path, gear chains.

A part file (YAML, SI units, numbers may be expressions such as ``3060*gcm2``,
see :mod:`manipcad.schema`) describes one motor (:class:`MotorSpec`) or one
transmission (:class:`GearSpec`) and names its source. The library's built-in
files are in ``manipcad/catalog/data/parts/{motors,gears}``; a name that is no
file there is looked up in the imported data sheets (:mod:`manipcad.catalog.library`).

Example:
    >>> from manipcad.catalog.library import load_gear
    >>> load_gear("harmonic_csg20_100").max_continuous_torque   # N·m
    52.0
"""

from __future__ import annotations

import math
from functools import lru_cache
from importlib import resources
from importlib.abc import Traversable
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from manipcad import fileio
from manipcad.errors import InputError
from manipcad.schema import Friction, Num, OptNum, problem

#: the built-in part files, one folder per kind ("motors", "gears")
PARTS: Traversable = resources.files("manipcad") / "catalog" / "data" / "parts"
#: the key prefixes of the Motor-Gearbox Database's parts (maxon, Faulhaber, Allied
#: Motion, T-motor)
MGDB_PREFIXES = ("MM_", "FH_", "AM_", "TM_")
#: a motor field's name in the Drive where it differs
_MOTOR_DRIVE_FIELD: dict[str, str] = {}


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    # every part's provenance (the fields motors and gears share, first in both)
    source: str = Field(min_length=1)
    description: str = ""
    order_number: str = ""
    name: str = ""
    maker: str = ""
    key: str = ""
    confidence: str = ""
    assumed: dict[str, str] = {}
    derived: dict[str, str] = {}


class MotorSpec(_Spec):
    """A catalog DC servo motor (motor side, SI units): rotor inertia J kg·m²,
    R Ω, L H, k_m N·m/A, k_w V·s/rad, viscous k_v N·m·s/rad, dry friction M_f N·m,
    ratings (N·m, rad/s, V, A), data-sheet extras and the source.

    A part of the library that is not a file (an imported data-sheet row) may
    hold nan (unknown) in J, R, L, k_m, k_w; a motor file must give them.
    ``assumed`` maps a field to why its value is assumed rather than printed,
    ``derived`` a field to how it was computed from printed values."""

    J: Num
    R: Num
    L: Num
    k_m: Num
    k_w: Num
    k_v: Num = 0.0
    M_f: Friction = (0.0, 0.0)
    rated_torque: OptNum = None
    peak_torque: OptNum = None
    max_speed: OptNum = None
    rated_voltage: OptNum = None
    rated_current: OptNum = None
    no_load_speed: OptNum = None
    no_load_current: OptNum = None
    stall_current: OptNum = None
    mass: OptNum = None

    @field_validator("R", "k_m")
    @classmethod
    def _positive(cls, v: float) -> float:
        """R Ω and k_m N·m/A are > 0 (nan: unknown): a motor of R = 0 draws infinite
        current, one of k_m = 0 makes no torque."""
        if not (math.isnan(v) or v > 0):
            raise ValueError("must be > 0 (nan: unknown)")
        return v

    def drive_fields(self) -> dict[str, Any]:
        """The :class:`~manipcad.model.robot.Drive` fields this motor sets (SI;
        u_max = rated voltage if known; ``assumed`` the (field, why) pairs of its
        assumed values)."""
        out: dict[str, Any] = {k: getattr(self, k) for k in
                               ("J", "R", "L", "k_m", "k_w", "k_v", "M_f")}
        for k in ("rated_torque", "peak_torque", "max_speed", "rated_voltage",
                  "rated_current"):
            v = getattr(self, k)
            if v is not None and not math.isnan(v):
                out[k] = v
        if self.rated_voltage is not None and not math.isnan(self.rated_voltage):
            out["u_max"] = self.rated_voltage
        if self.assumed:
            out["assumed"] = tuple(sorted((_MOTOR_DRIVE_FIELD.get(k, k), why)
                                          for k, why in self.assumed.items()))
        return out


class GearSpec(_Spec):
    """A catalog transmission: ratio i (input rad per output rad, or per output m
    for screws, racks and belts), direction ±1, input-side inertia J kg·m²,
    efficiency, output torque limits (N·m, or N for linear ones), max input speed
    rad/s, torsional stiffness on the output N·m/rad (N/m; used as the contact
    stiffness when a drive gives backlash without elasticity), mass kg, and the
    source.

    The torque ratings, output side (N·m, or N): ``max_continuous_torque`` the
    rated torque (a harmonic drive's at ``rated_input_speed``, rad/s, e.g. 2000
    rpm), ``max_average_torque`` the limit for the average load torque,
    ``max_intermittent_torque`` the repeated peak (acceleration) torque,
    ``max_momentary_torque`` the momentary (emergency-stop, collision) peak. Input
    speeds, rad/s: ``max_input_speed`` and ``max_average_input_speed`` (the limit
    for the average input speed). A rating the source does not give is left out
    (unknown); the loader checks the ones given are in the catalogues' order
    (rated <= average <= repeated peak <= momentary; average speed <= max speed).

    ``efficiency``: the printed value (0..1); left out, a strain-wave
    (``harmonic``) gear takes the library's stated assumption
    (:func:`manipcad.catalog.efficiency.strain_wave_assumption`, recorded in
    ``assumed``) and any other gear is unknown; ``"unknown"`` keeps it
    unknown without an assumption. ``efficiency_basis`` says which
    ("printed", "printed maximum", "assumed", "unknown")."""

    type: Literal["planetary", "harmonic", "spur", "koaxdrive", "ball_screw", "rack_pinion",
                  "belt"]
    ratio: Num
    direction: Literal[1, -1] = 1
    J: Num = 0.0
    efficiency: OptNum | Literal["unknown"] = None
    stages: int | None = None
    max_continuous_torque: OptNum = None
    max_intermittent_torque: OptNum = None
    max_input_speed: OptNum = None
    stiffness: OptNum = None
    mass: OptNum = None
    rated_input_speed: OptNum = None
    max_average_torque: OptNum = None
    max_momentary_torque: OptNum = None
    max_average_input_speed: OptNum = None

    @property
    def efficiency_value(self) -> float:
        """The efficiency as a number (nan: unknown)."""
        return math.nan if self.efficiency in (None, "unknown") else float(self.efficiency)

    @property
    def efficiency_basis(self) -> str:
        """Where the efficiency comes from: "assumed", "unknown", "printed maximum"
        (a data sheet's single maximum value, e.g. MGDB's) or "printed"."""
        if "efficiency" in self.assumed:
            return "assumed"
        if math.isnan(self.efficiency_value):
            return "unknown"
        return "printed maximum" if self.key.startswith(MGDB_PREFIXES) else "printed"

    @property
    def linear(self) -> bool:
        """True when the output is a translation (ratio in rad/m)."""
        return self.type in ("ball_screw", "rack_pinion", "belt")


# --------------------------------------------------------------------------- loading


def part_file(kind: str, name: str) -> Traversable | None:
    """The built-in file of a motor or gear name (kind "motors" or "gears"), or None
    (also for a name that is a path: ``/x/motor`` or ``../x`` would lead out of the
    folder)."""
    if not name or "/" in name or "\\" in name or name.startswith("."):
        return None
    entry = PARTS / kind / f"{name}.yaml"
    return entry if entry.is_file() else None


def part_names(kind: str) -> list[str]:
    """The names of the built-in part files of a kind ("motors" or "gears"), sorted.

    Example:
        >>> "maxon_re25_118743" in part_names("motors")
        True
    """
    return sorted(p.name[:-5] for p in (PARTS / kind).iterdir() if p.name.endswith(".yaml"))


def _validate(model: type[BaseModel], data: Any, label: str) -> Any:
    if not isinstance(data, dict):
        raise InputError(label, "", "expected a mapping of keys to values "
                         f"(see docs/robot-yaml.md), got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise fileio.validation_error(label, exc, lambda err: problem(err, model)) from None


@lru_cache(maxsize=256)
def _load_spec(kind: str, file: str) -> MotorSpec | GearSpec:
    model = MotorSpec if kind == "motors" else GearSpec
    path = Path(file)
    spec = _validate(model, fileio.read_yaml(path), file)
    if isinstance(spec, GearSpec):
        if spec.ratio <= 0:
            raise InputError(file, "ratio", f"must be > 0, got {spec.ratio}")
        eta = spec.efficiency
        if isinstance(eta, float) and not 0 < eta <= 1:
            raise InputError(file, "efficiency", f"must be in (0, 1], got {eta}")
        _check_gear_ratings(spec, file)
        spec = with_assumptions(spec)
    for key in ("J", "R", "L", "k_m", "k_w", "k_v"):
        v = getattr(spec, key, None)
        if v is not None and v < 0:
            raise InputError(file, key, f"must be >= 0, got {v}")
    return spec


def with_assumptions(gear: GearSpec) -> GearSpec:
    """The gear with the library's stated assumptions filled in: a strain-wave gear
    whose source prints no efficiency (``efficiency`` left out) takes
    :func:`manipcad.catalog.efficiency.strain_wave_assumption`, recorded in
    ``assumed``; any other gear is returned as it is."""
    if gear.type != "harmonic" or gear.efficiency is not None:
        return gear
    # deferred: start-up cost: keeps manipcad.catalog.efficiency out of import manipcad
    from manipcad.catalog.efficiency import strain_wave_assumption

    eta, why = strain_wave_assumption()
    return gear.model_copy(update={"efficiency": eta,
                                   "assumed": {**gear.assumed, "efficiency": why}})


#: a gear's ratings that must come in this order where given (GearSpec docstring)
_GEAR_ORDER: tuple[tuple[str, str], ...] = (
    ("max_continuous_torque", "max_average_torque"),
    ("max_continuous_torque", "max_intermittent_torque"),
    ("max_average_torque", "max_intermittent_torque"),
    ("max_intermittent_torque", "max_momentary_torque"),
    ("max_continuous_torque", "max_momentary_torque"),
    ("max_average_input_speed", "max_input_speed"),
)


def _check_gear_ratings(spec: GearSpec, file: str) -> None:
    """Every rating given is > 0, and they come in the order of :data:`_GEAR_ORDER`
    (a transcription that swapped two columns of a rating table fails here)."""
    for key in ("max_continuous_torque", "max_average_torque", "max_intermittent_torque",
                "max_momentary_torque", "max_input_speed", "max_average_input_speed",
                "rated_input_speed", "stiffness", "mass"):
        v = getattr(spec, key)
        if v is not None and not v > 0:
            raise InputError(file, key, f"must be > 0, got {v}")
    for low, high in _GEAR_ORDER:
        a, b = getattr(spec, low), getattr(spec, high)
        if a is not None and b is not None and a > b:
            raise InputError(file, high, f"{b:g} is below {low} {a:g}: the ratings must "
                             f"come in the order rated <= average <= repeated peak <= "
                             f"momentary (torque), average <= max (input speed)")


def _resolve(kind: str, name: str, base_dir: Path | None) -> Path | None:
    if name.endswith((".yaml", ".yml")):
        p = Path(name)
        if not p.is_absolute() and base_dir is not None:
            p = base_dir / p
        return p if p.is_file() else None
    entry = part_file(kind, name)
    if entry is None:
        return None
    with resources.as_file(entry) as p:
        return Path(p)


def _unknown(kind: str, name: str) -> InputError:
    return InputError(name, "", f"unknown {kind[:-1]}; catalog {kind}: "
                      + ", ".join(part_names(kind))
                      + f" and the data-sheet parts of 'manipcad catalog list --kind "
                      f"{kind[:-1]}'")


def _nan_first(x: float) -> float:
    """Sort key putting nan below every number (so min() keeps an unknown)."""
    return -math.inf if math.isnan(x) else x


def compose_gears(gears: list[GearSpec]) -> tuple[dict[str, Any], float | None]:
    """The drive fields a gear chain sets (gears from the motor outwards).

    ``J = sum_k J_k / (i_1···i_{k-1})²`` (kg·m², motor shaft), ``ratio = prod_k
    direction_k·i_k``, ``efficiency = prod_k η_k`` (nan, unknown, when a gear's
    source gives none: the sizing then says so rather than assume η = 1), the
    output torque ratings (rated, repeated peak, average) referred to the joint
    (gear k's limit times ``prod_{m>k} i_m·η_m``, the tightest over the chain,
    N·m or N; unknown when a later gear's efficiency is) and the input-speed
    limits (max, average) referred to the motor shaft (gear k's limit times
    ``i_1···i_{k-1}``, the tightest, rad/s). A rating
    that any gear of the chain lacks is left out (unknown). A gear's assumed
    efficiency makes the chain's assumed: ``assumed`` holds
    (("efficiency", why),) then.

    Returns:
        (fields, stiffness): the :class:`Drive` fields, and the chain's
        torsional stiffness on the joint side (N·m/rad, springs in series,
        gear k's referred by ``(prod_{m>k} i_m)²``), or None unless every gear
        gives one.

    Example:
        >>> from manipcad.catalog.library import load_gear
        >>> f, k = compose_gears([load_gear("harmonic_csf20_100")])
        >>> f["ratio"], f["gear_rated_torque"]
        (-100.0, 40.0)
    """
    J = 0.0
    before = 1.0
    eta = 1.0
    ratio = 1.0
    rated, peak, speed = math.inf, math.inf, math.inf
    average, avg_speed = math.inf, math.inf
    compliance = 0.0
    for k, g in enumerate(gears):
        J += g.J / before**2
        after = 1.0
        for m in gears[k + 1:]:
            after *= m.ratio * m.efficiency_value
        after_i = math.prod(m.ratio for m in gears[k + 1:])
        # a rating one gear of the chain lacks is unknown for the chain (nan)
        rated = min(rated, math.nan if g.max_continuous_torque is None
                    else g.max_continuous_torque * after, key=_nan_first)
        peak = min(peak, math.nan if g.max_intermittent_torque is None
                   else g.max_intermittent_torque * after, key=_nan_first)
        speed = min(speed, math.nan if g.max_input_speed is None
                    else g.max_input_speed * before, key=_nan_first)
        average = min(average, math.nan if g.max_average_torque is None
                      else g.max_average_torque * after, key=_nan_first)
        avg_speed = min(avg_speed, math.nan if g.max_average_input_speed is None
                        else g.max_average_input_speed * before, key=_nan_first)
        if compliance is not None:
            compliance = (None if g.stiffness is None or g.stiffness <= 0
                          else compliance + 1.0 / (g.stiffness * after_i**2))
        eta *= g.efficiency_value
        before *= g.ratio
        ratio *= g.direction * g.ratio
    out: dict[str, Any] = {"J": J, "ratio": ratio, "efficiency": eta}
    why = sorted({g.assumed["efficiency"] for g in gears if "efficiency" in g.assumed})
    if why and not math.isnan(eta):
        out["assumed"] = (("efficiency", " ".join(why)),)
    for key, v in (("gear_rated_torque", rated), ("gear_peak_torque", peak),
                   ("gear_max_input_speed", speed), ("gear_average_torque", average),
                   ("gear_average_input_speed", avg_speed)):
        if math.isfinite(v):
            out[key] = v
    stiffness = None if not compliance else 1.0 / compliance
    return out, stiffness


__all__ = ["MotorSpec", "GearSpec", "compose_gears", "part_names", "part_file",
           "with_assumptions", "PARTS", "MGDB_PREFIXES"]
