"""The Design page: the automated design (``manipcad design``) from a requirements form.

Requirements, trajectories, payload range, uncertainty and counterbalance in; the
design runs in the worker process (:class:`~manipcad.ui.worker.DesignSpec`, the same
:func:`manipcad.design.run_design` as the command) with its progress; the result is
stored as ``studies/NAME`` and its verdict, methods and worst-case errors shown, with a
link to its report.
"""

from __future__ import annotations

from typing import Any

from nicegui import ui

from manipcad.errors import InputError, ManipcadError
from manipcad.ui import worker
from manipcad.ui.pages import common
from manipcad.ui.worker import DesignSpec

FORM = "design form"


def read_form(fields: dict[str, Any], joints: list[str]) -> dict[str, Any]:
    """The requirement fields and the design's settings from the form's values.

    Raises:
        InputError: a field that is not a number where one is needed (named).

    Example:
        >>> f = read_form({"accuracy": "1e-3", "overshoot": True, "fast": False,
        ...                "backlash": False, "elasticity": False, "joint": None,
        ...                "payload": "0, 1", "uncertainty": "5", "samples": "3",
        ...                "period": "1e-3", "counterbalance": "auto", "methods": "4"},
        ...               ["q1"])
        >>> f["requirements"]["accuracy"], f["payload_range"], f["uncertainty"]
        (0.001, (0.0, 1.0), 0.05)
    """
    def num(key: str, name: str) -> float:
        return common.numbers(fields[key], name, FORM)[0]

    pay = (common.numbers(fields["payload"], "payload range", FORM)
           if str(fields["payload"]).strip() else [0.0])
    if len(pay) not in (1, 2):
        raise InputError(FORM, "payload range", f"expected LO, HI in kg, got "
                         f"{fields['payload']!r}")
    lo, hi = (pay[0], pay[-1])
    unc = num("uncertainty", "uncertainty")
    if not 0 <= unc < 100:
        raise InputError(FORM, "uncertainty", f"must be a percentage in [0, 100), got {unc:g}")
    samples, methods = num("samples", "samples"), num("methods", "methods")
    for name, v in (("samples", samples), ("methods", methods)):
        if v != int(v) or v < 1:
            raise InputError(FORM, name, f"must be a whole number >= 1, got {v:g}")
    joint = fields.get("joint")
    if joint is not None and joint not in joints:
        raise InputError(FORM, "joint", f"no joint {joint!r}")
    req = {"accuracy": num("accuracy", "accuracy"),
           "overshoot_allowed": fields["overshoot"], "fast_action": fields["fast"],
           "transmission": {"backlash": fields["backlash"],
                            "elasticity": fields["elasticity"]}}
    if joint is not None:
        req["joint"] = joint
    return {"requirements": req, "payload_range": (lo, hi), "uncertainty": unc / 100.0,
            "samples": int(samples), "period": num("period", "period"),
            "counterbalance": fields["counterbalance"], "max_methods": int(methods)}


async def page() -> None:
    S = await common.connected()
    worker.prestart()                   # this page runs jobs: have a worker ready
    with common.frame("Design"):
        show, clear = common.error_label()
        w = common.ws()
        trajs = [i.name for i in w.list("trajectories")]
        try:
            joints = list(common.robot().joint_names)
        except ManipcadError as exc:
            joints = []
            show(exc)
        yes_no = {True: "yes", False: "no"}
        ui.label("Requirements").classes("text-subtitle1")
        with ui.grid(columns=3).classes("gap-2"):
            acc = ui.input("accuracy: largest error [rad|m]", value="1e-3") \
                .props("data-testid=design-accuracy")
            over = ui.select(yes_no, value=True, label="overshoot allowed")
            fast = ui.select(yes_no, value=False, label="fastest action")
            back = ui.select(yes_no, value=False, label="backlash")
            elas = ui.select(yes_no, value=False, label="elasticity")
            joint = ui.select({None: "every joint", **{j: j for j in joints}}, value=None,
                              label="joint designed")
        ui.label("Operating cases").classes("text-subtitle1")
        with ui.grid(columns=3).classes("gap-2"):
            traj = ui.select(trajs, value=[S["trajectory"]] if S["trajectory"] in trajs
                             else trajs[:1], multiple=True, label="Trajectories") \
                .props("use-chips data-testid=design-traj")
            pay = ui.input("payload range LO, HI [kg]", value="0, 0")
            unc = ui.input("uncertainty ± [%]", value="5").mark("design-uncertainty")
            samples = ui.input("uncertainty samples", value="5")
            period = ui.input("control period [s]", value="1e-3")
            cb = ui.select({"none": "report only", "auto": "apply"}, value="none",
                           label="counterweights")
            methods = ui.input("methods verified (the rules' first)", value="4")
            name = ui.input("Design name", value="design").props("data-testid=design-name")
        panel = common.JobPanel("design", DesignSpec, show, clear)
        out = ui.column().classes("w-full")

        def form_spec() -> DesignSpec:
            if not traj.value:
                raise InputError(FORM, "trajectories", "pick at least one trajectory "
                                 "(make one on the Trajectories page)")
            f = read_form({"accuracy": acc.value, "overshoot": over.value,
                           "fast": fast.value, "backlash": back.value,
                           "elasticity": elas.value, "joint": joint.value,
                           "payload": pay.value, "uncertainty": unc.value,
                           "samples": samples.value, "period": period.value,
                           "counterbalance": cb.value, "methods": methods.value},
                          joints)
            return DesignSpec(workspace=str(common.SERVER["ws"]), robot=S["robot"],
                              trajectories=list(traj.value), name=name.value, **f)

        def done(job) -> None:
            m = job.metrics
            panel.status.text = (f"done in {job.wall:.3g} s: design {m['status']}; stored "
                                 f"studies/{job.result}")
            out.clear()
            with out:
                common.job_notes(job)
                if m.get("failure"):
                    ui.label(m["failure"]["text"]).classes("text-negative")
                rows = [{"joint": jn, "method": m["methods"].get(jn) or "-",
                         "worst": f"{e:.3g}" if isinstance(e, float) else str(e)}
                        for jn, e in m["worst_case_error"].items()]
                ui.table(columns=[{"name": c, "label": lab, "field": c} for c, lab in (
                    ("joint", "joint"), ("method", "method"),
                    ("worst", f"worst-case max |e| (accuracy {m['accuracy']:g})"))],
                    rows=rows, row_key="joint").props("dense flat data-testid=design-table")
                for f in m["files"]:
                    ui.link(f, f"/api/studies/{job.result}/{f}", new_tab=True)

        panel.controls("Design", form_spec, done, what=lambda job: "design ")
