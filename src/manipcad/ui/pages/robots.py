"""The Robots page: pick or upload a robot; its joints and drives as a table, the
arm as a stick figure turned with view sliders and posed with joint sliders (it opens
at :func:`~manipcad.ui.logic.start_pose`, a pose within the joint limits, and the
figure's caption names the pose the sliders show)."""

from __future__ import annotations

import math

from nicegui import ui

from manipcad.errors import ManipcadError
from manipcad.report.projection import VIEW
from manipcad.ui import logic
from manipcad.ui.pages import common


async def page() -> None:
    S = await common.connected()
    with common.frame("Robots"):
        show, clear = common.error_label()
        w = common.ws()
        pick = ui.select(logic.robot_choices(w), value=S["robot"], label="Robot") \
            .classes("w-64").props("data-testid=robot-select")
        with ui.row().classes("items-center"):
            name_in = ui.input("Name for an upload (optional)").props("data-testid=upload-name")

            async def uploaded(e) -> None:
                clear()
                try:
                    data, name = await e.file.read(), name_in.value or None
                    item = await common.off_loop(lambda: logic.add_upload(
                        common.ws(), e.file.name, data, kind="robots", name=name))
                except (ManipcadError, OSError) as exc:
                    show(exc)
                    return
                ui.notify(f"added {item.ref}")
                pick.options = logic.robot_choices(common.ws())
                pick.value = item.ref

            ui.upload(label="Upload URDF / YAML / MJCF", auto_upload=True,
                      max_file_size=logic.MAX_UPLOAD, on_upload=uploaded,
                      on_rejected=common.upload_refused(
                          show, ".urdf, .yaml, .yml, .xml or .mjcf")) \
                .props("accept=.urdf,.yaml,.yml,.xml,.mjcf data-testid=robot-upload")
        body = ui.column().classes("w-full")

        def render() -> None:
            body.clear()
            try:
                arm, notes = logic.load_robot_ref(common.ws(), S["robot"])
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
                q = [float(x) for x in logic.start_pose(arm)]   # within the limits
                view = {"az": round(math.degrees(VIEW[0])),
                        "el": round(math.degrees(VIEW[1]))}   # deg, as shown
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
                        plot = ui.plotly(logic.stick_view(arm, q, *VIEW)) \
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
                                                     math.degrees, VIEW)))):
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

                            ui.slider(min=lo, max=hi, step=(hi - lo) / 200, value=q[j],
                                      on_change=moved).props(f"label data-testid=pose-{j}")

        def picked(e) -> None:
            clear()
            S["robot"] = e.value
            render()

        pick.on_value_change(picked)
        render()
