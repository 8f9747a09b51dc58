"""The file routes: a stored study's reports and figures, a workspace item's file."""

from __future__ import annotations

from fastapi import HTTPException
from fastapi.responses import FileResponse

from manipcad.errors import InputError
from manipcad.ui import logic
from manipcad.ui.pages import common
from manipcad.workspace import check_name


def study_file(name: str, file: str):
    """A report or figure of a stored study; unsafe names 400, unknown ones 404."""
    try:
        check_name(name, "study")
        check_name(file, "file")
    except InputError as exc:
        raise HTTPException(400, str(exc)) from None
    try:
        path = logic.study_file(common.ws(), name, file)
    except InputError as exc:
        raise HTTPException(404, str(exc)) from None
    return FileResponse(path)


def item_file(kind: str, name: str):
    """A workspace item's file (robots, trajectories, regulators); names checked: a
    traversal (``../``), an absolute path or an unknown kind gets 400, a missing item 404."""
    if kind not in ("robots", "trajectories", "regulators", "motors", "gears"):
        raise HTTPException(400, f"{kind!r}: not a file kind")
    try:
        check_name(name, "name")
    except InputError as exc:
        raise HTTPException(400, str(exc)) from None
    w = common.ws()
    try:
        w.get(f"{kind}/{name}")
        path = w.resolve(kind, name)
    except InputError as exc:
        raise HTTPException(404, str(exc)) from None
    return FileResponse(path)
