"""The Simulation page: a closed-loop run in the worker process, its progress, and
the stored result's figures."""

from __future__ import annotations

from nicegui import ui

from manipcad.errors import InputError
from manipcad.ui import logic, worker
from manipcad.ui.pages import common
from manipcad.ui.worker import SimSpec


async def page() -> None:
    S = await common.connected()
    worker.prestart()                   # this page runs jobs: have a worker ready
    with common.frame("Simulation"):
        show, clear = common.error_label()
        w = common.ws()
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
        panel = common.JobPanel("sim", SimSpec, show, clear)
        figs = ui.column().classes("w-full")

        def form_spec() -> SimSpec:
            if not traj.value:
                raise InputError("simulation form", "trajectory", "pick a trajectory "
                                 "(make one on the Trajectories page)")
            return SimSpec(workspace=str(common.SERVER["ws"]), robot=S["robot"],
                           trajectory=traj.value,
                           regulators=list(dict.fromkeys(   # each once, in order
                               r for r in [reg.value, *(more.value or [])] if r)),
                           t_end=common.numbers(t_end.value, "t_end", "simulation form")[0]
                           if str(t_end.value).strip() else None,
                           dt=common.numbers(dt.value, "dt", "simulation form")[0],
                           name=name.value or None, save_diverged=keep.value)

        def done(job) -> None:
            panel.status.text = (f"done: stored results/{job.result} in {job.wall:.3g} s; "
                                 f"max |e| = {job.metrics.get('max_error', float('nan')):.3g}")
            figs.clear()
            with figs:
                common.job_notes(job)
                box = ui.column().classes("w-full")

                def draw(q: str, name: str = job.result) -> None:
                    box.clear()
                    with box:
                        ui.plotly(logic.overlay_figure(common.ws(), [name], q)).classes("w-full")

                ui.toggle(common.QUANTITIES, value="error", on_change=lambda e: draw(e.value)) \
                    .move(target_index=0)
                draw("error")
                rows, verdict = logic.check_rows(common.ws(), job.result)
                ui.label(verdict).props("data-testid=sim-verdict").classes(
                    "text-negative" if verdict.startswith("FAIL") else "")
                ui.table(columns=[{"name": c, "label": c, "field": c} for c in (
                    "joint", "check", "value", "limit", "unit", "verdict")], rows=rows) \
                    .props("dense flat data-testid=sim-checks")

        panel.controls("Simulate", form_spec, done)
