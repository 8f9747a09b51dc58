"""The pages of ``manipcad ui`` (NiceGUI), following the designer's path (paper Fig. 1).

Main menu → Robots → Trajectories → Requirements → method → Synthesis →
Simulation → Results. Each page lays out calls of :mod:`manipcad.ui.logic` (the
same Python API as the CLI) and shows a bad value or file as one line naming the
file or form, the field and the reason, never a traceback.

The application serves one workspace (:data:`SERVER`); each browser tab has its own
current robot, trajectory, method and runs (:func:`state`, NiceGUI's per-tab
``app.storage.tab``), so two designers (or two tabs) do not change each other's
selection. Each page waits for its tab's connection before it reads that state.
"""

from __future__ import annotations

import asyncio
import base64
import math
from pathlib import Path
from typing import Any

import numpy as np
from nicegui import app, ui
from nicegui.run import io_bound as run_io

from manipcad.errors import InputError, ManipcadError
from manipcad.sizing import required_drive
from manipcad.ui import logic
from manipcad.ui.worker import SimSpec, SimulationJob, StudySpec, VerifySpec, prestart

#: the server's state: the workspace root (one per server, set by ``manipcad ui``)
SERVER: dict[str, Any] = {"ws": None}

#: a new tab's selection: robot, trajectory (workspace name), recommended method
DEFAULTS: dict[str, Any] = {"robot": "puma560", "trajectory": None, "method": None}

#: stored series a figure can show, with their units
QUANTITIES = {k: f"{what} [{unit}]" for k, (what, unit) in logic.RESULT_SERIES.items()}

#: jobs (simulations, studies) per tab id: worker handles, kept out of the tab's storage
_JOBS: dict[str, list] = {}

MENU = (("/", "Main menu"), ("/robots", "Robots"), ("/drives", "Drives"),
        ("/trajectories", "Trajectories"), ("/requirements", "Requirements → method"),
        ("/synthesis", "Synthesis"), ("/simulation", "Simulation"),
        ("/results", "Results and studies"), ("/identification", "Identification"))


def state() -> dict[str, Any]:
    """This browser tab's selection (NiceGUI's ``app.storage.tab``, defaults from
    :data:`DEFAULTS`); only once the page's client is connected."""
    tab = app.storage.tab
    for key, value in DEFAULTS.items():
        tab.setdefault(key, value)
    return tab


def jobs() -> list:
    """This tab's worker jobs (simulations and studies), oldest first."""
    return _JOBS.setdefault(ui.context.client.tab_id or "", [])


async def connected() -> dict[str, Any]:
    """Wait for the page's websocket (the tab's identity), then its :func:`state`."""
    await ui.context.client.connected()
    return state()


def ws():
    """The opened workspace."""
    return logic.open_workspace(SERVER["ws"])


def robot():
    """The tab's picked robot (loaded through the workspace API)."""
    return logic.load_robot_ref(ws(), state()["robot"])[0]


def error_text(exc: Exception) -> str:
    """The one line shown for a failed action: the API's message (file: field: reason)."""
    return str(exc) if isinstance(exc, ManipcadError) else f"{type(exc).__name__}: {exc}"


def frame(title: str):
    """Header with the main menu; returns the page's content column."""
    ui.page_title(f"manipcad · {title}")
    with ui.header(fixed=False).classes("items-center gap-4 bg-blue-grey-9"):
        ui.label("manipcad").classes("text-h6")
        for path, text in MENU:
            ui.link(text, path).classes("text-white")
    # plotly.js (4.5 MB, NiceGUI's full bundle) compiles once the page is idle, so the
    # first figure the designer opens does not wait for it (~1.8 s here, ~0.1 s after)
    ui.run_javascript("(window.requestIdleCallback || setTimeout)"
                      "(() => import('nicegui-plotly'))")
    col = ui.column().classes("w-full p-4 gap-3")
    S = state()
    with col:
        ui.label(title).classes("text-h5").props("data-testid=page-title").mark("page-title")
        with ui.row().classes("text-caption gap-1").props("data-testid=selection"):
            ui.label(f"workspace {Path(SERVER['ws']).resolve()} · robot")
            ui.label().bind_text_from(S, "robot")
            ui.label("· trajectory")
            ui.label().bind_text_from(S, "trajectory", lambda v: v or "-")
    return col


def error_label():
    """A hidden error line; ``show(exc)`` fills it, ``clear()`` hides it."""
    lab = ui.label("").classes("text-negative text-body1").props("data-testid=error") \
        .mark("error")
    lab.set_visibility(False)

    def show(exc: Exception) -> None:
        lab.text = error_text(exc)
        lab.set_visibility(True)

    def clear() -> None:
        lab.set_visibility(False)

    return show, clear


def numbers(text: str, field: str, source: str) -> list[float]:
    """Comma-separated numbers from a form field (InputError naming it otherwise)."""
    try:
        vals = [float(x) for x in str(text).replace(";", ",").split(",") if x.strip()]
    except ValueError:
        raise InputError(source, field, f"expected numbers separated by commas, got "
                         f"{text!r}") from None
    if not vals or not all(math.isfinite(v) for v in vals):
        raise InputError(source, field, f"expected finite numbers, got {text!r}")
    return vals


# ---------------------------------------------------------------------------- pages
def register() -> None:
    """Register the pages and the file route on NiceGUI's application (once per app;
    the user simulation of the tests resets NiceGUI and registers them again)."""

    @ui.page("/")
    async def main_menu() -> None:
        await connected()
        with frame("Main menu"):
            ui.markdown("The designer's path (paper Fig. 1): pick a **robot**, make a "
                        "**trajectory**, state **requirements** and get the recommended synthesis "
                        "**method**, **synthesize** the regulators, **simulate** and compare the "
                        "**results**. Everything is kept in the workspace.")
            w = ws()
            with ui.row():
                for path, text in MENU[1:]:
                    kind = {"/robots": "robots", "/trajectories": "trajectories",
                            "/synthesis": "regulators", "/results": "results"}.get(path)
                    count = f" ({len(w.list(kind))} in the workspace)" if kind else ""
                    with ui.card().classes("w-64"):
                        ui.link(text, path).classes("text-h6")
                        ui.label(count)


    @ui.page("/robots")
    async def robots_page() -> None:
        S = await connected()
        with frame("Robots"):
            show, clear = error_label()
            w = ws()
            pick = ui.select(logic.robot_choices(w), value=S["robot"], label="Robot") \
                .classes("w-64").props("data-testid=robot-select")
            with ui.row().classes("items-center"):
                name_in = ui.input("Name for an upload (optional)").props("data-testid=upload-name")

                async def uploaded(e) -> None:
                    clear()
                    try:
                        data = await e.file.read()
                        item = logic.add_upload(ws(), e.file.name, data, kind="robots",
                                                name=name_in.value or None)
                    except (ManipcadError, OSError) as exc:
                        show(exc)
                        return
                    ui.notify(f"added {item.ref}")
                    pick.options = logic.robot_choices(ws())
                    pick.value = item.ref

                ui.upload(label="Upload URDF / YAML / MJCF", auto_upload=True,
                          max_file_size=logic.MAX_UPLOAD, on_upload=uploaded,
                          on_rejected=lambda: show(InputError(
                              "upload", "", f"larger than {logic.MAX_UPLOAD} bytes"))) \
                    .props("accept=.urdf,.yaml,.yml,.xml,.mjcf data-testid=robot-upload")
            body = ui.column().classes("w-full")

            def render() -> None:
                body.clear()
                try:
                    arm, notes = logic.load_robot_ref(ws(), S["robot"])
                except ManipcadError as exc:
                    show(exc)
                    return
                with body:
                    tot = logic.robot_totals(arm)
                    ui.label(f"{arm.name}: {tot['joints']} joints, {tot['driven']} driven, "
                             f"moving mass {tot['mass_kg']:.4g} kg").classes("text-subtitle1")
                    cols = [("joint", ""), ("type", ""), ("unit", ""), ("lower", "rad|m"),
                            ("upper", "rad|m"), ("mass", "kg"), ("motor", ""), ("gear", ""),
                            ("ratio", "i_r"), ("R", "Ω"), ("L", "H"), ("k_m", "N·m/A"),
                            ("J", "kg·m²"), ("u_max", "V")]
                    ui.table(columns=[{"name": c, "label": f"{c} [{u}]" if u else c, "field": c}
                                      for c, u in cols], rows=logic.joint_rows(arm),
                             row_key="joint").props("dense flat data-testid=joints-table")
                    for note in notes:
                        ui.label(f"note: {note}").classes("text-caption text-warning")
                    q = [0.0] * arm.n
                    view = {"az": round(math.degrees(logic.VIEW[0])),
                            "el": round(math.degrees(logic.VIEW[1]))}   # deg, as shown
                    webgl: list = []          # the interactive WebGL view, once asked for

                    def redraw() -> None:
                        fig = logic.stick_view(arm, q, math.radians(view["az"]),
                                               math.radians(view["el"]))
                        plot.update_figure(fig)
                        for gl in webgl:
                            gl.update_figure(logic.stick_figure(arm, q))

                    def turn(az: float | None = None, el: float | None = None) -> None:
                        if az is not None:
                            az_slider.value = az       # its change event redraws
                        if el is not None:
                            el_slider.value = el

                    def moved_view(e, key: str) -> None:
                        view[key] = float(e.value)
                        redraw()

                    with ui.row().classes("w-full no-wrap items-start"):
                        with ui.column().style("width: 640px"):
                            # the 3-D arm as an orthographic projection, in SVG: a browser
                            # draws it in tens of ms (a WebGL scene takes seconds in
                            # software rendering); turned with the view sliders
                            plot = ui.plotly(logic.stick_view(arm, q, *logic.VIEW)) \
                                .style("width: 640px; height: 440px") \
                                .props("data-testid=stick-view")
                            ui.label("View [deg]: azimuth about z (from x towards y), "
                                     "elevation above the floor").classes("text-caption")
                            with ui.row().classes("w-full no-wrap items-center"):
                                ui.label("azimuth").style("width: 80px")
                                az_slider = ui.slider(min=-180, max=180, step=5,
                                                      value=view["az"],
                                                      on_change=lambda e: moved_view(e, "az")) \
                                    .props("label data-testid=view-azimuth")
                            with ui.row().classes("w-full no-wrap items-center"):
                                ui.label("elevation").style("width: 80px")
                                el_slider = ui.slider(min=-90, max=90, step=5, value=view["el"],
                                                      on_change=lambda e: moved_view(e, "el")) \
                                    .props("label data-testid=view-elevation")
                            with ui.row():
                                for text, az, el in (("front (from +x)", 0, 0),
                                                     ("side (from -y)", -90, 0),
                                                     ("top", -90, 90),
                                                     ("three-quarter", *map(round, map(
                                                         math.degrees, logic.VIEW)))):
                                    ui.button(text, on_click=lambda az=az, el=el: turn(az, el)) \
                                        .props("flat dense no-caps")

                                def open_webgl() -> None:
                                    if not webgl:
                                        with gl_box:
                                            webgl.append(ui.plotly(logic.stick_figure(arm, q))
                                                         .style("width: 640px; height: 440px")
                                                         .props("data-testid=stick-webgl"))

                                ui.button("Interactive 3-D (WebGL, slow without a GPU)",
                                          on_click=open_webgl) \
                                    .props("flat dense no-caps data-testid=open-webgl")
                            gl_box = ui.column()
                        with ui.column().style("width: 320px"):
                            ui.label("Pose (sliders)").classes("text-subtitle2")
                            for j, jn in enumerate(arm.joint_names):
                                lo, hi = logic.slider_range(arm, j)
                                ui.label(f"{jn} [{logic._unit(arm.joint_types[j])}]")

                                def moved(e, j=j) -> None:
                                    q[j] = float(e.value)
                                    redraw()

                                ui.slider(min=lo, max=hi, step=(hi - lo) / 200, value=0.0,
                                          on_change=moved).props(f"label data-testid=pose-{j}")

            def picked(e) -> None:
                clear()
                S["robot"] = e.value
                render()

            pick.on_value_change(picked)
            render()


    @ui.page("/trajectories")
    async def trajectories_page() -> None:
        S = await connected()
        with frame("Trajectories"):
            show, clear = error_label()
            law = ui.select({"cosine": "laws (2): q = q0 + A(1 − cos ωt)",
                             "quintic": "quintic point to point",
                             "trapezoidal": "trapezoidal velocity",
                             "spline": "via points (C2 spline)",
                             "line": "gripper straight line (inverse kinematics)",
                             "circle": "gripper circle (inverse kinematics)"},
                            value="cosine",
                            label="Law").classes("w-96").props("data-testid=law")
            fields: dict[str, Any] = {}
            form = ui.column()

            def fill() -> None:
                form.clear()
                fields.clear()
                specs = {"cosine": (("amplitude", "A per joint [rad|m]", "0.3"),
                                    ("omega", "ω per joint [rad/s]", "4"),
                                    ("duration", "duration [s]", "1.6")),
                         "quintic": (("q_start", "start per joint [rad|m]", "0"),
                                     ("q_end", "end per joint [rad|m]", "0.5"),
                                     ("duration", "duration [s]", "2")),
                         "trapezoidal": (("q_start", "start per joint [rad|m]", "0"),
                                         ("q_end", "end per joint [rad|m]", "0.5"),
                                         ("v_max", "max speed [rad/s|m/s]", "1"),
                                         ("a_max", "max acceleration [rad/s²|m/s²]", "4")),
                         "spline": (("times", "times of the via points [s]", "0, 0.5, 1"),
                                    ("points", "via points, one row per time, rows split by "
                                     "';' [rad|m]", "0; 0.2; 0.1")),
                         "line": (("q0", "start pose per joint [rad|m]", "0.1"),
                                  ("move", "gripper displacement x, y, z [m]", "0.05, 0, 0"),
                                  ("duration", "duration [s]", "1")),
                         "circle": (("q0", "start pose per joint [rad|m]", "0.1"),
                                    ("offset", "centre from the gripper at the start pose "
                                     "x, y, z [m]", "0, 0, -0.05"),
                                    ("radius", "radius [m]", "0.05"),
                                    ("normal", "normal of the circle's plane x, y, z [-]",
                                     "1, 0, 0"),
                                    ("angle", "angle travelled [rad]", "6.283185307179586"),
                                    ("duration", "duration [s]", "2"))}
                with form:
                    ui.label("Lists: one value per joint, or one value for every joint.") \
                        .classes("text-caption")
                    for key, label, default in specs[law.value]:
                        fields[key] = ui.input(label, value=default).classes("w-96") \
                            .props(f"data-testid=traj-{key}")

            def build():
                arm = robot()
                data: dict[str, Any] = {"type": law.value}
                for key, inp in fields.items():
                    if key == "points":
                        rows = [numbers(r, f"points[{k}]", "trajectory form")
                                for k, r in enumerate(str(inp.value).split(";"))]
                        data[key] = [r * arm.n if len(r) == 1 else r for r in rows]
                        continue
                    vals = numbers(inp.value, key, "trajectory form")
                    if key in ("move", "offset"):
                        continue
                    if key == "q0" and len(vals) == 1:
                        vals = vals * arm.n
                    if key in ("duration", "radius", "angle"):
                        data[key] = vals[0]
                    elif key in ("q_start", "q_end") and len(vals) == 1:
                        data[key] = vals * arm.n
                    elif key in ("amplitude", "omega") and len(vals) == 1:
                        data[key] = vals * arm.n
                    else:
                        data[key] = vals
                if law.value == "line":     # from the tool's position at q0, by `move`
                    d = numbers(fields["move"].value, "move", "trajectory form")
                    if len(d) != 3:
                        raise InputError("trajectory form", "move", "expected x, y, z in m")
                    p0 = logic.tool_position(arm, data["q0"])
                    data["p_start"] = [float(x) for x in p0]
                    data["p_end"] = [float(x) for x in p0 + np.asarray(d)]
                if law.value == "circle":   # centred at the tool's position at q0 + offset
                    d = numbers(fields["offset"].value, "offset", "trajectory form")
                    if len(d) != 3:
                        raise InputError("trajectory form", "offset", "expected x, y, z in m")
                    p0 = logic.tool_position(arm, data["q0"])
                    data["center"] = [float(x) for x in p0 + np.asarray(d)]
                return arm, logic.make_trajectory(data, arm)

            def do_preview() -> None:
                clear()
                try:
                    arm, traj = build()
                    pv = logic.trajectory_preview(traj, arm)
                except ManipcadError as exc:
                    show(exc)
                    return
                preview.clear()
                with preview, ui.row().classes("w-full no-wrap"):
                    ui.plotly(logic.series_figure(pv["t"], pv["q"], arm.joint_names,
                                                  "joint positions", "q [rad|m]")).classes("w-1/2")
                    ui.plotly(logic.series_figure(pv["t"], pv["speed"][:, None], ["gripper"],
                                                  "gripper speed", "[m/s]")).classes("w-1/2")

            def do_save() -> None:
                clear()
                try:
                    _, traj = build()
                    item = logic.save_trajectory_to(ws(), traj, name.value, force=force.value)
                except ManipcadError as exc:
                    show(exc)
                    return
                S["trajectory"] = item.name
                ui.notify(f"saved {item.ref}")
                listing.refresh()

            async def uploaded(e) -> None:
                clear()
                try:
                    item = logic.add_upload(ws(), e.file.name, await e.file.read(),
                                            kind="trajectories", robot=robot())
                except (ManipcadError, OSError) as exc:
                    show(exc)
                    return
                S["trajectory"] = item.name
                ui.notify(f"added {item.ref}")
                listing.refresh()

            ui.upload(label="Or upload a trajectory file (.yaml)", auto_upload=True,
                      max_file_size=logic.MAX_UPLOAD, on_upload=uploaded) \
                .props("accept=.yaml,.yml data-testid=traj-upload")
            law.on_value_change(lambda _: fill())
            fill()
            with ui.row().classes("items-center"):
                ui.button("Preview", on_click=do_preview).props("data-testid=traj-preview")
                name = ui.input("Name", value="move").props("data-testid=traj-name")
                force = ui.checkbox("replace")
                ui.button("Save to workspace", on_click=do_save).props("data-testid=traj-save")

            @ui.refreshable
            def listing() -> None:
                names = [i.name for i in ws().list("trajectories")]
                ui.label("In the workspace (pick the current one):")

                def chosen(e) -> None:
                    S["trajectory"] = e.value

                ui.select(names, value=S["trajectory"] if S["trajectory"] in names
                          else None, on_change=chosen, label="Current trajectory").classes("w-64")

            listing()
            preview = ui.column().classes("w-full")


    @ui.page("/requirements")
    async def requirements_page() -> None:
        S = await connected()
        prestart()                   # this page runs jobs: have a worker ready
        with frame("Requirements → method"):
            show, clear = error_label()
            yes_no = {None: "—", True: "yes", False: "no"}
            with ui.grid(columns=3).classes("gap-2"):
                acc = ui.input("accuracy: largest error [rad|m]", value="1e-3") \
                    .props("data-testid=req-accuracy")
                over = ui.select(yes_no, value=False, label="overshoot allowed")
                fast = ui.select(yes_no, value=True, label="fastest action")
                speed = ui.input("gripper speed [m/s] (empty: derived)", value="")
                ind = ui.select({None: "—", "negligible": "negligible", "significant":
                                 "significant"}, value="negligible", label="inductance")
                coup = ui.select({None: "— (derived)", "decoupled": "decoupled",
                                  "inertial": "inertial", "full": "full"}, value=None,
                                 label="coupling")
                var = ui.select({None: "—", "slow": "slow", "fast": "fast"}, value="slow",
                                label="parameter variation")
                back = ui.select(yes_no, value=False, label="backlash")
                elas = ui.select(yes_no, value=False, label="elasticity")
            out = ui.column().classes("w-full")

            def read_form() -> dict[str, Any]:
                return {
                    "accuracy": numbers(acc.value, "accuracy", "requirements form")[0]
                    if str(acc.value).strip() else None,
                    "overshoot_allowed": over.value, "fast_action": fast.value,
                    "gripper_speed": numbers(speed.value, "gripper_speed",
                                             "requirements form")[0]
                    if str(speed.value).strip() else None,
                    "inductance": ind.value, "coupling": coup.value,
                    "parameter_variation": var.value,
                    "transmission": {"backlash": back.value, "elasticity": elas.value}}

            def run() -> None:
                clear()
                out.clear()
                try:
                    form = read_form()
                    arm = robot()
                    traj = logic.load_trajectory_ref(ws(), S["trajectory"], arm) \
                        if S["trajectory"] else None
                    recs = logic.recommend_for(form, arm, traj)
                except ManipcadError as exc:
                    show(exc)
                    return
                S["method"] = recs.best.method
                with out:
                    ui.label(f"Recommended, best first: {', '.join(recs.methods)}") \
                        .classes("text-subtitle1").props("data-testid=rec-methods")
                    rows = [{"rank": k, "method": r.method, "score": r.score,
                             "ops": r.complexity.get("ops_per_period"),
                             "gains": r.complexity.get("gains_stored"),
                             "rules": ", ".join(x.split(" ", 1)[0] for x in r.reasons)}
                            for k, r in enumerate(recs, 1)]
                    ui.table(columns=[{"name": c, "label": lab, "field": c} for c, lab in (
                        ("rank", "#"), ("method", "method"), ("score", "score"),
                        ("ops", "ops/period"), ("gains", "gains stored"),
                        ("rules", "rules"))], rows=rows, row_key="method").props("dense flat")
                    ui.label("Rules that fired").classes("text-subtitle2")
                    for text in recs.rule_texts.values():
                        ui.label(f"• {text}").classes("text-body2")
                    if recs.excluded_by:
                        ui.label("Excluded: " + "; ".join(
                            f"{m} ({', '.join(ids)})" for m, ids in recs.excluded_by.items()))
                    ui.link(f"Synthesize {recs.best.method} →", "/synthesis")

            async def verify() -> None:
                clear()
                try:
                    form = read_form()
                    if not S["trajectory"]:
                        raise InputError("requirements form", "trajectory", "verify by "
                                         "simulation needs a trajectory (Trajectories page)")
                    checked.text = "verifying: synthesizing and simulating the top candidates"
                    # in the spare worker process, as a simulation: the server keeps answering
                    job = SimulationJob(VerifySpec(str(SERVER["ws"]), S["robot"],
                                                   S["trajectory"], form))
                    while job.poll() in ("starting", "running"):
                        await asyncio.sleep(0.1)
                    if job.state != "done":
                        raise ManipcadError(job.message)
                    doc = job.metrics
                except ManipcadError as exc:
                    checked.text = ""
                    show(exc)
                    return
                checked.text = "verified by simulation along " + S["trajectory"]
                vbox.clear()
                with vbox:
                    ui.table(columns=[{"name": c, "label": lab, "field": c} for c, lab in (
                        ("method", "method"), ("max_error", "max error [rad|m]"),
                        ("meets", "meets the accuracy"), ("note", "note"))],
                        rows=[{"method": r["method"], "max_error": None if r["max_error"]
                               is None else f"{r['max_error']:.3g}",
                               "meets": r["meets_accuracy"], "note": r["note"]}
                              for r in doc["recommendations"]], row_key="method") \
                        .props("dense flat data-testid=req-verified")

            with ui.row():
                ui.button("Recommend", on_click=run).props("data-testid=req-run")
                ui.button("Verify by simulation", on_click=verify) \
                    .props("data-testid=req-verify")
            checked = ui.label("")
            vbox = ui.column().classes("w-full")


    @ui.page("/synthesis")
    async def synthesis_page() -> None:
        S = await connected()
        with frame("Synthesis"):
            show, clear = error_label()
            ms = logic.methods()
            with ui.row().classes("items-end"):
                method = ui.select(ms, value=S["method"] or "pid", label="Method") \
                    .classes("w-64").props("data-testid=syn-method")
                spec = ui.input("spec KEY=VALUE, ... (e.g. bandwidth=30)", value="") \
                    .classes("w-80")
                period = ui.input("period [s] (empty: the method's)", value="") \
                    .props("data-testid=syn-period")
                joints = ui.input("joints (names or 1..n, comma; empty: all)", value="") \
                    .classes("w-72").props("data-testid=syn-joints")
                name = ui.input("Name", value="").props("data-testid=syn-name")
                force = ui.checkbox("replace")

            async def run() -> None:
                clear()
                try:
                    pairs = {}
                    for part in filter(None, (p.strip() for p in spec.value.split(","))):
                        key, sep, val = part.partition("=")
                        if not sep:
                            raise InputError("synthesis form", "spec",
                                             f"expected KEY=VALUE, got {part!r}")
                        pairs[key.strip()] = numbers(val, f"spec.{key.strip()}",
                                                     "synthesis form")[0]
                    per = numbers(period.value, "period", "synthesis form")[0] \
                        if str(period.value).strip() else None
                    nm = name.value or f"{method.value}-{S['robot'].split('/')[-1]}"
                    picked = [int(x) - 1 if x.isdigit() else x for x in
                              (p.strip() for p in str(joints.value).split(",")) if x]
                    busy.text = f"synthesizing {method.value}..."
                    # in a thread: a gain table takes seconds, the page stays live meanwhile
                    root, arm, m, f = SERVER["ws"], robot(), method.value, force.value
                    regs, item = await run_io(   # its own workspace handle in the thread
                        lambda: logic.synthesize_to(logic.open_workspace(root), arm, m,
                                                    joints=picked or "all",
                                                    spec=pairs, period=per, name=nm, force=f))
                except ManipcadError as exc:
                    busy.text = ""
                    show(exc)
                    return
                busy.text = ""
                ui.notify(f"saved {item.ref}")
                out.clear()
                with out:
                    ui.label(f"saved regulators/{item.name}").props("data-testid=syn-saved")
                    for reg in regs:
                        c = reg.realization_complexity()
                        with ui.card().classes("w-full"):
                            ui.label(reg.describe()).classes("font-mono text-body2")
                            ui.label(f"complexity: {c['ops_per_period']} operations per period "
                                     f"({c['mul']} ×, {c['add']} +), {c['gains_stored']} numbers "
                                     f"stored, reads {', '.join(c['signals'])}") \
                                .classes("text-caption")
                            fig = logic.gain_table_figure(reg)
                            if fig is not None:     # LQR-GS: the gains over the H_ii grid
                                ui.plotly(fig).classes("w-full") \
                                    .props("data-testid=syn-gain-table")
                listing.refresh()

            ui.button("Synthesize and save", on_click=run).props("data-testid=syn-run")
            busy = ui.label("")

            @ui.refreshable
            def listing() -> None:
                ui.label("Regulators in the workspace: " + (", ".join(
                    i.name for i in ws().list("regulators")) or "none"))

            listing()
            out = ui.column().classes("w-full")


    @ui.page("/simulation")
    async def simulation_page() -> None:
        S = await connected()
        prestart()                   # this page runs jobs: have a worker ready
        with frame("Simulation"):
            show, clear = error_label()
            w = ws()
            trajs = [i.name for i in w.list("trajectories")]
            regs = [i.name for i in w.list("regulators")]
            with ui.row().classes("items-end"):
                traj = ui.select(trajs, value=S["trajectory"] if S["trajectory"] in trajs
                                 else (trajs[0] if trajs else None), label="Trajectory") \
                    .classes("w-48").props("data-testid=sim-traj")
                reg = ui.select(regs, value=regs[-1] if regs else None, label="Regulator") \
                    .classes("w-64").props("data-testid=sim-reg")
                # regulators synthesized per joint (one method here, another there) run
                # together; simulate() refuses two for one joint
                more = ui.select(regs, value=[], multiple=True,
                                 label="and regulators of other joints") \
                    .classes("w-64").props("use-chips data-testid=sim-more")
                t_end = ui.input("t_end [s] (empty: the trajectory's)", value="") \
                    .props("data-testid=sim-tend")
                dt = ui.input("dt [s]", value="1e-4").props("data-testid=sim-dt")
                name = ui.input("Result name (optional)", value="").props("data-testid=sim-name")
                keep = ui.checkbox("keep a diverged run's partial result")
            bar = ui.linear_progress(value=0.0, show_value=False).classes("w-full")
            status = ui.label("").props("data-testid=sim-status")
            figs = ui.column().classes("w-full")
            shown: dict[str, Any] = {"job": None, "state": None}

            def start() -> None:
                clear()
                try:
                    if not traj.value:
                        raise InputError("simulation form", "trajectory", "pick a trajectory "
                                         "(make one on the Trajectories page)")
                    spec = SimSpec(workspace=str(SERVER["ws"]), robot=S["robot"],
                                   trajectory=traj.value,
                                   regulators=list(dict.fromkeys(   # each once, in order
                                       r for r in [reg.value, *(more.value or [])] if r)),
                                   t_end=numbers(t_end.value, "t_end", "simulation form")[0]
                                   if str(t_end.value).strip() else None,
                                   dt=numbers(dt.value, "dt", "simulation form")[0],
                                   name=name.value or None, save_diverged=keep.value)
                except ManipcadError as exc:
                    show(exc)
                    return
                jobs().append(SimulationJob(spec))
                status.text = "starting the worker..."

            def cancel() -> None:
                for job in jobs():
                    if not job.finished:
                        job.cancel()

            def tick() -> None:
                if not jobs():
                    return
                job = jobs()[-1]
                state = job.poll()
                bar.value = job.fraction
                if state in ("starting", "running"):
                    status.text = f"{state}: {100 * job.fraction:.0f} %"
                    return
                if shown["job"] is job and shown["state"] == state:
                    return
                shown["job"], shown["state"] = job, state
                if state == "done":
                    status.text = (f"done: stored results/{job.result} in {job.wall:.3g} s; "
                                   f"max |e| = {job.metrics.get('max_error', float('nan')):.3g}")
                    figs.clear()
                    with figs:
                        box = ui.column().classes("w-full")

                        def draw(q: str, name: str = job.result) -> None:
                            box.clear()
                            with box:
                                ui.plotly(logic.overlay_figure(ws(), [name], q)).classes("w-full")

                        ui.toggle(QUANTITIES, value="error", on_change=lambda e: draw(e.value)) \
                            .move(target_index=0)
                        draw("error")
                else:
                    status.text = state
                    if state == "error":
                        show(ManipcadError(job.message))

            with ui.row():
                ui.button("Simulate", on_click=start).props("data-testid=sim-run")
                ui.button("Cancel", on_click=cancel, color="negative") \
                    .props("data-testid=sim-cancel")
            ui.timer(0.25, tick)


    @ui.page("/results")
    async def results_page() -> None:
        await connected()
        prestart()                   # this page runs jobs: have a worker ready
        with frame("Results and studies"):
            show, clear = error_label()
            with ui.row().classes("items-end"):
                where = ui.input("filter, e.g. max_error<1e-3 and status=ok", value="") \
                    .classes("w-96").props("data-testid=res-where")
                quantity = ui.select(QUANTITIES, value="error", label="Quantity")
            cols = ["name", "status", "max_error", "rms_error", "peak_torque", "peak_current",
                    "peak_power", "energy", "created"]
            table = ui.table(columns=[{"name": c, "label": c, "field": c, "sortable": True}
                                      for c in cols], rows=[], row_key="name",
                             selection="multiple").props("dense flat data-testid=res-table")

            def load() -> None:
                clear()
                try:
                    table.rows = logic.result_rows(ws(), where.value.strip() or None)
                except ManipcadError as exc:
                    show(exc)
                    table.rows = []
                table.update()

            def overlay() -> None:
                clear()
                names = [r["name"] for r in table.selected] or [r["name"] for r in table.rows]
                figs.clear()
                try:
                    fig = logic.overlay_figure(ws(), names, quantity.value)
                except ManipcadError as exc:
                    show(exc)
                    return
                with figs:
                    ui.plotly(fig).classes("w-full").props("data-testid=res-overlay")

            with ui.row():
                ui.button("Filter", on_click=load).props("data-testid=res-filter")
                ui.button("Overlay selected (all when none)", on_click=overlay) \
                    .props("data-testid=res-overlay-run")
            figs = ui.column().classes("w-full")
            load()
            ui.label("Studies: the paper's Fig. 3 study and the claims maps (manipcad study "
                     "fig3 | claims), run here in a worker process and kept in the workspace") \
                .classes("text-subtitle1")
            with ui.row().classes("items-end"):
                kind = ui.select({"fig3": "Fig. 3 study (laws (2), every method)",
                                  "claims": "claims maps (--grid quick)"}, value="fig3",
                                 label="Study").classes("w-72").props("data-testid=study-kind")
                sname = ui.input("name", value="fig3").props("data-testid=study-name")
                st_end = ui.input("fig3: t_end [s] (empty: 1.6)", value="") \
                    .props("data-testid=study-tend")
                smethods = ui.input("fig3: methods (comma; empty: all)", value="") \
                    .classes("w-64").props("data-testid=study-methods")
                kind.on_value_change(lambda e: sname.set_value(e.value))
            sbar = ui.linear_progress(value=0.0, show_value=False).classes("w-full")
            sstatus = ui.label("").props("data-testid=study-status")
            my_studies: list[SimulationJob] = []
            seen: dict[str, Any] = {"job": None}

            def start_study() -> None:
                clear()
                try:
                    spec = StudySpec(
                        workspace=str(SERVER["ws"]), study=kind.value, name=sname.value,
                        t_end=numbers(st_end.value, "t_end", "study form")[0]
                        if str(st_end.value).strip() else None,
                        methods=smethods.value.strip() or None)
                    from manipcad.workspace import check_name

                    check_name(spec.name, "study name")
                except ManipcadError as exc:
                    show(exc)
                    return
                job = SimulationJob(spec)
                jobs().append(job)
                my_studies.append(job)
                sstatus.text = f"starting the worker for {spec.study}..."

            def cancel_study() -> None:
                for job in my_studies:
                    if not job.finished:
                        job.cancel()

            def study_tick() -> None:
                if not my_studies:
                    return
                job = my_studies[-1]
                st = job.poll()
                sbar.value = job.fraction
                if st in ("starting", "running"):
                    sstatus.text = f"{job.spec.study} {st}: {100 * job.fraction:.0f} %"
                    return
                if seen["job"] is job:
                    return
                seen["job"] = job
                if st == "done":
                    report = "report.html" if "report.html" in job.metrics.get("files", []) \
                        else None
                    sstatus.text = (f"done: stored studies/{job.result} in {job.wall:.3g} s")
                    studies.refresh()
                    if report:
                        ui.navigate.to(f"/api/studies/{job.result}/{report}", new_tab=True)
                else:
                    sstatus.text = st
                    if st == "error":
                        show(ManipcadError(job.message))

            with ui.row():
                ui.button("Run the study", on_click=start_study).props("data-testid=study-run")
                ui.button("Cancel", on_click=cancel_study, color="negative") \
                    .props("data-testid=study-cancel")
            ui.timer(0.5, study_tick)

            @ui.refreshable
            def studies() -> None:
                w = ws()
                for item in w.list("studies"):
                    with ui.row().classes("items-center").props(
                            f"data-testid=study-{item.name}"):
                        ui.label(item.name).classes("font-bold")
                        for f in logic.study_files(w, item.name):
                            ui.link(f, f"/api/studies/{item.name}/{f}", new_tab=True)
                if not w.list("studies"):
                    ui.label("none yet").classes("text-caption")

            studies()


    # ---------------------------------------------------------------------------- files
    @ui.page("/drives")
    async def drives_page() -> None:
        S = await connected()
        with frame("Drives"):
            show, clear = error_label()
            ui.markdown("Motors and gears: the catalog's and your own (kept in the workspace), "
                        "attached to the joints of the current robot; then what the current "
                        "trajectory needs from the drives against their limits (`manipcad "
                        "size`) and the gear-ratio sweep (`manipcad size --ratio-sweep`).")

            # ---- the libraries
            @ui.refreshable
            def libraries() -> None:
                w = ws()
                for kind, fields in (("motors", logic.MOTOR_FIELDS),
                                     ("gears", logic.GEAR_FIELDS)):
                    cols = [("ref", "name", ""), ("origin", "origin", "")] + \
                        ([("type", "type", "")] if kind == "gears" else []) + \
                        [(k, lab, u) for k, u, lab in fields]
                    ui.label(f"{kind.capitalize()} library").classes("text-subtitle1")
                    ui.table(columns=[{"name": k, "label": f"{k} [{u}]" if u else lab,
                                       "field": k, "sortable": True} for k, lab, u in cols],
                             rows=logic.library_rows(w, kind), row_key="ref",
                             pagination=6).props(f"dense flat data-testid={kind}-table")

            libraries()

            def part_form(kind: str, fields) -> None:
                inputs: dict[str, Any] = {}
                with ui.expansion(f"Add your own {kind[:-1]}").classes("w-full") \
                        .props(f"data-testid=add-{kind[:-1]}"):
                    with ui.grid(columns=4).classes("gap-2"):
                        name = ui.input(f"{kind[:-1]} name").props(f"data-testid={kind[:-1]}-name")
                        source = ui.input("source (data sheet)", value="own data") \
                            .props(f"data-testid={kind[:-1]}-source")
                        gtype = ui.select(list(logic.GEAR_TYPES), value="planetary",
                                          label="type") if kind == "gears" else None
                        for key, unit, label in fields:
                            inputs[key] = ui.input(f"{label} [{unit}]").props(
                                f"data-testid={kind[:-1]}-{key}")

                    def save() -> None:
                        clear()
                        form: dict[str, Any] = {"type": gtype.value} if gtype else {}
                        try:
                            for key, inp in inputs.items():
                                if not str(inp.value).strip():
                                    continue
                                vals = numbers(inp.value, key, f"{kind}/{name.value}")
                                form[key] = vals if key == "M_f" and len(vals) > 1 else (
                                    int(vals[0]) if key == "direction" else vals[0])
                            item = logic.add_part(ws(), kind, name.value, form,
                                                  source=source.value)
                        except ManipcadError as exc:
                            show(exc)
                            return
                        ui.notify(f"added {item.ref}")
                        libraries.refresh()
                        reload_parts()

                    ui.button(f"Save the {kind[:-1]}", on_click=save) \
                        .props(f"data-testid={kind[:-1]}-save")

            part_form("motors", logic.MOTOR_FIELDS)
            part_form("gears", logic.GEAR_FIELDS)

            # ---- attach motor + gear to a joint of the current robot
            sel: dict[str, Any] = {}

            def reload_parts() -> None:
                w = ws()
                sel["motor"].set_options([r["ref"] for r in logic.library_rows(w, "motors")])
                sel["gear"].set_options(["(none)", *(r["ref"] for r in
                                                    logic.library_rows(w, "gears"))])

            def attach_form() -> None:
                try:
                    arm = robot()
                except ManipcadError as exc:
                    show(exc)
                    return
                ui.label("Attach a motor and a gear to a joint of the current robot (saved as "
                         "a workspace robot, which becomes the current one)") \
                    .classes("text-subtitle1")
                with ui.row().classes("items-end"):
                    joint = ui.select(list(arm.joint_names), value=arm.joint_names[0],
                                      label="joint").classes("w-40") \
                        .props("data-testid=attach-joint")
                    sel["motor"] = ui.select([], value=None, label="motor").classes("w-64") \
                        .props("data-testid=attach-motor")
                    sel["gear"] = ui.select(["(none)"], value="(none)", label="gear") \
                        .classes("w-64").props("data-testid=attach-gear")
                    reload_parts()
                    base = S["robot"].split("/")[-1]
                    own = S["robot"].startswith("robots/")
                    rname = ui.input("robot name", value=base if own else f"{base}-drives") \
                        .props("data-testid=attach-name")
                    force = ui.checkbox("replace", value=own)

                    def attach() -> None:
                        clear()
                        motor, gear = sel["motor"].value, sel["gear"].value
                        try:
                            _, item = logic.attach_drive(
                                ws(), robot(), joint.value, motor or "",
                                [] if gear in (None, "(none)") else [gear],
                                name=rname.value, force=force.value)
                        except ManipcadError as exc:
                            show(exc)
                            return
                        S["robot"] = item.ref
                        rname.value, force.value = item.name, True
                        ui.notify(f"{joint.value}: {motor} + {gear}; saved {item.ref}")

                    ui.button("Attach", on_click=attach).props("data-testid=attach-run")

            attach_form()

            # ---- what the trajectory needs, against the limits
            ui.label("Along the current trajectory").classes("text-subtitle1")
            out = ui.column().classes("w-full")

            def run() -> None:
                clear()
                out.clear()
                try:
                    if not S["trajectory"]:
                        raise InputError("drives", "trajectory", "pick or make a trajectory "
                                         "first (Trajectories page)")
                    arm = robot()
                    traj = logic.load_trajectory_ref(ws(), S["trajectory"], arm)
                    req = required_drive(arm, traj)
                    png = logic.torque_speed_png(req)
                    figs = logic.required_series_figures(req)
                except ManipcadError as exc:
                    show(exc)
                    return
                with out:
                    cols = [("joint", ""), ("peak_torque", "N·m|N"), ("rms_torque", "N·m|N"),
                            ("peak_motor_speed", "rad/s"), ("peak_motor_torque", "N·m"),
                            ("peak_current", "A"), ("rms_current", "A"),
                            ("peak_voltage", "V"), ("peak_elec_power", "W"), ("status", "")]
                    ui.table(columns=[{"name": c, "label": f"{c} [{u}]" if u else c,
                                       "field": c} for c, u in cols],
                             rows=logic.drive_rows(req), row_key="joint") \
                        .props("dense flat data-testid=drives-table")
                    b64 = base64.b64encode(png).decode()
                    ui.image(f"data:image/png;base64,{b64}").style("max-width: 1100px") \
                        .props("data-testid=torque-speed")
                    with ui.row().classes("w-full no-wrap"):
                        for key in ("current", "voltage", "power"):
                            ui.plotly(figs[key]).classes("w-1/3") \
                                .props(f"data-testid=drives-{key}")

            ui.button("Compute the drive requirements", on_click=run) \
                .props("data-testid=drives-run")

            # ---- the gear-ratio sweep
            ui.label("Gear-ratio sweep of one joint (its motor kept; feasible ratios shaded)") \
                .classes("text-subtitle1")
            with ui.row().classes("items-end"):
                sj = ui.input("joint (name or 1..n)", value="2").props("data-testid=sweep-joint")
                lo = ui.input("lowest |i_r| [rad/rad|rad/m]", value="10") \
                    .props("data-testid=sweep-lo")
                hi = ui.input("highest |i_r| [rad/rad|rad/m]", value="1000") \
                    .props("data-testid=sweep-hi")
                nr = ui.input("ratios [-]", value="200").props("data-testid=sweep-n")
            sweep_out = ui.column().classes("w-full")

            def sweep() -> None:
                clear()
                sweep_out.clear()
                try:
                    if not S["trajectory"]:
                        raise InputError("sweep form", "trajectory", "pick or make a "
                                         "trajectory first (Trajectories page)")
                    arm = robot()
                    traj = logic.load_trajectory_ref(ws(), S["trajectory"], arm)
                    jv = str(sj.value).strip()
                    joint = int(jv) - 1 if jv.isdigit() else jv
                    if isinstance(joint, int) and not 0 <= joint < arm.n:
                        raise InputError("sweep form", "joint", f"{jv}: expected 1..{arm.n} or "
                                         f"a name ({', '.join(arm.joint_names)})")
                    if isinstance(joint, str) and joint not in arm.joint_names:
                        raise InputError("sweep form", "joint", f"no joint {jv!r}; joints: "
                                         f"{', '.join(arm.joint_names)}")
                    n = numbers(nr.value, "ratios", "sweep form")[0]
                    if n != int(n):
                        raise InputError("sweep form", "ratios", f"a whole number, got {n}")
                    sw = logic.ratio_sweep_for(
                        arm, traj, joint, numbers(lo.value, "lowest", "sweep form")[0],
                        numbers(hi.value, "highest", "sweep form")[0], int(n))
                    png = logic.ratio_sweep_png(sw)
                except ManipcadError as exc:
                    show(exc)
                    return
                spans = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in sw.intervals) or "none"
                with sweep_out:
                    ui.label(f"{sw.joint} ({sw.motor or 'motor'}): feasible |i_r| {spans}; best "
                             f"{sw.best_ratio:.4g} (least {sw.criterion.replace('_', ' ')}); "
                             f"present {abs(sw.ratio):.4g}"
                             + ("; the range reaches the grid's end" if sw.bounded_by_grid
                                else "")).props("data-testid=sweep-result")
                    b64 = base64.b64encode(png).decode()
                    ui.image(f"data:image/png;base64,{b64}").style("max-width: 700px")

            ui.button("Sweep the ratio", on_click=sweep).props("data-testid=sweep-run")

    @ui.page("/identification")
    async def identification_page() -> None:
        await connected()
        with frame("Identification"):
            show, clear = error_label()
            ui.label("Upload measured joint torques or motor currents along a motion (CSV: t, "
                     "q1.., qd1.., qdd1.., tau1.. or current1..; SI units) of the picked "
                     "robot; get the payload mass with its uncertainty (manipcad identify).")
            com = ui.input("payload centre of mass x, y, z [m] in the last link's frame",
                           value="0, 0, 0").classes("w-96")
            out = ui.column().classes("w-full")

            async def uploaded(e) -> None:
                clear()
                out.clear()
                try:
                    c = numbers(com.value, "com", "identification form")
                    if len(c) != 3:
                        raise InputError("identification form", "com", "expected x, y, z")
                    est = logic.identify_upload(robot(), e.file.name, await e.file.read(),
                                                com=c)
                except ManipcadError as exc:
                    show(exc)
                    return
                with out:
                    ui.label(f"payload mass m_r = {est.mass:.5g} ± {est.std:.2g} kg "
                             f"({est.samples} samples of {est.signal}, {est.method}; residual "
                             f"RMS {est.residual:.3g} N·m|N)").classes("text-h6") \
                        .props("data-testid=ident-mass")
                    ui.table(columns=[{"name": k, "label": lab, "field": k} for k, lab in (
                        ("joint", "joint"), ("mass", "m_r alone [kg]"), ("std", "std [kg]"))],
                        rows=[{"joint": n, "mass": f"{m:.5g}", "std": f"{s:.2g}"}
                              for n, m, s in zip(est.joint_names, est.per_joint_mass,
                                                 est.per_joint_std, strict=True)],
                        row_key="joint").props("dense flat")

            ui.upload(label="Upload measured data (.csv)", auto_upload=True,
                      max_file_size=logic.MAX_UPLOAD, on_upload=uploaded) \
                .props("accept=.csv data-testid=ident-upload")

    @app.get("/api/studies/{name}/{file:path}")
    def study_file(name: str, file: str):
        """A report or figure of a stored study; unsafe names 400, unknown ones 404."""
        from fastapi import HTTPException
        from fastapi.responses import FileResponse

        from manipcad.workspace import check_name

        try:
            check_name(name, "study")
            check_name(file, "file")
        except InputError as exc:
            raise HTTPException(400, str(exc)) from None
        try:
            path = logic.study_file(ws(), name, file)
        except InputError as exc:
            raise HTTPException(404, str(exc)) from None
        return FileResponse(path)

    @app.get("/api/items/{kind}/{name:path}")
    def item_file(kind: str, name: str):
        """A workspace item's file (robots, trajectories, regulators); names checked: a
        traversal (``../``), an absolute path or an unknown kind gets 400, a missing item 404."""
        from fastapi import HTTPException
        from fastapi.responses import FileResponse

        from manipcad.workspace import check_name

        if kind not in ("robots", "trajectories", "regulators", "motors", "gears"):
            raise HTTPException(400, f"{kind!r}: not a file kind")
        try:
            check_name(name, "name")
        except InputError as exc:
            raise HTTPException(400, str(exc)) from None
        w = ws()
        try:
            w.get(f"{kind}/{name}")
            path = w.resolve(kind, name)
        except InputError as exc:
            raise HTTPException(404, str(exc)) from None
        return FileResponse(path)
