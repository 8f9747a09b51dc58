"""The Trajectories page: a motion law from a form (joint laws, point to point, via
points, gripper line or circle), previewed and saved in the workspace."""

from __future__ import annotations

from typing import Any

import numpy as np
from nicegui import ui

from manipcad.errors import InputError, ManipcadError
from manipcad.ui import logic
from manipcad.ui.pages import common


async def page() -> None:
    S = await common.connected()
    with common.frame("Trajectories"):
        show, clear = common.error_label()
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
            arm = common.robot()
            data: dict[str, Any] = {"type": law.value}
            for key, inp in fields.items():
                if key == "points":
                    rows = [common.numbers(r, f"points[{k}]", "trajectory form")
                            for k, r in enumerate(str(inp.value).split(";"))]
                    data[key] = [r * arm.n if len(r) == 1 else r for r in rows]
                    continue
                vals = common.numbers(inp.value, key, "trajectory form")
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
                d = common.numbers(fields["move"].value, "move", "trajectory form")
                if len(d) != 3:
                    raise InputError("trajectory form", "move", "expected x, y, z in m")
                p0 = logic.tool_position(arm, data["q0"])
                data["p_start"] = [float(x) for x in p0]
                data["p_end"] = [float(x) for x in p0 + np.asarray(d)]
            if law.value == "circle":   # centred at the tool's position at q0 + offset
                d = common.numbers(fields["offset"].value, "offset", "trajectory form")
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
                item = logic.save_trajectory_to(common.ws(), traj, name.value, force=force.value)
            except ManipcadError as exc:
                show(exc)
                return
            S["trajectory"] = item.name
            ui.notify(f"saved {item.ref}")
            listing.refresh()

        async def uploaded(e) -> None:
            clear()
            try:
                data, ref = await e.file.read(), S["robot"]

                def add():  # in a worker thread: the robot's loading too
                    w = common.ws()
                    return logic.add_upload(w, e.file.name, data, kind="trajectories",
                                            robot=logic.load_robot_ref(w, ref)[0])

                item = await common.off_loop(add)
            except (ManipcadError, OSError) as exc:
                show(exc)
                return
            S["trajectory"] = item.name
            ui.notify(f"added {item.ref}")
            listing.refresh()

        ui.upload(label="Or upload a trajectory file (.yaml)", auto_upload=True,
                  max_file_size=logic.MAX_UPLOAD, on_upload=uploaded,
                  on_rejected=common.upload_refused(show, ".yaml or .yml")) \
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
            names = [i.name for i in common.ws().list("trajectories")]
            ui.label("In the workspace (pick the current one):")

            def chosen(e) -> None:
                S["trajectory"] = e.value

            ui.select(names, value=S["trajectory"] if S["trajectory"] in names
                      else None, on_change=chosen, label="Current trajectory").classes("w-64")

        listing()
        preview = ui.column().classes("w-full")
