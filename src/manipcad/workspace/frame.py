"""A simulation result as a pandas DataFrame (units in the column names)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def results_dataframe(result, joint_types: Sequence[str] | None = None):
    """The time series of a result as a :class:`pandas.DataFrame`.

    The index is the time ``t [s]``; one column per joint and quantity,
    named ``"JOINT.QUANTITY [UNIT]"`` (``"waist.q [rad]"``, ``"lift.tau [N]"``)
    for the quantities of :data:`manipcad.store.results.SERIES`, the same
    columns and units as the CSV export.

    Args:
        result: a :class:`manipcad.sim.SimulationResult`.
        joint_types: "revolute"/"prismatic" per joint for the units; None:
            "rad|m" style units.

    Returns:
        The DataFrame (float64, full precision).

    Example:
        >>> import numpy as np
        >>> from manipcad.sim.simulate import SimulationResult
        >>> z = np.zeros((3, 1))
        >>> res = SimulationResult(t=np.array([0.0, 0.1, 0.2]), q=z, qd=z, q_ref=z + 0.1,
        ...                        qd_ref=z, u=z, current=z, tau=z, joint_names=("lift",),
        ...                        settings={"drives": True})
        >>> df = results_dataframe(res, ["prismatic"])
        >>> df["lift.error [m]"].tolist()
        [0.1, 0.1, 0.1]
        >>> df.index.name
        't [s]'
    """
    import pandas as pd

    from manipcad.store.results import series_columns

    cols = series_columns(result, joint_types)
    return pd.DataFrame(dict(cols[1:]), index=pd.Index(np.asarray(cols[0][1]), name="t [s]"))


def result_html(result, joint_types: Sequence[str] | None = None) -> str:
    """A result's per-joint metrics as an HTML table (for ``SimulationResult._repr_html_``).

    Errors in rad or m, effort in V (N·m or N without drives), energy in J.

    Example:
        >>> import numpy as np
        >>> from manipcad.sim.simulate import SimulationResult
        >>> z = np.zeros((2, 1))
        >>> res = SimulationResult(t=np.array([0.0, 0.1]), q=z, qd=z, q_ref=z, qd_ref=z, u=z,
        ...                        current=z, tau=z, joint_names=("a",),
        ...                        metrics={"a": {"max_error": 0.0, "rms_error": 0.0}})
        >>> "max |e|" in result_html(res)
        True
    """
    from html import escape

    def cell(x) -> str:
        return "—" if x is None or (isinstance(x, float) and np.isnan(x)) else f"{x:.4g}"

    types = list(joint_types) if joint_types is not None else [None] * len(result.joint_names)
    rows = "".join(
        f"<tr><td>{escape(j)}</td><td>{'m' if jt == 'prismatic' else 'rad' if jt else 'rad|m'}"
        f"</td>" + "".join(f"<td>{cell((result.metrics.get(j) or {}).get(k))}</td>"
                           for k in ("max_error", "rms_error", "effort_rms", "energy"))
        + "</tr>" for j, jt in zip(result.joint_names, types, strict=True))
    t_end = float(result.t[-1]) if len(result.t) else 0.0
    return (f"<p><b>{escape(result.robot or 'result')}</b>: {len(result.t)} samples, "
            f"t = 0 … {t_end:.4g} s</p><table><thead><tr><th>joint</th><th>unit</th>"
            "<th>max |e|</th><th>RMS e</th><th>effort RMS</th><th>energy J</th></tr></thead>"
            f"<tbody>{rows}</tbody></table>")
