"""The Drives page's "select automatically" section: every joint's drive chosen from the
catalogue (``manipcad select``; :func:`manipcad.ui.logic.select_drives_along` in a worker
thread, :func:`~manipcad.ui.logic.save_selected`) and the report."""

from __future__ import annotations

from nicegui import run, ui

from manipcad.errors import InputError, ManipcadError
from manipcad.ui import logic
from manipcad.ui.pages import common


def select_form(S, show, clear) -> None:
    """"Select automatically": every joint's drive from the catalogue (``manipcad select``)
    along the current trajectory, the robot saved with them (it becomes the current one),
    and the report: chosen pair, binding check, candidates, alternatives and rejects."""
    ui.label("Select automatically: the lightest catalogue drive of every joint that passes "
             "size's checks along the current trajectory, drive masses included (`manipcad "
             "select`)").classes("text-subtitle1")
    with ui.row().classes("items-end"):
        pay = ui.input("payload range LO, HI [kg]", value="0, 0") \
            .props("data-testid=select-payload")
        obj = ui.select({"mass": "least mass", "rotor_inertia": "least rotor inertia",
                         "power": "least electrical power"}, value="mass",
                        label="objective").classes("w-48").props("data-testid=select-objective")
        mar = ui.input("margin (ratings ≥ M × need) [-]", value="1.1") \
            .props("data-testid=select-margin")
        makers = ui.input("makers (e.g. maxon, faulhaber)", value="") \
            .props("data-testid=select-makers")
        types = ui.input("gear types (e.g. planetary, harmonic, direct)", value="") \
            .props("data-testid=select-gear-types")
        name = ui.input("robot name", value=f"{S['robot'].split('/')[-1]}-selected") \
            .props("data-testid=select-name")
        force = ui.checkbox("replace", value=False)
    out = ui.column().classes("w-full")

    async def go() -> None:
        clear()
        out.clear()
        try:
            arm, traj = common.trajectory("select form")
            lohi = common.numbers(pay.value, "payload range", "select form")
            if len(lohi) != 2:
                raise InputError("select form", "payload range", f"expected LO, HI in kg, "
                                 f"got {pay.value!r}")
            margin = common.numbers(mar.value, "margin", "select form")[0]
            w = common.ws()
            with out:
                ui.spinner()
            sel = await run.io_bound(
                logic.select_drives_along, arm, traj, payload_range=lohi,
                objective=obj.value, margin=margin, makers=makers.value,
                gear_types=types.value, parts=w.root)
            item = logic.save_selected(w, sel, name.value, force=force.value)
        except ManipcadError as exc:
            out.clear()
            show(exc)
            return
        out.clear()
        S["robot"] = item.ref
        force.value = True
        with out:
            ui.label(f"saved {item.ref} (now the current robot): drive masses on the links, "
                     f"fixed point in {sel.iterations} sweeps, "
                     + ("verified by size's checks" if sel.verified else "not verified")
                     + f"; total drive mass {sel.total_drive_mass:.3g} kg") \
                .props("data-testid=select-result")
            cols = [("joint", "joint"), ("chosen", "chosen (motor + gear)"),
                    ("ratio", "i_r"), ("mass", "mass [kg]"),
                    ("objective", f"{sel.objective}"), ("binding", "binding check"),
                    ("margin", "margin"), ("candidates", "feasible / evaluated / considered"),
                    ("mounted_on", "mass on")]
            ui.table(columns=[{"name": k, "label": lab, "field": k} for k, lab in cols],
                     rows=logic.selection_rows(sel), row_key="joint") \
                .props("dense flat data-testid=select-table").mark("select-table")
            cols = [("joint", "joint"), ("kind", ""), ("candidate", "candidate"),
                    ("objective", sel.objective), ("note", "binding check / why not")]
            ui.table(columns=[{"name": k, "label": lab, "field": k} for k, lab in cols],
                     rows=logic.alternative_rows(sel), row_key="key", pagination=12) \
                .props("dense flat data-testid=select-alternatives").mark("select-alternatives")

    ui.button("Select the drives automatically", on_click=go) \
        .props("data-testid=select-run")

