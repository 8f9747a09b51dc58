"""``manipcad ui``: the main-menu dialogue in the browser (see :mod:`manipcad.ui`).

::

    manipcad ui [--ws DIR] [--port 8080] [--host 127.0.0.1] [--open] [--token T]
"""

from __future__ import annotations

from manipcad.cli.app import app, guarded
from manipcad.cli.options import option


@app.command("ui")
@guarded
def ui_command(
    ws: option(str | None, "--ws", "Workspace folder (made if missing; default ./manipcad-ws or "
               "$MANIPCAD_WORKSPACE).") = None,
    port: option(int, "--port", "TCP port.") = 8080,
    host: option(str, "--host", "Address to bind; any but loopback needs a token.") = "127.0.0.1",
    open_browser: option(bool, "--open", "Open a browser tab.") = False,
    token: option(str | None, "--token", "Token every request must carry (?token=T, then a "
                  "cookie); generated and printed when --host is not loopback.") = None,
) -> None:
    """Start the designer's web application over a workspace (local, Ctrl-C stops it)."""
    # deferred: start-up cost: keeps manipcad.ui out of the CLI's start
    from manipcad.ui import serve

    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import default_root

    serve(default_root(ws), host=host, port=port, show=open_browser, token=token)
