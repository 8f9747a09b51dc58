"""Gear efficiency where a data sheet prints none: the stated strain-wave assumption.

Harmonic Drive's CSF/CSG rating tables print no efficiency; the catalogues give
charts. The manufacturer's published model (Harmonic Drive AG, "CSD-2A Component
Sets Engineering Data", section 4.3.1; ``gears.yaml`` ``efficiency_models``) is

    η_L = η(n_in, T_amb, lubricant, ratio) · K(V),   V = T_av / T_N

with η read from a chart at rated torque and K a load-factor curve (K < 1 below
rated torque). The one machine-readable point of it is the manual's worked
example, HFUC-20-80 (a CSF-class component set): η = 0.78 at 1000 rpm input,
20 °C, grease, rated torque, and K = 0.93 at V = 0.57, so η_L = 0.73. The
library assumes that value for every strain-wave gear whose source prints no
efficiency, and says so: the value is read from the data file, not typed here.

Example:
    >>> eta, why = strain_wave_assumption()
    >>> round(eta, 4)
    0.7254
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

from manipcad import fileio

#: the data file holding the efficiency data point (beside the part files, catalog.files.PARTS)
GEARS_YAML = resources.files("manipcad") / "catalog" / "data" / "gears.yaml"


@lru_cache(maxsize=1)
def strain_wave_assumption() -> tuple[float, str]:
    """The efficiency assumed for a strain-wave gear without a printed one, and why.

    Returns:
        (η, why): η = η_chart · K (dimensionless) from the HFUC-20-80 point of
        ``gears.yaml``; ``why`` states the model, the point and its conditions.
    """
    data = fileio.read_yaml(GEARS_YAML)
    point = next(p for p in data["parts"] if str(p["id"]).startswith("HFUC-20-80"))
    eta = float(point["efficiency_at_rated_torque"]["value"])
    example = point["efficiency_at_partial_load_example"]
    conditions = str(example["conditions"])      # "T_av = 19.6 N*m (V = 0.57), K = 0.93"
    k = float(conditions.rsplit("K =", 1)[1].strip())
    why = (f"assumed η = {eta:g}·{k:g} = {eta * k:.3g}: Harmonic Drive AG's efficiency "
           f"model η_L = η(n_in, T_amb, lubricant, ratio)·K(T_av/T_N) at its one published "
           f"data point, HFUC-20-80 (η = {eta:g} at 1000 rpm input, 20 °C, grease, rated "
           f"torque; K = {k:g} at T_av/T_N = 0.57), taken for every CSF/CSG size, ratio, "
           f"speed and load; the data sheet prints no efficiency")
    return eta * k, why


__all__ = ["strain_wave_assumption", "GEARS_YAML"]
