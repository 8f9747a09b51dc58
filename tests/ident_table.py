"""The closed-loop accuracy table of docs/identification.md ("Accuracy"), from the same
simulated data as tests/test_identification_sim.py::test_within_two_percent_with_friction.

Run ``python tests/ident_table.py`` (from the repository root; a few minutes on two
cores): one row per robot, the mass ± reported std (relative error) per method and signal.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

from ident_sim import SETUPS, run  # noqa: E402

from manipcad.dynamics.identification import identify_payload  # noqa: E402
from manipcad.errors import ManipcadWarning  # noqa: E402

COLUMNS = (("stops", "tau", "estimate"), ("stops", "current", "estimate"),
           ("motion", "tau", "model"), ("motion", "current", "model"),
           ("stops", "tau", "model"), ("stops", "tau", "none"))


def row(name: str) -> list[str]:
    """The table's cells for robot ``name``: the data of the test (dithered stops for the
    stops method, except on the Fig. 2 arm, whose stops are approached from both sides)."""
    cyl = name == "cylindrical"
    kw = dict(stops=20 if cyl else 14, dwell=0.8 if cyl else 0.6)
    true = SETUPS[name]["mass"]
    cells = []
    for method, signal, friction in COLUMNS:
        d = run(name, dither=0.01 if method == "stops" and not cyl else 0.0, **kw)
        s = d["setup"]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ManipcadWarning)
            est = identify_payload(d["robot"], d["q"], d["qd"], None, t=d["t"], method=method,
                                   com=s["com"], link=s["link"] or -1,
                                   **({} if method == "motion" else {"friction": friction}),
                                   **{signal: d[signal]})
        err = (est.mass / true - 1) * 100
        cells.append(f"{est.mass:.4f} ± {est.std:.4f} ({err:+.2f} %)" if friction == "estimate"
                     or method == "motion" else f"{est.mass:.4g} ({err:+.1f} %)")
    return cells


if __name__ == "__main__":
    names = sys.argv[1:] or ["puma560", "ur10", "cylindrical"]
    print("| robot | true kg | stops, torque | stops, current | motion, torque | motion, current "
          "| stops, model friction | stops, friction ignored |")
    print("|---|---|---|---|---|---|---|---|")
    for name in names:
        print(f"| {name} | {SETUPS[name]['mass']} | " + " | ".join(row(name)) + " |", flush=True)
