"""The main menu: the designer's path (paper Fig. 1), a card per page with the
workspace's count of its items."""

from __future__ import annotations

from nicegui import ui

from manipcad.ui.pages import common


async def page() -> None:
    await common.connected()
    with common.frame("Main menu"):
        ui.markdown("The designer's path (paper Fig. 1): pick a **robot**, make a "
                    "**trajectory**, state **requirements** and get the recommended synthesis "
                    "**method**, **synthesize** the regulators, **simulate** and compare the "
                    "**results**. Everything is kept in the workspace.")
        w = common.ws()
        with ui.row():
            for path, text in common.MENU[1:]:
                kind = {"/robots": "robots", "/trajectories": "trajectories",
                        "/synthesis": "regulators", "/results": "results"}.get(path)
                count = f" ({len(w.list(kind))} in the workspace)" if kind else ""
                with ui.card().classes("w-64"):
                    ui.link(text, path).classes("text-h6")
                    ui.label(count)
