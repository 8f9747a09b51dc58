"""What the pages of ``manipcad ui`` do, with no web framework in sight.

Every function here is a thin call into the same Python API the CLI uses
(:func:`manipcad.load_robot`, :func:`manipcad.trajectories.trajectory_from_dict`,
:func:`manipcad.recommend`, :func:`manipcad.synthesize`, :func:`manipcad.simulate`,
:class:`manipcad.workspace.Workspace`); the pages (:mod:`manipcad.ui.pages`) only
lay these out and show their errors. Nothing here computes a formula of its own.

Robot references used by the pages: a catalog name (``puma560``) or a workspace
robot ``robots/NAME``. Names typed or uploaded by the user are checked by
:func:`manipcad.workspace.check_name` before anything touches the disk.

Units: joint coordinates rad (revolute) or m (prismatic), times s, positions m,
torques N·m (N), voltages V, currents A.
"""

from __future__ import annotations

import io
import json
import tempfile
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.control import save_regulators, synthesize
from manipcad.control.lqr import GAIN_NAMES
from manipcad.control.registry import METHODS
from manipcad.dynamics.identification import (
    check_estimate,
    identify_payload,
    load_torque_data,
    result_torque_data,
)
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.expert import Requirements, recommend
from manipcad.fileio import dump_yaml
from manipcad.kinematics.forward import stick_points, tool_pose
from manipcad.model import catalog_names, load_robot
from manipcad.model.load import referenced_files
from manipcad.model.robot import loader_notes
from manipcad.model.tree_file import save_robot
from manipcad.model.yaml_robot import DriveSpec, build_drive, load_gear, load_motor
from manipcad.report.projection import VIEW, project
from manipcad.sim.checks import RunChecks
from manipcad.sim.metrics import armature_voltage
from manipcad.sizing import ratio_sweep, torque_speed_plot
from manipcad.sizing.limits import voltage_limit
from manipcad.sizing.plot import ratio_sweep_figure
from manipcad.sizing.select import save_selection, select_drives
from manipcad.store.results import METRICS_JSON, load_result
from manipcad.trajectories import (
    gripper_speed,
    load_trajectory,
    save_trajectory,
    trajectory_from_dict,
)
from manipcad.workspace import Workspace, check_name
from manipcad.workspace.runs import COMPARE_METRICS

#: largest upload accepted, bytes (robot, trajectory, regulator files are far smaller)
MAX_UPLOAD = 2_000_000

#: upload suffixes accepted, per kind
UPLOAD_SUFFIXES = {"robots": (".urdf", ".yaml", ".yml", ".xml", ".mjcf"),
                   "trajectories": (".yaml", ".yml"), "regulators": (".yaml", ".yml")}


def open_workspace(root: str | Path) -> Workspace:
    """Open the workspace at ``root``, making it when the folder is not one yet.

    Args:
        root: the workspace folder.

    Returns:
        The opened :class:`~manipcad.workspace.Workspace`.

    Example:
        >>> import tempfile
        >>> ws = open_workspace(tempfile.mkdtemp() + "/ws")
        >>> ws.list().__len__()
        0
    """
    try:
        return Workspace(root)
    except InputError:
        return Workspace.init(root)


#: the installed package's folder (``.../manipcad``), named ``manipcad/`` on the pages
_PACKAGE = Path(__file__).resolve().parents[1]


def short_paths(text: str, ws_root: str | Path | None = None) -> str:
    """``text`` for a page: the package's install folder named ``manipcad/...`` and the
    workspace's files by their name inside it (``robots/arm.urdf``; the page's header
    names the workspace), so notes and errors show no install path.

    Args:
        text: a message (a loader's note, an error).
        ws_root: the workspace folder, or None.

    Example:
        >>> short_paths(str(_PACKAGE / "model" / "catalog" / "puma560.yaml") + ": note")
        'manipcad/model/catalog/puma560.yaml: note'
        >>> short_paths("/home/me/ws/robots/arm.urdf: joint 'j'", "/home/me/ws")
        "robots/arm.urdf: joint 'j'"
        >>> short_paths("/abs/a.yaml: bad", "/")
        '/abs/a.yaml: bad'
    """
    roots = {str(_PACKAGE): "manipcad/"}
    pkg = Path(__file__).parents[1]                    # as imported (maybe through a link)
    roots.setdefault(str(pkg), "manipcad/")
    if ws_root is not None:
        for r in (Path(ws_root), Path(ws_root).absolute(), Path(ws_root).resolve()):
            roots.setdefault(str(r), "")
    for root in sorted(roots, key=len, reverse=True):  # the longest first
        if root.strip("/.") and not root.startswith("../"):  # never "/", "." or ".."
            text = text.replace(root.rstrip("/") + "/", roots[root])
    return text


def robot_choices(ws: Workspace) -> list[str]:
    """The robots a user can pick: the catalog's names, then the workspace's ``robots/NAME``.

    Example:
        >>> import tempfile
        >>> "puma560" in robot_choices(open_workspace(tempfile.mkdtemp()))
        True
    """

    return list(catalog_names()) + [i.ref for i in ws.list("robots")]


def load_robot_ref(ws: Workspace, ref: str):
    """Load a robot by its reference (catalog name or ``robots/NAME``), data notes kept.

    Args:
        ws: the workspace.
        ref: a catalog name or a workspace robot reference.

    Returns:
        ``(robot, notes)``: the :class:`~manipcad.model.Robot` and the loader's
        warnings as strings (paths as :func:`short_paths` gives them).

    Raises:
        InputError: an unknown or unsafe reference; the loader's errors.

    Example:
        >>> import tempfile
        >>> arm, notes = load_robot_ref(open_workspace(tempfile.mkdtemp()), "cylindrical")
        >>> arm.n
        3
    """

    source = robot_source(ws, ref)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ManipcadWarning)
        robot = load_robot(source)
    return robot, [short_paths(n, ws.root) for n in loader_notes(caught, robot)]


def robot_source(ws: Workspace, ref: str) -> str:
    """What :func:`manipcad.load_robot` loads for a robot reference: a catalog name as it
    is, ``robots/NAME`` as the workspace item's file (name checked).

    Raises:
        InputError: an unknown or unsafe reference.

    Example:
        >>> import tempfile
        >>> robot_source(open_workspace(tempfile.mkdtemp()), "cylindrical")
        'cylindrical'
    """
    if ref in catalog_names():
        return ref
    kind, _, name = ref.partition("/")
    if kind != "robots":
        raise InputError("robot", "", f"{ref!r}: pick a catalog robot or robots/NAME")
    check_name(name, "robot")
    return str(ws.resolve("robots", name))


def _unit(joint_type: str) -> str:
    return "m" if joint_type == "prismatic" else "rad"


def joint_rows(robot) -> list[dict[str, Any]]:
    """One row per joint for the joints table: limits, link mass, drive, in SI units.

    Keys: ``joint``, ``type``, ``unit`` (rad or m), ``lower``, ``upper`` (rad or m),
    ``mass`` (kg), ``motor``, ``gear``, ``ratio`` (i_r), ``R`` (Ω), ``L`` (H),
    ``k_m`` (N·m/A), ``J`` (kg·m²), ``u_max`` (V). Values are rounded for display
    (4 significant digits) and strings (``-`` for no value), so they show as given.

    Example:
        >>> import manipcad
        >>> joint_rows(manipcad.load_robot("cylindrical"))[0]["unit"]
        'rad'
    """
    def num(v: float) -> str:
        v = float(v)
        return "-" if not np.isfinite(v) else f"{v:.4g}"

    rows = []
    for i, name in enumerate(robot.joint_names):
        d = robot.drives[i]
        lo, hi = robot.limits[i]
        rows.append({
            "joint": name, "type": robot.joint_types[i], "unit": _unit(robot.joint_types[i]),
            "lower": num(lo), "upper": num(hi), "mass": num(robot.mass[i]),
            "motor": (d.name or "yes") if d else "-", "gear": (d.gear or "-") if d else "-",
            "ratio": num(d.ratio) if d else "-", "R": num(d.R) if d else "-",
            "L": num(d.L) if d else "-", "k_m": num(d.k_m) if d else "-",
            "J": num(d.J) if d else "-", "u_max": num(d.u_max) if d else "-"})
    return rows


def robot_totals(robot) -> dict[str, Any]:
    """Totals shown under the joints table: joints, driven joints, moving mass (kg).

    Example:
        >>> import manipcad
        >>> robot_totals(manipcad.load_robot("cylindrical"))["joints"]
        3
    """
    return {"joints": robot.n, "driven": sum(d is not None for d in robot.drives),
            "mass_kg": float(np.sum(robot.mass))}


def slider_range(robot, j: int) -> tuple[float, float]:
    """The pose slider's range of joint ``j``: its limits, or ±π rad / ±1 m when unlimited."""
    lo, hi = (float(x) for x in robot.limits[j])
    wide = 1.0 if robot.joint_types[j] == "prismatic" else float(np.pi)
    return (lo if np.isfinite(lo) else -wide, hi if np.isfinite(hi) else wide)


def start_pose(robot) -> np.ndarray:
    """The pose the Robots page opens at, (n,) rad|m: each joint at 0 where 0 is within
    its limits, else at the middle of its slider's range (:func:`slider_range`), so the
    arm is drawn in a pose it can take and the sliders show that pose.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> [float(x) for x in arm.limits[1]], [round(float(x), 3) for x in start_pose(arm)]
        ([0.0, 0.6], [0.0, 0.0, 0.0])
        >>> low = arm.replace(limits=np.array([[-1.0, 1.0], [0.1, 0.6], [0.0, 0.5]]))
        >>> [round(float(x), 3) for x in start_pose(low)]
        [0.0, 0.35, 0.0]
    """
    q = np.zeros(robot.n)
    for j in range(robot.n):
        lo, hi = (float(x) for x in robot.limits[j])
        if not lo <= 0.0 <= hi:
            a, b = slider_range(robot, j)
            q[j] = 0.5 * (a + b)
    return q


def tool_position(robot, q: Sequence[float]) -> np.ndarray:
    """The tool (gripper) point at pose ``q`` (rad|m) in the base frame, (3,) m.

    Example:
        >>> import manipcad
        >>> tool_position(manipcad.load_robot("puma560"), [0.0] * 6).shape
        (3,)
    """
    return tool_pose(robot, np.asarray(q, dtype=float))[:3, 3]


#: the projected view's hover text: the point's name and base-frame position
_WHERE = ("%{text}<br>x, y, z = %{customdata[0]:.3f}, %{customdata[1]:.3f}, "
          "%{customdata[2]:.3f} m<extra></extra>")


def stick_view(robot, q: Sequence[float], azimuth: float = VIEW[0],
               elevation: float = VIEW[1]) -> dict[str, Any]:
    """The arm's 3-D stick figure (:func:`stick_points`) at pose ``q`` as an orthographic
    projection: a 2-D Plotly figure (a dict), drawn as SVG, which a browser draws in
    tens of ms where the WebGL scene of :func:`stick_figure` takes seconds in software.

    Drawn: the links with a marker at each joint and the gripper point (hover: the
    name and the base-frame position, m), the base frame's x, y, z axes and the floor
    z = 0 as a square grid, both sized to the arm; screen axes in m, equal scale.

    Args:
        robot: the robot.
        q: (n,) joint coordinates, rad or m.
        azimuth, elevation: the view, rad (:func:`view_axes`).

    Returns:
        ``{"data": [...], "layout": {...}}``: traces floor, arm, x, y, z axes, gripper.

    Example:
        >>> import manipcad
        >>> fig = stick_view(manipcad.load_robot("cylindrical"), [0.0, 0.3, 0.2])
        >>> [t["name"] for t in fig["data"]]
        ['floor z = 0', 'arm', 'x (base)', 'y (base)', 'z (base)', 'gripper']
    """
    segs = stick_points(robot, q)
    reach = max(float(np.linalg.norm(segs[:, 1] - segs[:, 0], axis=-1).sum()), 0.1)
    half = 0.6 * reach                              # floor and axes, sized to the arm
    grid = np.linspace(-half, half, 5)
    floor = []
    for g in grid:
        floor += [(g, -half, 0.0), (g, half, 0.0), None, (-half, g, 0.0), (half, g, 0.0), None]

    def line(pts):
        xy = [None if p is None else project(p, azimuth, elevation) for p in pts]
        return ([None if p is None else float(p[0]) for p in xy],
                [None if p is None else float(p[1]) for p in xy])

    fu, fv = line(floor)
    data: list[dict[str, Any]] = [{"type": "scatter", "mode": "lines", "x": fu, "y": fv,
                                   "name": "floor z = 0", "hoverinfo": "skip",
                                   "line": {"color": "#d0d0d0", "width": 1}}]
    names = ["base"] + list(robot.joint_names)
    arm, labels = [], []
    for i in range(robot.n):                        # parent's origin to the joint's own
        arm += [segs[i, 0], segs[i, 1], None]
        labels += [names[int(robot.parent[i]) + 1], names[i + 1], None]
    u, v = line(arm)
    data.append({"type": "scatter", "mode": "lines+markers", "x": u, "y": v, "name": "arm",
                 "text": labels,
                 "customdata": [None if p is None else [float(c) for c in p] for p in arm],
                 "hovertemplate": _WHERE, "line": {"color": "#444", "width": 6},
                 "marker": {"size": 8}})
    for k, (axis, colour) in enumerate(zip("xyz", ("#d62728", "#2ca02c", "#1f77b4"),
                                           strict=True)):
        tip = np.zeros(3)
        tip[k] = 0.4 * reach
        u, v = line([np.zeros(3), tip])
        data.append({"type": "scatter", "mode": "lines+text", "x": u, "y": v,
                     "text": ["", axis], "textposition": "top center", "name": f"{axis} (base)",
                     "hoverinfo": "skip", "line": {"color": colour, "width": 2}})
    tool = segs[-1, 1]
    u, v = line([segs[-1, 0], tool])
    data.append({"type": "scatter", "mode": "lines+markers", "x": u, "y": v,
                 "name": "gripper", "text": [names[-1], "gripper"],
                 "customdata": [[float(c) for c in segs[-1, 0]], [float(c) for c in tool]],
                 "hovertemplate": _WHERE, "line": {"color": "#ff7f0e", "width": 6},
                 "marker": {"size": [0, 12], "symbol": "diamond"}})
    return {"data": data, "layout": {
        "title": {"text": f"{robot.name} at q = [{', '.join(f'{x:.2f}' for x in q)}]; "
                          f"view azimuth {np.degrees(azimuth):.0f}°, elevation "
                          f"{np.degrees(elevation):.0f}°", "font": {"size": 13}},
        "xaxis": {"title": {"text": "screen right [m]"}, "zeroline": False},
        "yaxis": {"title": {"text": "screen up [m]"}, "zeroline": False,
                  "scaleanchor": "x", "scaleratio": 1},
        "showlegend": False, "margin": {"l": 50, "r": 10, "t": 40, "b": 40},
        "height": 440}, "config": {"displaylogo": False}}


def stick_figure(robot, q: Sequence[float]):
    """A Plotly 3-D figure of :func:`stick_points` (axes in m, equal scale): the
    interactive WebGL view (turned with the mouse), drawn on demand."""
    import plotly.graph_objects as go  # deferred: start-up cost: plotly loaded on first use

    segs = stick_points(robot, q)
    xs, ys, zs = [], [], []
    for a, b in segs:
        xs += [a[0], b[0], None]
        ys += [a[1], b[1], None]
        zs += [a[2], b[2], None]
    fig = go.Figure(go.Scatter3d(x=xs, y=ys, z=zs, mode="lines+markers",
                                 line={"width": 8}, marker={"size": 4}, name=robot.name))
    fig.update_layout(scene={"aspectmode": "data", "xaxis_title": "x [m]",
                             "yaxis_title": "y [m]", "zaxis_title": "z [m]"},
                      margin={"l": 0, "r": 0, "t": 30, "b": 0}, height=420,
                      title=f"{robot.name} at q = [{', '.join(f'{v:.2f}' for v in q)}]")
    return fig


def add_upload(ws: Workspace, filename: str, data: bytes, *, kind: str, name: str | None = None,
               robot=None):
    """Store an uploaded file in the workspace, validated by the loaders everything uses.

    Args:
        ws: the workspace.
        filename: the name the browser sent (only its suffix is used).
        data: the file's bytes (at most :data:`MAX_UPLOAD`).
        kind: robots, trajectories or regulators.
        name: the item's name; None: the file name's stem.
        robot: for a regulator, the robot to check it against.

    Returns:
        The new :class:`~manipcad.workspace.Item`.

    Raises:
        InputError: too big, a suffix not accepted, an unsafe name, a robot file that
            names other files (read from outside the workspace otherwise), or the
            loader's error (file, field, reason) naming the uploaded file.
    """
    base = Path(filename or "").name
    if len(data) > MAX_UPLOAD:
        raise InputError(base or "upload", "", f"{len(data)} bytes: larger than the "
                         f"{MAX_UPLOAD} bytes accepted")
    suffix = Path(base).suffix.lower()
    if suffix not in UPLOAD_SUFFIXES[kind]:
        raise InputError(base or "upload", "", f"a {kind[:-1]} file ends in "
                         f"{', '.join(UPLOAD_SUFFIXES[kind])}, not {suffix or 'nothing'!r}")
    item_name = check_name(name or Path(base).stem, "name")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{item_name}{suffix}"
        path.write_bytes(data)
        try:
            if kind == "robots":
                _self_contained(path)
            return ws.add(path, kind=kind, name=item_name, robot=robot)
        except InputError as exc:
            # name the file as the user knows it, not the temporary copy
            raise InputError(base, exc.field, exc.reason.replace(str(path), base)) from None


def _self_contained(path: Path) -> None:
    """Refuse an uploaded robot file that names other files (a URDF, motor or gear file,
    an MJCF include, mesh or texture): those would be read from wherever they point,
    outside the workspace (:func:`manipcad.model.load.referenced_files`).

    Raises:
        InputError: naming the field and the file it names.
    """

    refs = referenced_files(path)
    if refs:
        field, ref = refs[0]
        raise InputError(str(path), field, f"names the file {ref!r}: an uploaded robot file "
                         "must stand alone (catalog motors and gears by name, no URDF, "
                         "include, mesh or texture files); add robots that need their own "
                         "files with `manipcad ws add`")


def make_trajectory(form: Mapping[str, Any], robot):
    """Build a trajectory from the page's form through the trajectory file schema.

    Args:
        form: the fields of a trajectory file (``type`` and the law's fields).
        robot: the robot (its joint count is checked; line/circle paths use it).

    Returns:
        The :class:`~manipcad.trajectories.Trajectory`.

    Raises:
        InputError: naming ``trajectory form``, the field and the reason.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> make_trajectory({"type": "quintic", "q_start": [0, 0, 0],
        ...                  "q_end": [1.0, 0.1, 0.2], "duration": 1.0}, arm).duration
        1.0
    """

    traj = trajectory_from_dict(dict(form), "trajectory form", robot=robot)
    if traj.n != robot.n:
        raise InputError("trajectory form", "", f"has {traj.n} joints, robot {robot.name!r} "
                         f"has {robot.n}")
    return traj


def trajectory_preview(traj, robot, samples: int = 201) -> dict[str, Any]:
    """Joint positions and the gripper speed along a trajectory, for the preview plot.

    Returns:
        ``{"t": (K,) s, "q": (K, n) rad|m, "qd": (K, n), "speed": (K,) m/s}``.
    """

    duration = float(traj.duration) if np.isfinite(traj.duration) else 1.0
    t = np.linspace(0.0, duration, samples)
    q, qd, _ = traj.sample(t)
    return {"t": t, "q": q, "qd": qd, "speed": gripper_speed(robot, traj, t)}


def save_trajectory_to(ws: Workspace, traj, name: str, *, force: bool = False):
    """Save a trajectory into the workspace as ``trajectories/NAME`` (the file schema)."""

    check_name(name, "name")
    with tempfile.TemporaryDirectory() as tmp:
        path = save_trajectory(traj, Path(tmp) / f"{name}.yaml")
        return ws.add(path, kind="trajectories", name=name, force=force)


def load_trajectory_ref(ws: Workspace, name: str, robot):
    """Load ``trajectories/NAME`` from the workspace (name checked)."""

    check_name(name, "trajectory")
    return load_trajectory(ws.resolve("trajectories", name), robot=robot)


def recommend_for(form: Mapping[str, Any], robot=None, trajectory=None, *,
                  verify: bool = False):
    """The recommended methods for the requirement form (the expert system's ranking).

    Args:
        form: requirement fields (:class:`manipcad.expert.Requirements`); empty
            values are left out (derived from the robot and trajectory when they can be).
        robot, trajectory: to derive the fields left out.
        verify: synthesize the top candidates, simulate them along the trajectory
            and re-rank by the measured error (``manipcad recommend --verify``).

    Returns:
        :class:`manipcad.expert.Recommendations`.

    Raises:
        InputError: a bad field (naming ``requirements form``, the field and why);
            the expert system's incomplete/contradictory errors.
    """

    data = {k: v for k, v in form.items() if v not in (None, "")}
    if "transmission" in data:
        data["transmission"] = {k: v for k, v in data["transmission"].items()
                                if v not in (None, "")}
    req = Requirements.from_dict(data, "requirements form")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return recommend(req, robot, trajectory, verify=verify)


def synthesize_to(ws: Workspace, robot, method: str, *, joints: str | Sequence = "all",
                  spec: Mapping[str, float] | None = None, period: float | None = None,
                  name: str, force: bool = False):
    """Synthesize regulators and save them as ``regulators/NAME`` in the workspace.

    Args:
        ws: the workspace.
        robot: the robot (with drives).
        method: a registry method name (``manipcad synthesize --list``).
        joints: ``"all"`` or joint names/indices.
        spec: the method's spec (e.g. ``{"bandwidth": 30.0}`` rad/s).
        period: the regulators' sampling period, s (None: the method's default).
        name: the workspace name of the regulator file.
        force: replace a regulator of that name.

    Returns:
        ``(regulators, item)``: the list of :class:`~manipcad.control.Regulator` and
        the workspace item.
    """

    check_name(name, "name")
    options = {} if period is None else {"period": float(period)}
    regs = synthesize(robot, list(joints) if joints != "all" else "all", method,
                      spec=dict(spec) if spec else None, **options)
    regs = regs if isinstance(regs, list) else [regs]
    with tempfile.TemporaryDirectory() as tmp:
        path = save_regulators(regs, Path(tmp) / f"{name}.yaml")
        item = ws.add(path, kind="regulators", name=name, force=force, robot=robot)
    return regs, item


def methods() -> list[str]:
    """The registry's synthesis method names."""

    return list(METHODS)


def result_rows(ws: Workspace, where: str | None = None) -> list[dict[str, Any]]:
    """Stored results with their key metrics (largest over the joints), for the table.

    Args:
        ws: the workspace.
        where: a ``ws list --where`` filter (e.g. ``max_error<1e-3``), or None.

    Returns:
        One dict per result: name, status, created and the metrics (SI units).

    Raises:
        InputError: a bad filter (naming ``where``).
    """

    rows = []
    for item in ws.list("results", where=where or None):
        row = {"name": item.name, "status": item.status or "", "created": item.created}
        fails, unknowns = item.metrics.get("fails"), item.metrics.get("unknowns")
        row["checks"] = ("" if fails is None else f"fail ({int(fails)})" if fails
                         else "unknown" if unknowns else "pass")
        for m, _ in COMPARE_METRICS:
            v = item.metrics.get(m)
            row[m] = None if v is None else float(f"{v:.4g}")
        rows.append(row)
    return rows


def check_rows(ws: Workspace, name: str) -> tuple[list[dict[str, Any]], str]:
    """A stored result's run checks (docs/checks.md) as table rows, and its one-line verdict.

    Args:
        ws: the workspace.
        name: the result's name.

    Returns:
        (rows ``{joint, check, value, limit, unit, verdict}`` with numbers rounded to 4
        digits and "fail" marked "✗ fail", the summary line); ([], "") for a result
        stored without checks.
    """

    doc = json.loads((ws.path(ws.get(f"results/{name}")) / METRICS_JSON).read_text())
    if not isinstance(doc.get("checks"), dict):
        return [], ""
    checks = RunChecks.from_dict(doc["checks"])

    def num(x):
        return None if x is None else float(f"{x:.4g}")
    rows = [{**r, "value": num(r["value"]), "limit": num(r["limit"]),
             "verdict": "✗ fail" if r["verdict"] == "fail" else r["verdict"]}
            for r in checks.rows()]
    return rows, checks.summary()


def overlay_figure(ws: Workspace, names: Sequence[str], quantity: str = "error"):
    """One Plotly figure of a quantity of several stored results, a panel per joint.

    Args:
        ws: the workspace.
        names: result names (checked).
        quantity: a stored series (error, q, u, current, tau) or one of the drives'
            (voltage, power: :func:`result_series`).

    Returns:
        A ``plotly.graph_objects.Figure``.
    """
    import plotly.graph_objects as go  # deferred: start-up cost: plotly loaded on first use
    from plotly.subplots import make_subplots  # deferred: start-up cost: plotly loaded on first use


    loaded = []
    for name in names:
        check_name(name, "result")
        item = ws.get(f"results/{name}")
        res, _doc = load_result(ws.path(item))
        loaded.append((name, res, ws.path(item)))
    if not loaded:
        return go.Figure()
    joints = list(loaded[0][1].joint_names)
    fig = make_subplots(rows=len(joints), cols=1, shared_xaxes=True, subplot_titles=joints,
                        vertical_spacing=0.03)
    palette = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
               "#7f7f7f", "#bcbd22", "#17becf")
    for r, (name, res, folder) in enumerate(loaded):
        y = result_series(res, quantity, folder)
        for k, jn in enumerate(joints):
            if jn not in res.joint_names:
                continue
            col = list(res.joint_names).index(jn)
            fig.add_trace(go.Scatter(x=res.t, y=y[:, col], mode="lines", name=name,
                                     line={"color": palette[r % len(palette)]},
                                     legendgroup=name, showlegend=k == 0), row=k + 1, col=1)
    fig.update_layout(height=160 * len(joints) + 80, margin={"l": 40, "r": 10, "t": 40,
                                                             "b": 30},
                      title=f"{quantity} of {', '.join(names)} (SI units: rad|m, V, A, N·m)")
    fig.update_xaxes(title_text="t [s]", row=len(joints), col=1)
    return fig


#: series a result figure can show: name -> (what, unit)
RESULT_SERIES = {"error": ("tracking error q_ref − q", "rad|m"),
                 "tau": ("joint torque", "N·m|N"), "current": ("armature current", "A"),
                 "voltage": ("armature voltage u_a", "V"),
                 "power": ("electrical power u_a·i", "W"), "u": ("regulator output U", "V"),
                 "q": ("position", "rad|m")}


def result_series(res, quantity: str, folder: str | Path | None = None) -> np.ndarray:
    """One (K, n) series of a stored result, SI units (:data:`RESULT_SERIES`).

    ``voltage`` is the armature voltage u_a = clip(k_u·U, ±u_max)
    (:func:`manipcad.sim.metrics.armature_voltage`, the one the run's energy metric
    uses) with the drives of the robot as it ran (``folder/inputs/robot.yaml``, saved
    with every result); ``power`` is u_a·i, the electrical power the amplifier delivers
    (the integrand of the ``energy`` metric). Joints without a drive give nan.

    Raises:
        InputError: an unknown quantity, or voltage/power of a result stored without
            its robot.
    """
    if quantity not in RESULT_SERIES:
        raise InputError("quantity", "", f"{quantity!r}: expected one of "
                         f"{', '.join(RESULT_SERIES)}")
    if quantity not in ("voltage", "power"):
        return np.asarray(getattr(res, quantity))

    path = Path(folder or "") / "inputs" / "robot.yaml"
    if folder is None or not path.is_file():
        raise InputError(str(folder or "result"), "inputs/robot.yaml", "the result was stored "
                         "without its robot: its voltages and powers are not known")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = load_robot(path)
    idx = [list(arm.joint_names).index(jn) for jn in res.joint_names]
    drives = [arm.drives[i] if arm.drives else None for i in idx]
    nan = float("nan")
    k_u = np.array([d.k_u if d is not None else nan for d in drives])
    u_max = np.array([d.u_max if d is not None else nan for d in drives])
    ua = armature_voltage(res.u, k_u, u_max)
    return ua if quantity == "voltage" else ua * np.asarray(res.current)


def series_figure(t, y, labels: Sequence[str], title: str, yunit: str):
    """A Plotly figure of columns of ``y`` (K, m) against ``t`` (K,) s."""
    import plotly.graph_objects as go  # deferred: start-up cost: plotly loaded on first use

    fig = go.Figure([go.Scatter(x=np.asarray(t), y=np.asarray(y)[:, k], mode="lines",
                                name=lab) for k, lab in enumerate(labels)])
    fig.update_layout(title=title, xaxis_title="t [s]", yaxis_title=yunit, height=320,
                      margin={"l": 40, "r": 10, "t": 40, "b": 30})
    return fig


# ---------------------------------------------------------------- drives and identification
def drive_rows(req) -> list[dict[str, Any]]:
    """One row per joint of :func:`manipcad.required_drive`'s summary, for the Drives table.

    Keys (units): joint, peak_torque / rms_torque (N·m|N, joint side), peak_motor_speed
    (rad/s), peak_motor_torque (N·m), peak_current / rms_current (A), peak_voltage (V),
    peak_elec_power (W), status (pass, fail, unknown over the motor and gear limits).
    """
    def num(v: float) -> str:
        return "-" if not np.isfinite(v) else f"{float(v):.4g}"

    keys = ("peak_torque", "rms_torque", "peak_motor_speed", "peak_motor_torque",
            "peak_current", "rms_current", "peak_voltage", "peak_elec_power")
    return [{"joint": name, **{k: num(getattr(req, k)[j]) for k in keys},
             "status": req.status[j]} for j, name in enumerate(req.joint_names)]


def torque_speed_png(req) -> bytes:
    """The torque-speed figure of :func:`manipcad.torque_speed_plot` (the motors'
    envelopes and the required points), as PNG bytes for the page."""

    with tempfile.TemporaryDirectory() as tmp:
        return torque_speed_plot(req, Path(tmp) / "torque-speed.png").read_bytes()


def identify_upload(robot, filename: str, data: bytes, *, com: Sequence[float] | None = None):
    """Identify the payload mass from an uploaded CSV of measured torques or currents.

    Args:
        robot: the robot that carried the payload.
        filename: the browser's file name (its suffix must be .csv).
        data: the CSV bytes (``manipcad identify``'s format: t, q1.., qd1.., qdd1..,
            tau1.. or current1..; at most :data:`MAX_UPLOAD` bytes).
        com: the payload's centre of mass in the last link's frame, m (None: its origin).

    Returns:
        :class:`manipcad.PayloadEstimate` (mass kg with its standard deviation).

    Raises:
        InputError: too big, not .csv, or the loader's error naming the file.
    """

    base = Path(filename or "").name or "upload.csv"
    if len(data) > MAX_UPLOAD:
        raise InputError(base, "", f"{len(data)} bytes: larger than the {MAX_UPLOAD} bytes "
                         "accepted")
    if Path(base).suffix.lower() != ".csv":
        raise InputError(base, "", "measured data is a .csv file (manipcad identify's format)")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / base
        path.write_bytes(data)
        try:
            d = load_torque_data(path, robot)
        except InputError as exc:
            raise InputError(base, exc.field, exc.reason.replace(str(path), base)) from None
    if d.tau is None and d.current is None:
        raise InputError(base, "", "no tau1.. or current1.. columns")
    return _identify(robot, d, base, com)


def _identify(robot, d, source: str, com: Sequence[float] | None):
    """:func:`~manipcad.dynamics.identification.identify_payload` on measured data ``d``
    (a :class:`~manipcad.dynamics.identification.TorqueData`): its torques, else its
    currents; a nan estimate refused naming ``source``."""

    kw = {"tau": d.tau} if d.tau is not None else {"current": d.current}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return check_estimate(identify_payload(robot, d.q, d.qd, d.qdd, t=d.t, com=com, **kw),
                              source)


def identify_result(ws: Workspace, name: str, robot, *, com: Sequence[float] | None = None):
    """Identify the payload mass from a stored simulation result: its recorded positions,
    velocities and joint torques are the measured data (``manipcad identify ROBOT --data
    RESULT``).

    Args:
        ws: the workspace.
        name: the result's name (``results/NAME`` or NAME).
        robot: the robot without the payload; its joints must be the result's.
        com: the payload's centre of mass in the last link's frame, m (None: its origin).

    Returns:
        :class:`manipcad.PayloadEstimate` (mass kg with its standard deviation).

    Raises:
        InputError: no such result, other joints, data that determine no estimate.
    """

    name = name.removeprefix("results/")
    check_name(name, "result")
    folder = ws.resolve("results", name)
    res, _ = load_result(folder)
    return _identify(robot, result_torque_data(res, robot, f"results/{name}"),
                     f"results/{name}", com)


def result_names(ws: Workspace) -> list[str]:
    """The stored simulation results, by name (``ws list results``), for a choice."""
    return [i.name for i in ws.list("results")]


#: files of a study folder the application serves (reports and figures)
STUDY_SUFFIXES = (".html", ".png", ".svg", ".json", ".csv", ".md", ".pdf")


def study_files(ws: Workspace, name: str) -> list[str]:
    """The report and figure files directly in ``studies/NAME`` (sorted), for links.

    Raises:
        InputError: an unsafe or unknown name.
    """
    check_name(name, "study")
    folder = ws.path(ws.get(f"studies/{name}"))
    return sorted(p.name for p in folder.iterdir()
                  if p.is_file() and not p.is_symlink() and p.suffix.lower() in STUDY_SUFFIXES)


def study_file(ws: Workspace, name: str, file: str) -> Path:
    """The path of one file of ``studies/NAME``: both names checked, only the files
    :func:`study_files` lists (no sub-folders, no links, no other suffixes).

    Raises:
        InputError: an unsafe name, an unknown study, or a file it does not list.
    """
    check_name(file, "file")
    if file not in study_files(ws, name):
        raise InputError(f"studies/{name}", file, "no such report or figure file")
    return ws.path(ws.get(f"studies/{name}")) / file


# ---------------------------------------------------------------- motor and gear libraries
#: the motor fields of the page's form: (file key, unit, label); the motor file's schema
#: (:class:`manipcad.model.yaml_robot.MotorSpec`) checks them
MOTOR_FIELDS = (("J", "kg·m²", "rotor inertia J"), ("R", "Ω", "armature resistance R"),
                ("L", "H", "armature inductance L"), ("k_m", "N·m/A", "torque constant k_m"),
                ("k_w", "V·s/rad", "back-EMF constant k_w"),
                ("k_v", "N·m·s/rad", "viscous friction k_v"),
                ("M_f", "N·m", "dry friction M_f (one value or +, −)"),
                ("rated_torque", "N·m", "rated (continuous) torque"),
                ("peak_torque", "N·m", "peak torque"), ("max_speed", "rad/s", "max speed"),
                ("rated_voltage", "V", "rated voltage"), ("rated_current", "A", "rated current"))
#: the gear fields of the form (:class:`manipcad.model.yaml_robot.GearSpec`); ``type`` is text
GEAR_FIELDS = (("ratio", "rad/rad (rad/m linear)", "ratio i"),
               ("direction", "±1", "direction"), ("J", "kg·m²", "input-side inertia J"),
               ("efficiency", "-", "efficiency η"),
               ("max_continuous_torque", "N·m (N)", "rated output torque"),
               ("max_intermittent_torque", "N·m (N)", "peak output torque"),
               ("max_input_speed", "rad/s", "max input speed"),
               ("stiffness", "N·m/rad (N/m)", "torsional stiffness"))
GEAR_TYPES = ("planetary", "harmonic", "spur", "ball_screw", "rack_pinion", "belt")


def part_source(ws: Workspace, kind: str, ref: str) -> str:
    """The loader's argument for a motor or gear reference: a catalog name as it is, or
    ``motors/NAME`` / ``gears/NAME`` as the workspace file's path (name checked).

    Raises:
        InputError: an unknown kind of reference or an unsafe name.

    Example:
        >>> import tempfile
        >>> part_source(open_workspace(tempfile.mkdtemp()), "motors", "maxon_re40_148877")
        'maxon_re40_148877'
    """
    if ref in catalog_names(kind):
        return ref
    head, _, name = ref.partition("/")
    if head != kind:
        raise InputError(kind[:-1], "", f"{ref!r}: pick a catalog {kind[:-1]} or {kind}/NAME")
    check_name(name, kind[:-1])
    return str(ws.resolve(kind, name))


def library_rows(ws: Workspace, kind: str) -> list[dict[str, Any]]:
    """The motors or gears a designer can pick: the catalog's, then the workspace's own
    (``kind/NAME``), each loaded by :func:`~manipcad.model.yaml_robot.load_motor` /
    :func:`~manipcad.model.yaml_robot.load_gear` (as ``manipcad robots list --ws``).

    Args:
        ws: the workspace.
        kind: "motors" or "gears".

    Returns:
        One dict per part: ``ref`` (what to pick), ``origin`` (catalog or workspace) and
        the fields of :data:`MOTOR_FIELDS` / :data:`GEAR_FIELDS` in SI units, as display
        strings (``-`` unknown).

    Example:
        >>> import tempfile
        >>> rows = library_rows(open_workspace(tempfile.mkdtemp()), "gears")
        >>> rows[0]["origin"], "ratio" in rows[0]
        ('catalog', True)
    """
    if kind not in ("motors", "gears"):
        raise InputError("library", "", f"{kind!r}: expected motors or gears")
    load = load_motor if kind == "motors" else load_gear
    keys = [k for k, _, _ in (MOTOR_FIELDS if kind == "motors" else GEAR_FIELDS)]
    refs = [(n, "catalog") for n in catalog_names(kind)] + \
        [(i.ref, "workspace") for i in ws.list(kind)]
    rows = []
    for ref, origin in refs:
        spec = load(part_source(ws, kind, ref))
        row: dict[str, Any] = {"ref": ref, "origin": origin}
        if kind == "gears":
            row["type"] = spec.type
        for k in keys:
            v = getattr(spec, k)
            if k == "efficiency" and v == "unknown":   # a file's "efficiency: unknown"
                v = None
            row[k] = "-" if v is None else (", ".join(f"{x:.4g}" for x in v)
                                            if isinstance(v, tuple) else f"{float(v):.4g}")
        rows.append(row)
    return rows


def add_part(ws: Workspace, kind: str, name: str, form: Mapping[str, Any], *,
             source: str = "", force: bool = False):
    """Save a motor or gear of one's own into the workspace (``motors/NAME`` or
    ``gears/NAME``), checked by the loader every motor and gear file goes through.

    Args:
        ws: the workspace.
        kind: "motors" or "gears".
        name: the part's name.
        form: the file's fields (SI units, :data:`MOTOR_FIELDS` / :data:`GEAR_FIELDS`,
            and ``type`` for a gear); empty values are left out.
        source: where the numbers come from (a data sheet); required by the schema.
        force: replace a part of that name.

    Returns:
        The workspace :class:`~manipcad.workspace.Item`.

    Raises:
        InputError: naming ``motors/NAME`` or ``gears/NAME``, the field and the reason.

    Example:
        >>> import tempfile
        >>> ws = open_workspace(tempfile.mkdtemp())
        >>> add_part(ws, "gears", "g50", {"type": "planetary", "ratio": 50.0},
        ...          source="test").ref
        'gears/g50'
    """

    if kind not in ("motors", "gears"):
        raise InputError("library", "", f"{kind!r}: expected motors or gears")
    check_name(name, "name")
    data: dict[str, Any] = {"source": source or ""}
    data.update({k: v for k, v in form.items() if v not in (None, "", [])})
    label = f"{kind}/{name}"
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{name}.yaml"
        path.write_text(f"# {kind[:-1]} file (SI units, docs/robot-files.md)\n"
                        + dump_yaml(data, sort_keys=False, allow_unicode=True),
                        encoding="utf-8")
        try:
            return ws.add(path, kind=kind, name=name, force=force)
        except InputError as exc:
            raise InputError(label, exc.field, exc.reason.replace(str(path), label)) from None


def attach_drive(ws: Workspace, robot, joint: int | str, motor: str, gears: Sequence[str], *,
                 name: str, force: bool = False):
    """Give a joint of a robot the drive of a motor and a gear chain, and save the robot
    into the workspace as ``robots/NAME`` (its tree form, :func:`save_robot`).

    The drive is composed by the robot files' own rule
    (:func:`manipcad.model.yaml_robot.build_drive`, as ``drive: {motor: M, gear: [G]}``):
    J of the motor plus the gears', ratio the product of the gears', electrical data and
    ratings from the motor, efficiency and gear ratings referred to the joint.

    Args:
        ws: the workspace.
        robot: the robot.
        joint: the joint, index or name.
        motor: a catalog motor name or ``motors/NAME``.
        gears: catalog gear names or ``gears/NAME``, from the motor outwards (may be empty).
        name: the saved robot's name.
        force: replace a robot of that name.

    Returns:
        ``(robot, item)``: the new :class:`~manipcad.model.Robot` and the workspace item.

    Raises:
        InputError: an unknown joint, motor or gear (naming the drive form's field).

    Example:
        >>> import manipcad, tempfile
        >>> ws = open_workspace(tempfile.mkdtemp())
        >>> arm, item = attach_drive(ws, manipcad.load_robot("cylindrical"), "turn",
        ...                          "maxon_re40_148877", ["maxon_gp42c_43"], name="arm2")
        >>> item.ref, arm.drives[0].gear
        ('robots/arm2', 'maxon_gp42c_43')
    """

    check_name(name, "name")
    try:
        j = robot.joint_index(joint)
    except (IndexError, KeyError, ValueError, ManipcadError) as exc:
        raise InputError("drive form", "joint", str(exc)) from None
    if not motor:
        raise InputError("drive form", "motor", "pick a motor")
    spec = DriveSpec(motor=part_source(ws, "motors", motor),
                     gear=[part_source(ws, "gears", g) for g in gears] or None)
    drive = build_drive(spec, "drive form", f"joints[{j}].drive")
    # label the parts by the names the designer picked, not by their file paths
    drive = drive.replace(name=motor, gear=" + ".join(gears))
    drives = list(robot.drives) if robot.drives else [None] * robot.n
    drives[j] = drive
    new = robot.replace(drives=tuple(drives))
    with tempfile.TemporaryDirectory() as tmp:
        path = save_robot(new, Path(tmp) / f"{name}.yaml")
        item = ws.add(path, kind="robots", name=name, force=force)
    return new, item


# ---------------------------------------------------------------- the drives along a trajectory
def required_series_figures(req) -> dict[str, Any]:
    """Plotly figures of the currents, armature voltages and powers a trajectory needs
    (:func:`manipcad.required_drive`'s series), each against the motor's limit.

    Limits drawn dashed, in the joint's colour: ±rated current (A; the continuous
    rating, which bounds the RMS current); ±the voltage limit
    (:func:`manipcad.sizing.limits.voltage_limit`: the amplifier's u_max, else the rated
    voltage, V). The motor data hold no power rating: the power figure shows the
    electrical power u_a·i and the mechanical power P·q̇ (W), without a limit line.

    Returns:
        ``{"current": Figure, "voltage": Figure, "power": Figure}``.
    """
    import plotly.graph_objects as go  # deferred: start-up cost: plotly loaded on first use


    palette = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
               "#7f7f7f", "#bcbd22", "#17becf")
    t = np.asarray(req.t)
    out = {}
    specs = {"current": ("current", "armature current i [A]",
                         lambda d: float(d.rated_current), "rated current"),
             "voltage": ("voltage", "armature voltage u_a [V]", voltage_limit, "voltage limit"),
             "power": ("elec_power", "electrical power u_a·i (dotted: mechanical P·q̇) [W]",
                       None, "")}
    for key, (attr, ylabel, limit, limit_name) in specs.items():
        fig = go.Figure()
        y = np.asarray(getattr(req, attr))
        for j, jn in enumerate(req.joint_names):
            col = palette[j % len(palette)]
            fig.add_trace(go.Scatter(x=t, y=y[:, j], mode="lines", name=jn, legendgroup=jn,
                                     line={"color": col}))
            if key == "power":
                fig.add_trace(go.Scatter(x=t, y=np.asarray(req.mech_power)[:, j], mode="lines",
                                         name=f"{jn} P·q̇", legendgroup=jn, showlegend=False,
                                         line={"color": col, "dash": "dot", "width": 1}))
            d = req.drives[j]
            lim = limit(d) if (limit is not None and d is not None) else float("nan")
            if np.isfinite(lim):
                for s in (1.0, -1.0):
                    fig.add_trace(go.Scatter(x=[t[0], t[-1]], y=[s * lim, s * lim], mode="lines",
                                             name=f"{jn} {limit_name} {lim:.4g}",
                                             legendgroup=jn, showlegend=s > 0,
                                             line={"color": col, "dash": "dash", "width": 1}))
        fig.update_layout(title={"text": ylabel.split(" [")[0] + (
                              f"<br><sub>dashed: ±{limit_name}</sub>" if limit else
                              "<br><sub>no power rating in the motor data</sub>"),
                              "font": {"size": 13}},
                          xaxis_title="t [s]", yaxis_title=ylabel, height=340,
                          margin={"l": 50, "r": 10, "t": 50, "b": 30})
        out[key] = fig
    return out


def ratio_sweep_for(robot, traj, joint: int | str, lo: float, hi: float, n: int):
    """The gear-ratio sweep of one joint over ``n`` ratios spaced in log from ``lo`` to
    ``hi`` (|i_r|, rad/rad or rad/m): :func:`manipcad.sizing.ratio_sweep`, the function
    ``manipcad size --ratio-sweep LO:HI:N --sweep-joint J`` calls.

    Returns:
        :class:`~manipcad.sizing.sweep.RatioSweep` (feasible range, best ratio).

    Raises:
        InputError: bad bounds (naming ``sweep form``), or ratio_sweep's own errors.
    """

    lo, hi, n = float(lo), float(hi), int(n)
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi and 2 <= n <= 100000):
        raise InputError("sweep form", "ratios", f"needs 0 < LO < HI and 2 <= N <= 100000, "
                         f"got {lo:g}:{hi:g}:{n}")
    return ratio_sweep(robot, traj, joint, np.geomspace(lo, hi, n))


def ratio_sweep_png(sweep) -> bytes:
    """:func:`manipcad.sizing.plot.ratio_sweep_figure` (the figure of ``size --sweep-plot``),
    as PNG bytes for the page."""


    buf = io.BytesIO()
    ratio_sweep_figure(sweep).savefig(buf, format="png", dpi=110)
    return buf.getvalue()


# ---------------------------------------------------------------- synthesis: the LQR-GS table
# ---------------------------------------------------------------- drives from the catalogue
def select_drives_for(ws: Workspace, robot, trajectory: str, *,
                      payload_range: Sequence[float] = (0.0, 0.0), objective: str = "mass",
                      margin: float = 1.1, makers: str = "", gear_types: str = "",
                      name: str, force: bool = False):
    """Choose every joint's motor and gear from the catalogue (``manipcad select``,
    :func:`manipcad.sizing.select.select_drives`) for a workspace trajectory, and save the
    robot with them as ``robots/NAME`` (its file names the parts chosen).

    Args:
        ws: the workspace (its own motor and gear files join the catalogue).
        robot: the arm (its drives are replaced; its links get the drives' masses).
        trajectory: the workspace trajectory's name.
        payload_range: (LO, HI) payload masses on the last link, kg; both are checked.
        objective: "mass", "rotor_inertia" or "power".
        margin: every rating at least this × what the motion needs (1.0: size's limits).
        makers, gear_types: comma-separated filters ("" for all).
        name: the saved robot's name; force: replace a robot of that name.

    Returns:
        ``(selection, item)``: the :class:`~manipcad.sizing.select.Selection` and the
        workspace item of the robot saved.

    Raises:
        NoFeasibleDrive: a joint has no feasible drive (naming the joint, the closest
            candidate and the check it fails); InputError: a bad form value.
    """
    check_name(name, "name")
    traj = load_trajectory_ref(ws, trajectory, robot)
    sel = select_drives_along(robot, traj, payload_range=payload_range, objective=objective,
                              margin=margin, makers=makers, gear_types=gear_types,
                              parts=ws.root)
    return sel, save_selected(ws, sel, name, force=force)


def select_drives_along(robot, traj, *, payload_range: Sequence[float] = (0.0, 0.0),
                        objective: str = "mass", margin: float = 1.1, makers: str = "",
                        gear_types: str = "", parts: str | Path | None = None):
    """The selection of :func:`select_drives_for` without the workspace's index (so it may
    run in a worker thread): ``traj`` a trajectory, ``parts`` the workspace folder whose
    motor and gear files join the catalogue (None: the catalogue alone)."""

    def names(text: str) -> list[str] | None:
        out = [x.strip() for x in str(text or "").split(",") if x.strip()]
        return out or None

    lo, hi = (float(x) for x in payload_range)
    return select_drives(robot, [traj], payload_range=(lo, hi), objective=objective,
                         margin=margin, makers=names(makers), gear_types=names(gear_types),
                         ws=parts)


def save_selected(ws: Workspace, sel, name: str, *, force: bool = False):
    """Save a selection's robot into the workspace as ``robots/NAME`` (the file
    :func:`manipcad.sizing.select.save_selection` writes); returns the item."""

    check_name(name, "name")
    with tempfile.TemporaryDirectory() as tmp:
        path = save_selection(sel, Path(tmp) / f"{name}.yaml")
        return ws.add(path, kind="robots", name=name, force=force)


def selection_rows(sel) -> list[dict[str, Any]]:
    """One row per joint of a selection: joint, chosen pair, ratio i_r, mass (kg), the
    objective's value, the binding check and its margin (%), and the candidates
    feasible / evaluated / considered."""
    rows = []
    for c in sel.joints:
        ch = c.chosen
        rows.append({"joint": c.joint, "chosen": ch.label, "ratio": f"{ch.part.drive.ratio:.4g}",
                     "mass": f"{ch.part.mass:.3g}", "objective": f"{ch.objective:.4g}",
                     "binding": ch.binding or "-",
                     "margin": f"{ch.binding_margin:+.0%}" if np.isfinite(ch.binding_margin)
                     else "-",
                     "candidates": f"{c.feasible} / {c.evaluated} / {c.considered}",
                     "mounted_on": c.mount_link or "base"})
    return rows


def alternative_rows(sel) -> list[dict[str, Any]]:
    """Per joint, the next alternatives and the lighter candidates rejected: joint, kind
    ("alternative" or "rejected"), candidate, objective, binding check and margin or
    the reason it fails."""
    rows = []
    for c in sel.joints:
        for kind, cands in (("alternative", c.alternatives), ("rejected", c.rejected)):
            for a in cands:
                note = (f"{a.binding} {a.binding_margin:+.0%}" if kind == "alternative"
                        and np.isfinite(a.binding_margin) else a.reason)
                rows.append({"key": f"{c.joint}/{kind}/{a.label}", "joint": c.joint,
                             "kind": kind, "candidate": a.label,
                             "objective": f"{a.objective:.4g}", "note": note})
    return rows


def gain_table_figure(reg):
    """The LQR-GS gain table of a regulator as a Plotly figure: each gain (D_e V/rad,
    D_v V·s/rad, D_i V/A, and D_θ, D_ω of an elastic model) against the H_ii grid
    (kg·m²), one line per h_i grid value (N·m·s/rad). None when the regulator holds no
    table (every method but lqr_gs, and lqr's one-point table).

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> gain_table_figure(manipcad.synthesize(arm, "turn", "pid")) is None
        True
    """
    import plotly.graph_objects as go  # deferred: start-up cost: plotly loaded on first use
    from plotly.subplots import make_subplots  # deferred: start-up cost: plotly loaded on first use


    table = (reg.design or {}).get("table")
    if table is None or len(table.H) < 2:
        return None
    g = np.asarray(table.gains)
    names = GAIN_NAMES[:g.shape[-1]]
    fig = make_subplots(rows=1, cols=len(names), subplot_titles=[
        n.replace("_V_s_per_rad", " [V·s/rad]").replace("_V_per_rad", " [V/rad]")
        .replace("_V_per_A", " [V/A]") for n in names])
    for k in range(len(names)):
        for v, h in enumerate(table.h):
            fig.add_trace(go.Scatter(x=table.H, y=g[:, v, k], mode="lines+markers",
                                     name=f"h_i = {h:.3g} N·m·s/rad", legendgroup=str(v),
                                     showlegend=k == 0, marker={"size": 4}), row=1, col=k + 1)
        fig.update_xaxes(title_text="H_ii [kg·m²]", row=1, col=k + 1)
    joint = reg.joint_names[0] if reg.joint_names else reg.joint
    fig.update_layout(title=f"{reg.method} gain table of {joint}: {len(table.H)} × "
                      f"{len(table.h)} grid over (H_ii, h_i)", height=340,
                      margin={"l": 40, "r": 10, "t": 60, "b": 40})
    return fig
