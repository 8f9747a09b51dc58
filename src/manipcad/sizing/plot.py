"""Torque-speed plot: each motor's required operating points against its envelope.

One panel per joint, motor speed ω_m (rad/s) across, motor torque T_m = k_m·i
(N·m) up, all four quadrants (motoring and braking in both directions):

- the path (ω_m(t), T_m(t)) the trajectory needs, and its RMS point
  (RMS speed, RMS torque) with the same sign as the mean operating point;
- the continuous (rated) torque ±M_N and the peak torque ±M_peak (dashed);
- the maximum speed ±ω_max (dotted);
- the voltage limit lines T = k_m·(±U_max - k_w·ω)/R, the largest torque
  the amplifier's output voltage U_max can drive at speed ω with the
  inductance neglected (steady current): operating points must lie between
  them.

The figure is drawn on a :class:`matplotlib.figure.Figure` with the Agg
canvas (no display, no global pyplot state), written to a temporary file in
the target folder and renamed over the target, so a failed or interrupted
save leaves no partial file.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from manipcad.errors import InputError
from manipcad.fileio import atomic_write, writable_target
from manipcad.sizing.limits import voltage_limit
from manipcad.sizing.requirements import DriveRequirements


def _panel(ax, req: DriveRequirements, j: int) -> None:
    d = req.drives[j]
    name = req.joint_names[j]
    if d is None:
        ax.text(0.5, 0.5, "no drive", ha="center", va="center", transform=ax.transAxes)
        ax.set_title(name)
        ax.set_xticks([])
        ax.set_yticks([])
        return
    w = req.motor_speed[:, j]
    T = req.motor_torque[:, j]
    w_rms = float(req.rms_motor_speed[j])
    T_rms = float(req.rms_motor_torque[j])
    sw = 1.0 if np.mean(w) >= 0 else -1.0
    sT = 1.0 if np.mean(T) >= 0 else -1.0
    rated, peak_t, w_max = d.rated_torque, d.peak_torque, d.max_speed
    u_lim = voltage_limit(d)
    # axis ranges: the requirement and the known ratings, with some room
    xs = [float(np.max(np.abs(w)))] + [v for v in (w_max,) if math.isfinite(v)]
    ys = [float(np.max(np.abs(T)))] + [v for v in (rated, peak_t) if math.isfinite(v)]
    x_lim = 1.15 * max(max(xs), 1e-9)
    y_lim = 1.15 * max(max(ys), 1e-9)
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.axvline(0.0, color="0.7", lw=0.6)
    ax.plot(w, T, color="C0", lw=1.2, label="required")
    ax.plot([sw * w_rms], [sT * T_rms], "o", color="C0", ms=6, mfc="white",
            label="RMS point")
    if math.isfinite(rated):
        ax.axhline(rated, color="C2", ls="--", lw=1.0, label=f"rated {rated:.3g} N·m")
        ax.axhline(-rated, color="C2", ls="--", lw=1.0)
    if math.isfinite(peak_t):
        ax.axhline(peak_t, color="C3", ls="--", lw=1.0, label=f"peak {peak_t:.3g} N·m")
        ax.axhline(-peak_t, color="C3", ls="--", lw=1.0)
    if math.isfinite(w_max):
        ax.axvline(w_max, color="C1", ls=":", lw=1.2, label=f"max speed {w_max:.4g} rad/s")
        ax.axvline(-w_max, color="C1", ls=":", lw=1.2)
    if math.isfinite(u_lim) and d.has_electrics and d.R > 0:
        ww = np.linspace(-x_lim, x_lim, 3)
        for sgn in (1.0, -1.0):
            ax.plot(ww, d.k_m * (sgn * u_lim - d.k_w * ww) / d.R, color="C4", lw=1.0,
                    label=f"voltage limit {u_lim:.3g} V" if sgn > 0 else None)
    ax.set_xlim(-x_lim, x_lim)
    ax.set_ylim(-y_lim, y_lim)
    status = req.status[j]
    colour = {"pass": "green", "fail": "red"}.get(status, "0.4")
    motor = d.name or "(unnamed motor)"
    ax.set_title(f"{name}: {motor}, i_r = {d.ratio:.4g} [{status}]", color=colour, fontsize=9)
    ax.set_xlabel("motor speed ω_m (rad/s)")
    ax.set_ylabel("motor torque k_m·i (N·m)")
    ax.legend(fontsize=6, loc="best")
    ax.grid(True, lw=0.3)


def torque_speed_figure(req: DriveRequirements, *, dpi: int = 120):
    """Each drive's required motor torque against motor speed and the motor envelope, as a
    matplotlib Figure (saving is the caller's choice; :func:`torque_speed_plot` writes one).

    Example:
        >>> import manipcad
        >>> from manipcad.sizing import required_drive
        >>> from manipcad.sizing.plot import torque_speed_figure
        >>> from manipcad.trajectories import cosine
        >>> arm = manipcad.load_robot("cylindrical")
        >>> req = required_drive(arm, cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], 1.6))
        >>> len(torque_speed_figure(req).axes)
        3
    """
    from matplotlib.figure import Figure  # deferred: start-up cost: matplotlib loaded on first use

    fig = Figure(figsize=(5.0 * min(req.n, 3), 4.2 * math.ceil(req.n / 3)), dpi=dpi)
    cols = min(req.n, 3)
    rows = math.ceil(req.n / 3)
    axes = fig.subplots(rows, cols, squeeze=False)
    for j in range(rows * cols):
        ax = axes[j // cols][j % cols]
        if j < req.n:
            _panel(ax, req, j)
        else:
            ax.set_visible(False)
    fig.suptitle(f"{req.robot.name}: required motor torque vs speed, t_end = {req.t_end:g} s"
                 + (f", payload {req.payload_mass:g} kg" if req.payload_mass else ""))
    fig.tight_layout()
    return fig


def torque_speed_plot(req: DriveRequirements, path: str | Path, *, dpi: int = 120) -> Path:
    """Plot each drive's required motor torque against motor speed and the motor envelope.

    Args:
        req: the result of :func:`~manipcad.sizing.required_drive`.
        path: the image file to write (format from its suffix: .png, .pdf, .svg...).
        dpi: resolution for raster formats, dots per inch.

    Returns:
        The path written.

    Raises:
        InputError: the folder does not exist, or the format is not supported.

    Example:
        >>> import manipcad
        >>> from manipcad.sizing import required_drive, torque_speed_plot
        >>> from manipcad.trajectories import load_trajectory
        >>> arm = manipcad.load_robot("cylindrical")
        >>> req = required_drive(arm, load_trajectory("examples/fig3_laws.yaml"))  # doctest: +SKIP
        >>> torque_speed_plot(req, "/tmp/ts.png")  # doctest: +SKIP
        PosixPath('/tmp/ts.png')
    """
    p = writable_target(path)
    src = str(path)
    fmt = p.suffix.lower().lstrip(".")
    fig = torque_speed_figure(req, dpi=dpi)
    supported = fig.canvas.get_supported_filetypes()
    if fmt not in supported:
        raise InputError(src, "", f"unknown image format {fmt!r}; use one of "
                         f"{', '.join(sorted(supported))}")
    return atomic_write(path, lambda fh: fig.savefig(fh, format=fmt), binary=True)


def ratio_sweep_figure(sweeps):
    """The gear-ratio sweep of one or more joints as a matplotlib Figure.

    Per joint: the RMS and peak motor torque (N·m) and the peak current (A, right axis)
    against |i_r| (log scale), the feasible ratios shaded, the present ratio and the best
    one (:attr:`~manipcad.sizing.sweep.RatioSweep.best_ratio`) marked.

    Args:
        sweeps: a :class:`~manipcad.sizing.sweep.RatioSweep` or a list of them.

    Returns:
        :class:`matplotlib.figure.Figure` (saving is the caller's choice).

    Example:
        >>> import manipcad
        >>> from manipcad.sizing import ratio_sweep
        >>> from manipcad.trajectories import cosine
        >>> move = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], 1.6)
        >>> sw = ratio_sweep(manipcad.load_robot("cylindrical"), move, "turn",
        ...                  ratios=[20.0, 50.0, 100.0, 200.0])
        >>> len(ratio_sweep_figure(sw).axes)
        2
    """
    from matplotlib.figure import Figure  # deferred: start-up cost: matplotlib loaded on first use

    sweeps = sweeps if isinstance(sweeps, list | tuple) else [sweeps]
    fig = Figure(figsize=(6.0, 3.6 * len(sweeps)))
    axes = fig.subplots(len(sweeps), 1, squeeze=False)[:, 0]
    for ax, sw in zip(axes, sweeps, strict=True):
        r = sw.ratios
        ax.plot(r, sw.rms_motor_torque, label="RMS motor torque, N·m")
        ax.plot(r, sw.peak_motor_torque, label="peak motor torque, N·m")
        for lo, hi in sw.intervals:
            ax.axvspan(lo, hi, color="tab:green", alpha=0.12, lw=0)
        ax.axvline(abs(sw.ratio), color="k", lw=0.8, ls="--", label=f"present {abs(sw.ratio):.4g}")
        if math.isfinite(sw.best_ratio):
            ax.axvline(sw.best_ratio, color="tab:green", lw=1.2,
                       label=f"best {sw.best_ratio:.4g} ({sw.criterion})")
        ax.set_xscale("log")
        ax.set_xlabel("|i_r| (rad/rad, rad/m)")
        ax.set_ylabel("motor torque (N·m)")
        ax2 = ax.twinx()
        ax2.plot(r, sw.peak_current, color="tab:red", lw=0.8, label="peak current, A")
        ax2.set_ylabel("peak current (A)", color="tab:red")
        spans = ", ".join(f"[{lo:.4g}, {hi:.4g}]" for lo, hi in sw.intervals)
        feas = f"feasible (shaded) {spans}" if sw.intervals else "no feasible ratio"
        ax.set_title(f"{sw.joint}: {sw.motor or 'motor'}; {feas}", fontsize=9)
        ax.legend(fontsize=7, loc="upper center")
        ax.grid(True, lw=0.3, which="both")
    fig.tight_layout()
    return fig
