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
