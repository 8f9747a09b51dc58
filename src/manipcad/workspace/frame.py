"""A simulation result as a pandas DataFrame (units in the column names)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace


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
    return result.to_dataframe(joint_types)


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
    if joint_types is not None:

        result = replace(result, joint_types=tuple(joint_types))
    return result._repr_html_()
