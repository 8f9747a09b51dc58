"""The Synthesis page: a method's regulators synthesized for the current robot and
saved in the workspace, with their realization complexity."""

from __future__ import annotations

from nicegui import ui
from nicegui.run import io_bound as run_io

from manipcad.control import realization_complexity
from manipcad.errors import InputError, ManipcadError
from manipcad.ui import logic
from manipcad.ui.pages import common


async def page() -> None:
    S = await common.connected()
    with common.frame("Synthesis"):
        show, clear = common.error_label()
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
                    pairs[key.strip()] = common.numbers(val, f"spec.{key.strip()}",
                                                 "synthesis form")[0]
                per = common.numbers(period.value, "period", "synthesis form")[0] \
                    if str(period.value).strip() else None
                nm = name.value or f"{method.value}-{S['robot'].split('/')[-1]}"
                picked = [int(x) - 1 if x.isdigit() else x for x in
                          (p.strip() for p in str(joints.value).split(",")) if x]
                busy.text = f"synthesizing {method.value}..."
                # in a thread: a gain table takes seconds, the page stays live meanwhile
                root, arm, m, f = common.SERVER["ws"], common.robot(), method.value, force.value
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
                    c = realization_complexity(reg)
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
                i.name for i in common.ws().list("regulators")) or "none"))

        listing()
        out = ui.column().classes("w-full")
