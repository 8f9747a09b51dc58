"""Per-joint quality figures of a simulated run."""

from __future__ import annotations

import math

import numpy as np

from manipcad.drives.params import P_KU, P_UMAX


def step_metrics(t: np.ndarray, y: np.ndarray, y0: float, y_final: float,
                 settling: float = 0.02) -> dict[str, float]:
    """Rise time (10-90 %), settling time (±2 % band) and overshoot of a step response.

    Args:
        t: (K,) times, s.
        y: (K,) response, rad or m.
        y0: value before the step; y_final: the commanded value.
        settling: band around y_final as a fraction of the step.

    Returns:
        ``rise_time`` and ``settling_time`` in s (nan if never reached),
        ``overshoot`` as a fraction of the step (0 for a monotone response).
    """
    step = y_final - y0
    if step == 0:
        return {"rise_time": math.nan, "settling_time": math.nan, "overshoot": math.nan}
    s = (y - y0) / step  # normalized: 0 -> 1
    t10 = t[np.argmax(s >= 0.1)] if (s >= 0.1).any() else math.nan
    t90 = t[np.argmax(s >= 0.9)] if (s >= 0.9).any() else math.nan
    outside = np.nonzero(np.abs(s - 1.0) > settling)[0]
    if len(outside) == 0:
        ts = float(t[0])
    elif outside[-1] == len(s) - 1:
        ts = math.nan
    else:
        ts = float(t[outside[-1] + 1])
    return {"rise_time": float(t90 - t10), "settling_time": ts,
            "overshoot": float(max(0.0, s.max() - 1.0))}


def armature_voltage(u: np.ndarray, k_u, u_max) -> np.ndarray:
    """The amplifiers' output (armature) voltage of a run, u_a = clip(k_u·U, ±u_max).

    The array form of :func:`manipcad.drives.dc.amplifier_voltage`, over a run's
    stored regulator outputs.

    Args:
        u: (K, n) amplifier inputs U (a result's ``u``), V.
        k_u: (n,) amplifier gains, V/V.
        u_max: (n,) amplifier output limits, V (inf: none).

    Returns:
        (K, n) armature voltages u_a, V.

    Example:
        >>> armature_voltage(np.array([[1.0, -3.0]]), np.array([10.0, 10.0]),
        ...                  np.array([24.0, np.inf])).tolist()
        [[10.0, -30.0]]
    """
    lim = np.asarray(u_max, dtype=float)
    return np.clip(np.asarray(k_u, dtype=float) * np.asarray(u, dtype=float), -lim, lim)


def joint_metrics(res, *, drives: bool, dtable: np.ndarray) -> dict[str, dict[str, float]]:
    """Max and RMS error, step figures (when the reference is a step), effort, energy.

    Energy is the electrical energy the amplifiers deliver, ∫ u_a·i dt (J), with
    drives; otherwise the mechanical work ∫ τ·q̇ dt (J). Control effort is the
    RMS regulator output (V, or N·m).
    """
    out = {}
    e = res.error
    dt = np.diff(res.t)
    for j, name in enumerate(res.joint_names):
        m = {"max_error": float(np.abs(e[:, j]).max()),
             "rms_error": float(np.sqrt(np.mean(e[:, j] ** 2))),
             "effort_rms": float(np.sqrt(np.mean(res.u[:, j] ** 2)))}
        if drives and np.isfinite(res.current[:, j]).all():
            ua = armature_voltage(res.u[:, j], dtable[j, P_KU], dtable[j, P_UMAX])
            p = ua * res.current[:, j]
        else:
            p = res.tau[:, j] * res.qd[:, j]
        m["energy"] = float(np.sum(0.5 * (p[1:] + p[:-1]) * dt))
        ref = res.q_ref[:, j]
        if len(ref) > 2 and np.all(ref[1:] == ref[-1]) and ref[-1] != res.q[0, j]:
            m.update(step_metrics(res.t, res.q[:, j], res.q[0, j], ref[-1]))
        else:
            m.update(rise_time=math.nan, settling_time=math.nan, overshoot=math.nan)
        out[name] = m
    return out
