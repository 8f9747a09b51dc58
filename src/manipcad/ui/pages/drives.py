"""The Drives page: the motor and gear libraries, parts attached to joints, what the
current trajectory needs from the drives, and the gear-ratio sweep."""

from __future__ import annotations

import base64
from typing import Any

from nicegui import ui

from manipcad.errors import InputError, ManipcadError
from manipcad.sizing import required_drive
from manipcad.ui import logic
from manipcad.ui.pages import common
from manipcad.ui.pages.drive_select import select_form


async def page() -> None:
    S = await common.connected()
    with common.frame("Drives"):
        show, clear = common.error_label()
        ui.markdown("Motors and gears: the catalog's and your own (kept in the workspace), "
                    "attached to the joints of the current robot; then what the current "
                    "trajectory needs from the drives against their limits (`manipcad "
                    "size`) and the gear-ratio sweep (`manipcad size --ratio-sweep`).")

        # ---- the libraries
        @ui.refreshable
        def libraries() -> None:
            w = common.ws()
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
                            vals = common.numbers(inp.value, key, f"{kind}/{name.value}")
                            form[key] = vals if key == "M_f" and len(vals) > 1 else (
                                int(vals[0]) if key == "direction" else vals[0])
                        item = logic.add_part(common.ws(), kind, name.value, form,
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
            w = common.ws()
            sel["motor"].set_options([r["ref"] for r in logic.library_rows(w, "motors")])
            sel["gear"].set_options(["(none)", *(r["ref"] for r in
                                                logic.library_rows(w, "gears"))])

        def attach_form() -> None:
            try:
                arm = common.robot()
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
                            common.ws(), common.robot(), joint.value, motor or "",
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
        select_form(S, show, clear)

        # ---- what the trajectory needs, against the limits
        ui.label("Along the current trajectory").classes("text-subtitle1")
        out = ui.column().classes("w-full")

        def run() -> None:
            clear()
            out.clear()
            try:
                arm, traj = common.trajectory("drives")
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
                arm, traj = common.trajectory("sweep form")
                jv = str(sj.value).strip()
                joint = int(jv) - 1 if jv.isdigit() else jv
                if isinstance(joint, int) and not 0 <= joint < arm.n:
                    raise InputError("sweep form", "joint", f"{jv}: expected 1..{arm.n} or "
                                     f"a name ({', '.join(arm.joint_names)})")
                if isinstance(joint, str) and joint not in arm.joint_names:
                    raise InputError("sweep form", "joint", f"no joint {jv!r}; joints: "
                                     f"{', '.join(arm.joint_names)}")
                n = common.numbers(nr.value, "ratios", "sweep form")[0]
                if n != int(n):
                    raise InputError("sweep form", "ratios", f"a whole number, got {n}")
                sw = logic.ratio_sweep_for(
                    arm, traj, joint, common.numbers(lo.value, "lowest", "sweep form")[0],
                    common.numbers(hi.value, "highest", "sweep form")[0], int(n))
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

