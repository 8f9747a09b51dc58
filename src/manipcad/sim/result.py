"""What a closed-loop run gives: :class:`SimulationResult`, and the errors that carry a
partial one (:class:`SimulationDiverged`, :class:`JointLimitExceeded`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from html import escape

import numpy as np

from manipcad.errors import ManipcadError
from manipcad.sim.metrics import joint_metrics


class SimulationDiverged(ManipcadError):
    """The simulation blew up; ``.result`` holds what was computed up to then."""

    def __init__(self, message: str, result: SimulationResult) -> None:
        super().__init__(message)
        self.result = result


class JointLimitExceeded(SimulationDiverged):
    """A joint left its limits (``joint_limits="stop"``); ``.result`` holds the run so far."""


@dataclass
class SimulationResult:
    """Time series and metrics of a closed-loop run (SI units).

    Attributes:
        t: (K,) times, s.
        q, qd: (K, n) joint positions (rad or m) and velocities (rad/s or m/s).
        q_ref, qd_ref: (K, n) reference positions and velocities.
        u: (K, n) regulator outputs: amplifier inputs U, V (joint torque for
            joints without a drive model).
        current: (K, n) armature currents, A (nan without a drive model).
        tau: (K, n) joint torques from the drives (plus disturbance), N·m or N.
        metrics: per joint name: max and RMS error, overshoot, rise and
            settling time (of a step), control effort, energy
            (:func:`manipcad.sim.metrics.joint_metrics`; for a result of
            :func:`simulate`, computed from its arrays when first read).
        robot: the robot's name; joint_names, joint_types: its joints ("revolute" in rad,
            "prismatic" in m; ``units`` maps each joint to its unit).
        settings: dt, t_end and the regulators' descriptions (and the pickup, the
            estimator and the model's payload when given; ``joint_limits: "hard-stop"``
            when the limits were modelled as stops).
        payload_estimate: with ``estimator=``: (M, 2), the time (s) and the online payload
            estimate (kg) after each of the estimator's samples; else None.
        checks: the run's checks against every rating, ``{joint: {check: {value, limit,
            unit, verdict}}}`` (:meth:`manipcad.sim.checks.RunChecks.to_dict`), once a
            caller has made them (``manipcad simulate``, ``verify``); else None. Saved in
            metrics.json.
        events: (E, 3) the located stick-slip switches of the lossy joints (dry friction
            or gear losses, :mod:`manipcad.sim.events`): time (s), joint index, new mode
            (+1 or -1 slipping that way, 0 stuck; +2 / -2 reaching the upper / lower hard
            stop with ``joint_limits="hard-stop"``; an elastic gear's contact as 10 + c, c
            +1 / -1 the teeth closing on that flank, 0 the gap opening; its motor shaft as
            20 + its mode, +1 / -1 sliding that way, 0 stuck); None without lossy joints,
            stops or such gears.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_ref: np.ndarray
    qd_ref: np.ndarray
    u: np.ndarray
    current: np.ndarray
    tau: np.ndarray
    joint_names: tuple[str, ...]
    robot: str = ""
    settings: dict = field(default_factory=dict)
    metrics: dict = field(default_factory=dict)
    joint_types: tuple[str, ...] = ()
    payload_estimate: np.ndarray | None = None
    checks: dict | None = None
    events: np.ndarray | None = None

    @property
    def units(self) -> dict[str, str]:
        """Unit of each joint's position ("rad" or "m"); velocities are per s, torques
        N·m or N, U in V, currents in A."""
        return {nm: ("m" if t == "prismatic" else "rad")
                for nm, t in zip(self.joint_names, self.joint_types, strict=False)}

    @property
    def error(self) -> np.ndarray:
        """Tracking error q_ref - q, rad or m, shape (K, n)."""
        return self.q_ref - self.q

    def to_dataframe(self, joint_types: Sequence[str] | None = None):
        """The time series as a :class:`pandas.DataFrame`, units in the column names.

        The index is ``t [s]``; one column per joint and quantity, ``"JOINT.QUANTITY
        [UNIT]"`` (``"waist.q [rad]"``, ``"lift.tau [N]"``), the columns of the CSV export
        (:mod:`manipcad.sim.series`). ``joint_types`` defaults to the result's own.

        Example:
            >>> import manipcad
            >>> res = manipcad.simulate(manipcad.load_robot("cylindrical"), t_end=0.01,
            ...                         dt=1e-3, drives=False)
            >>> res.to_dataframe().columns[0]
            'turn.q [rad]'
        """
        # deferred: start-up cost: pandas is 0.3-0.6 s of every command's start
        import pandas as pd

        # deferred: start-up cost: keeps manipcad.sim.series out of import manipcad
        from manipcad.sim.series import series_columns

        types = joint_types if joint_types is not None else (self.joint_types or None)
        cols = series_columns(self, types)
        return pd.DataFrame(dict(cols[1:]), index=pd.Index(np.asarray(cols[0][1]),
                                                           name="t [s]"))

    def _lazy_metrics(self, drives: bool, dtable: np.ndarray, excess: dict) -> None:
        """Compute :attr:`metrics` when first read (:func:`joint_metrics` with these
        arguments, then each joint's ``limit_excess`` of ``excess``): most callers of
        :func:`simulate` in a loop never read them."""
        self.__dict__["_metrics_of"] = (drives, dtable, excess)

    def _repr_html_(self) -> str:
        """The per-joint metrics as an HTML table (Jupyter)."""

        def cell(x) -> str:
            return "—" if x is None or (isinstance(x, float) and np.isnan(x)) else f"{x:.4g}"

        types = list(self.joint_types) or [None] * len(self.joint_names)
        rows = "".join(
            f"<tr><td>{escape(j)}</td><td>{'m' if jt == 'prismatic' else 'rad' if jt else 'rad|m'}"
            f"</td>" + "".join(f"<td>{cell((self.metrics.get(j) or {}).get(k))}</td>"
                               for k in ("max_error", "rms_error", "effort_rms", "energy"))
            + "</tr>" for j, jt in zip(self.joint_names, types, strict=True))
        t_end = float(self.t[-1]) if len(self.t) else 0.0
        return (f"<p><b>{escape(self.robot or 'result')}</b>: {len(self.t)} samples, "
                f"t = 0 … {t_end:.4g} s</p><table><thead><tr><th>joint</th><th>unit</th>"
                "<th>max |e|</th><th>RMS e</th><th>effort RMS</th><th>energy J</th></tr>"
                f"</thead><tbody>{rows}</tbody></table>")


def _get_metrics(self) -> dict:
    d = self.__dict__
    of = d.pop("_metrics_of", None)
    if of is not None:
        drives, dtable, excess = of
        m = joint_metrics(self, drives=drives, dtable=dtable)
        for nm, v in excess.items():
            m[nm]["limit_excess"] = v
        d["_metrics"] = m
    if "_metrics" not in d:  # unpickled from before the metrics were computed lazily
        d["_metrics"] = d.pop("metrics", {})
    return d["_metrics"]


def _set_metrics(self, value: dict) -> None:
    self.__dict__.pop("_metrics_of", None)
    self.__dict__["_metrics"] = value


# a property over the dataclass field (its __init__ assigns through the setter)
SimulationResult.metrics = property(_get_metrics, _set_metrics,
                                    doc="Per-joint metrics (see the class docstring).")


__all__ = ["SimulationResult", "SimulationDiverged", "JointLimitExceeded"]
