"""``manipcad ui``: the main-menu dialogue as a local web application (NiceGUI + Plotly).

::

    manipcad ui [--ws DIR] [--port 8080] [--host 127.0.0.1] [--open] [--token T]

Pages follow the designer's path of the paper's Fig. 1 (main menu, robots,
trajectories, requirements → method, synthesis, simulation, results); each calls
the same Python API as the CLI (:mod:`manipcad.ui.logic`). Bound to 127.0.0.1 by
default (requests naming another host refused); any other address needs a
token that every request carries (:mod:`manipcad.ui.security`). docs/ui.md has
the tour and screenshots.
"""

from __future__ import annotations

from pathlib import Path

from manipcad.errors import InputError
from manipcad.ui.logic import MAX_UPLOAD, open_workspace
from manipcad.ui.security import (
    MULTIPART_SLACK,
    BodyCap,
    HostCheck,
    TokenGate,
    is_loopback,
    quiet_disconnects,
    token_for,
)
from manipcad.ui.worker import stop_spare

#: seconds a page's connection may stall before NiceGUI drops it (and the page reloads)
RECONNECT_TIMEOUT = 10.0


def serve(ws: str | Path, *, host: str = "127.0.0.1", port: int = 8080, show: bool = False,
          token: str | None = None, announce=print) -> None:
    """Run the application until interrupted (blocks).

    Args:
        ws: the workspace folder (made if it is not one yet).
        host: the address to bind; not loopback needs a token.
        port: the TCP port.
        show: open a browser tab.
        token: the token every request must carry; None: none on loopback, a new
            one (printed through ``announce``) elsewhere.
        announce: where the address (with the token) is printed.

    Raises:
        InputError: a workspace that cannot be opened or made, a bad port.
    """
    from nicegui import app, ui  # deferred: start-up cost: nicegui loaded on first use

    # deferred: start-up cost: manipcad.ui.pages loads fastapi, nicegui
    from manipcad.ui import pages

    if not 0 < int(port) < 65536:
        raise InputError("--port", "", f"must be 1..65535, got {port}")
    root = Path(ws)
    open_workspace(root).close()
    pages.SERVER["ws"] = str(root)
    pages.register()
    required = token_for(host, token)
    url = f"http://{host}:{port}/"
    # the body cap first, then the gate outside it: without the token nothing is read
    app.add_middleware(BodyCap, limit=MAX_UPLOAD + MULTIPART_SLACK)
    if required:
        app.add_middleware(TokenGate, token=required)
        url += f"?token={required}"
    elif is_loopback(host):        # no token: only loopback names (no DNS rebinding)
        app.add_middleware(HostCheck)
    quiet_disconnects(app)         # a page left while loading: no traceback per cut request

    # the worker that runs simulations, verifications and studies is started when a page
    # that runs them is opened (pages.prestart), not here: a session that only looks at
    # robots, trajectories or drives never pays its imports (2.5-3 s of CPU)
    app.on_shutdown(stop_spare)
    announce(f"manipcad ui on {url} (workspace {root.resolve()}); Ctrl-C stops it")
    # a run on every core, or a large figure drawn in another tab of the same browser
    # process, can hold a tab's JavaScript for seconds on a small machine: with NiceGUI's
    # default (3 s, a ping timeout of 2 s) the tab's connection then dropped and the page
    # reloaded, losing what the designer had just picked; 10 s gives a 4 s ping timeout
    ui.run(host=host, port=int(port), title="manipcad", reload=False, show=show,
           show_welcome_message=False, favicon="🦾", uvicorn_logging_level="warning",
           reconnect_timeout=RECONNECT_TIMEOUT)
