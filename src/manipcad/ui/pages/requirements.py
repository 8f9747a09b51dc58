"""The Requirements → method page: the designer's requirements in, the rule base's
recommended synthesis methods out, best first; verified by simulation on request."""

from __future__ import annotations

import asyncio
from typing import Any

from nicegui import ui

from manipcad.errors import InputError, ManipcadError
from manipcad.ui import logic, worker
from manipcad.ui.pages import common
from manipcad.ui.worker import SimulationJob, VerifySpec


async def page() -> None:
    S = await common.connected()
    worker.prestart()                   # this page runs jobs: have a worker ready
    with common.frame("Requirements → method"):
        show, clear = common.error_label()
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
                "accuracy": common.numbers(acc.value, "accuracy", "requirements form")[0]
                if str(acc.value).strip() else None,
                "overshoot_allowed": over.value, "fast_action": fast.value,
                "gripper_speed": common.numbers(speed.value, "gripper_speed",
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
                arm = common.robot()
                traj = logic.load_trajectory_ref(common.ws(), S["trajectory"], arm) \
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
                job = SimulationJob(VerifySpec(str(common.SERVER["ws"]), S["robot"],
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
