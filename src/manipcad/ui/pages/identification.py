"""The Identification page: an unknown payload mass from measured torques or currents,
uploaded as CSV or taken from a stored simulation result of the workspace (its recorded
q, q̇ and joint torques, as ``manipcad identify ROBOT --data RESULT``)."""

from __future__ import annotations

from nicegui import ui

from manipcad.errors import InputError, ManipcadError
from manipcad.ui import logic
from manipcad.ui.pages import common


async def page() -> None:
    await common.connected()
    with common.frame("Identification"):
        show, clear = common.error_label()
        ui.label("Upload measured joint torques or motor currents along a motion (CSV: t, "
                 "q1.., qd1.., qdd1.., tau1.. or current1..; SI units) of the picked "
                 "robot, or take a stored simulation result's recorded motion and torques; "
                 "get the payload mass with its uncertainty (manipcad identify).")
        com = ui.input("payload centre of mass x, y, z [m] in the last link's frame",
                       value="0, 0, 0").classes("w-96")
        out = ui.column().classes("w-full")

        def centre() -> list[float]:
            c = common.numbers(com.value, "com", "identification form")
            if len(c) != 3:
                raise InputError("identification form", "com", "expected x, y, z")
            return c

        def shown(est) -> None:
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

        async def uploaded(e) -> None:
            clear()
            out.clear()
            try:
                c = centre()
                data, arm = await e.file.read(), common.robot()
                est = await common.off_loop(logic.identify_upload, arm, e.file.name, data, com=c)
            except ManipcadError as exc:
                show(exc)
                return
            shown(est)

        ui.upload(label="Upload measured data (.csv)", auto_upload=True,
                  max_file_size=logic.MAX_UPLOAD, on_upload=uploaded,
                  on_rejected=common.upload_refused(show, ".csv")) \
            .props("accept=.csv data-testid=ident-upload")

        async def from_result() -> None:
            clear()
            out.clear()
            try:
                if not stored.value:
                    raise InputError("identification form", "result", "pick a stored result")
                c, arm, name, root = centre(), common.robot(), stored.value, common.SERVER["ws"]
                # the workspace opened in the worker thread (its index belongs to it)
                est = await common.off_loop(lambda: logic.identify_result(
                    logic.open_workspace(root), name, arm, com=c))
            except ManipcadError as exc:
                show(exc)
                return
            shown(est)

        with ui.row().classes("items-center"):
            names = logic.result_names(common.ws())
            stored = ui.select(names, value=names[-1] if names else None,
                               label="or a stored simulation result").classes("w-64") \
                .props("data-testid=ident-result")
            ui.button("Identify from the result", on_click=from_result) \
                .props("data-testid=ident-result-run")
