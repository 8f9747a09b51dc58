"""The pages of ``manipcad ui`` (NiceGUI), following the designer's path (paper Fig. 1).

Main menu → Robots → Drives → Trajectories → Requirements → method → Synthesis →
Simulation → Results → Identification, and the automated Design: one module per page,
each an ``async def page()`` that lays out calls of :mod:`manipcad.ui.logic` (the same
Python API as the CLI) and shows a bad value or file as one line naming the file or form, the field
and the reason, never a traceback. What the pages share (the frame with the main
menu, the tab's selection, the error line, number fields) is in
:mod:`manipcad.ui.pages.common`; the file routes in :mod:`manipcad.ui.pages.files`.

A new page: a module here with its ``page()``, a line in :data:`PAGES` and one in
:data:`~manipcad.ui.pages.common.MENU`.
"""

from __future__ import annotations

from nicegui import app, ui

from manipcad.ui.pages import (
    design,
    drives,
    files,
    identification,
    main_menu,
    requirements,
    results,
    robots,
    simulation,
    synthesis,
    trajectories,
)
from manipcad.ui.pages.common import MENU, SERVER, state

__all__ = ["PAGES", "SERVER", "register", "state"]

#: the page served at each path of the main menu (:data:`~manipcad.ui.pages.common.MENU`)
PAGES = {"/": main_menu.page, "/robots": robots.page, "/drives": drives.page,
         "/trajectories": trajectories.page, "/requirements": requirements.page,
         "/synthesis": synthesis.page, "/simulation": simulation.page,
         "/results": results.page, "/identification": identification.page,
         "/design": design.page}


def register() -> None:
    """Register the pages and the file routes on NiceGUI's application (once per app;
    the user simulation of the tests resets NiceGUI and registers them again)."""
    for path, _ in MENU:
        ui.page(path)(PAGES[path])
    app.get("/api/studies/{name}/{file:path}")(files.study_file)
    app.get("/api/items/{kind}/{name:path}")(files.item_file)
