"""``manipcad ui``: the main-menu dialogue in the browser (see :mod:`manipcad.ui`).

::

    manipcad ui [--ws DIR] [--port 8080] [--host 127.0.0.1] [--open] [--token T]
"""

from __future__ import annotations

from typing import Annotated

import typer

from manipcad.cli.app import app, guarded


@app.command("ui")
@guarded
def ui_command(
    ws: Annotated[str | None, typer.Option(
        "--ws", help="Workspace folder (made if missing; default ./manipcad-ws or "
        "$MANIPCAD_WORKSPACE).")] = None,
    port: Annotated[int, typer.Option("--port", help="TCP port.")] = 8080,
    host: Annotated[str, typer.Option(
        "--host", help="Address to bind; any but loopback needs a token.")] = "127.0.0.1",
    open_browser: Annotated[bool, typer.Option("--open", help="Open a browser tab.")] = False,
    token: Annotated[str | None, typer.Option(
        "--token", help="Token every request must carry (?token=T, then a cookie); "
        "generated and printed when --host is not loopback.")] = None,
) -> None:
    """Start the designer's web application over a workspace (local, Ctrl-C stops it)."""
    # deferred: start-up cost: keeps manipcad.ui out of the CLI's start
    from manipcad.ui import serve

    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import default_root

    serve(default_root(ws), host=host, port=port, show=open_browser, token=token)
