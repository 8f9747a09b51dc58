"""The Results and studies page: stored results filtered and overlaid; the paper's
studies run in the worker process and their reports linked."""

from __future__ import annotations

from nicegui import ui

from manipcad.errors import ManipcadError
from manipcad.ui import logic, worker
from manipcad.ui.pages import common
from manipcad.ui.worker import StudySpec
from manipcad.workspace import check_name


async def page() -> None:
    await common.connected()
    worker.prestart()                   # this page runs jobs: have a worker ready
    with common.frame("Results and studies"):
        show, clear = common.error_label()
        with ui.row().classes("items-end"):
            where = ui.input("filter, e.g. max_error<1e-3 and status=ok", value="") \
                .classes("w-96").props("data-testid=res-where")
            quantity = ui.select(common.QUANTITIES, value="error", label="Quantity")
        cols = ["name", "status", "checks", "max_error", "rms_error", "peak_torque",
                "peak_current", "peak_power", "energy", "created"]
        table = ui.table(columns=[{"name": c, "label": c, "field": c, "sortable": True}
                                  for c in cols], rows=[], row_key="name",
                         selection="multiple").props("dense flat data-testid=res-table")

        def load() -> None:
            clear()
            try:
                table.rows = logic.result_rows(common.ws(), where.value.strip() or None)
            except ManipcadError as exc:
                show(exc)
                table.rows = []
            table.update()

        def overlay() -> None:
            clear()
            names = [r["name"] for r in table.selected] or [r["name"] for r in table.rows]
            figs.clear()
            try:
                fig = logic.overlay_figure(common.ws(), names, quantity.value)
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

        def show_checks() -> None:
            clear()
            picked = [r["name"] for r in table.selected] or [r["name"] for r in table.rows]
            figs.clear()
            with figs:
                for nm in picked[:1]:
                    rows, verdict = logic.check_rows(common.ws(), nm)
                    ui.label(f"{nm}: {verdict or 'stored without checks'}") \
                        .props("data-testid=res-verdict")
                    ui.table(columns=[{"name": c, "label": c, "field": c} for c in (
                        "joint", "check", "value", "limit", "unit", "verdict")], rows=rows) \
                        .props("dense flat data-testid=res-checks")

        ui.button("Checks of the selected result (docs/checks.md)", on_click=show_checks) \
            .props("data-testid=res-checks-run")
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
        panel = common.JobPanel("study", StudySpec, show, clear)
        snotes = ui.column().classes("gap-0")

        def study_spec() -> StudySpec:
            spec = StudySpec(
                workspace=str(common.SERVER["ws"]), study=kind.value, name=sname.value,
                t_end=common.numbers(st_end.value, "t_end", "study form")[0]
                if str(st_end.value).strip() else None,
                methods=smethods.value.strip() or None)
            check_name(spec.name, "study name")
            return spec

        def ended(job) -> None:
            snotes.clear()
            with snotes:
                common.job_notes(job)

        def done(job) -> None:
            report = "report.html" if "report.html" in job.metrics.get("files", []) else None
            panel.status.text = f"done: stored studies/{job.result} in {job.wall:.3g} s"
            studies.refresh()
            if report:
                ui.navigate.to(f"/api/studies/{job.result}/{report}", new_tab=True)

        panel.controls("Run the study", study_spec, done, ended=ended, period=0.5,
                       what=lambda job: f"{job.spec.study} ",
                       note=lambda spec: f"starting the worker for {spec.study}...")

        @ui.refreshable
        def studies() -> None:
            w = common.ws()
            for item in w.list("studies"):
                with ui.row().classes("items-center").props(
                        f"data-testid=study-{item.name}"):
                    ui.label(item.name).classes("font-bold")
                    for f in logic.study_files(w, item.name):
                        ui.link(f, f"/api/studies/{item.name}/{f}", new_tab=True)
            if not w.list("studies"):
                ui.label("none yet").classes("text-caption")

        studies()
