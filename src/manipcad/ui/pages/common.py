"""What every page of ``manipcad ui`` shares: the server's workspace, the tab's
selection and jobs, the page frame with the main menu, the error line and the
form's number fields.

The application serves one workspace (:data:`SERVER`); each browser tab has its own
current robot, trajectory, method and runs (:func:`state`, NiceGUI's per-tab
``app.storage.tab``), so two designers (or two tabs) do not change each other's
selection. Each page waits for its tab's connection before it reads that state.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from nicegui import app, ui

from manipcad.errors import InputError, ManipcadError
from manipcad.ui import logic
from manipcad.ui.worker import SimulationJob

#: the server's state: the workspace root (one per server, set by ``manipcad ui``)
SERVER: dict[str, Any] = {"ws": None}

#: a new tab's selection: robot, trajectory (workspace name), recommended method
DEFAULTS: dict[str, Any] = {"robot": "puma560", "trajectory": None, "method": None}

#: stored series a figure can show, with their units
QUANTITIES = {k: f"{what} [{unit}]" for k, (what, unit) in logic.RESULT_SERIES.items()}

#: jobs (simulations, studies) per tab id: worker handles, kept out of the tab's storage
_JOBS: dict[str, list] = {}

MENU = (("/", "Main menu"), ("/robots", "Robots"), ("/drives", "Drives"),
        ("/trajectories", "Trajectories"), ("/requirements", "Requirements → method"),
        ("/synthesis", "Synthesis"), ("/simulation", "Simulation"),
        ("/results", "Results and studies"), ("/identification", "Identification"),
        ("/design", "Design"))


def state() -> dict[str, Any]:
    """This browser tab's selection (NiceGUI's ``app.storage.tab``, defaults from
    :data:`DEFAULTS`); only once the page's client is connected."""
    tab = app.storage.tab
    for key, value in DEFAULTS.items():
        tab.setdefault(key, value)
    return tab


def jobs() -> list:
    """This tab's worker jobs (simulations and studies), oldest first."""
    return _JOBS.setdefault(ui.context.client.tab_id or "", [])


async def connected() -> dict[str, Any]:
    """Wait for the page's websocket (the tab's identity), then its :func:`state`.

    A page whose browser never connects (a plain HTTP GET, a tab closed or left for
    another page while loading) is deleted by NiceGUI after a while; its building then
    ends here, cancelled, with nothing logged (reading the tab's state of a deleted
    client raised RuntimeError, a traceback in the server log for every such request).
    """
    import asyncio  # deferred: start-up cost: asyncio loaded on first use

    client = ui.context.client
    await client.connected()
    if client.is_deleted or not client.has_socket_connection:
        raise asyncio.CancelledError
    return state()


def ws():
    """The opened workspace."""
    return logic.open_workspace(SERVER["ws"])


def robot():
    """The tab's picked robot (loaded through the workspace API)."""
    return logic.load_robot_ref(ws(), state()["robot"])[0]


def trajectory(form: str, arm=None):
    """The tab's picked trajectory loaded for ``arm`` (default: the tab's robot) through
    the workspace API; one clear error naming ``form`` when none is picked.

    Args:
        form: the form's name in an error (``"sweep form"``).
        arm: the robot the trajectory is for; None: :func:`robot`.

    Returns:
        ``(arm, trajectory)``.

    Raises:
        InputError: no trajectory picked (``form: trajectory: pick or make ...``).
    """
    name = state()["trajectory"]
    if not name:
        raise InputError(form, "trajectory", "pick or make a trajectory first "
                         "(Trajectories page)")
    arm = robot() if arm is None else arm
    return arm, logic.load_trajectory_ref(ws(), name, arm)


def error_text(exc: Exception) -> str:
    """The one line shown for a failed action: the API's message (file: field: reason),
    files named without install or workspace paths (:func:`~manipcad.ui.logic.short_paths`)."""
    text = str(exc) if isinstance(exc, ManipcadError) else f"{type(exc).__name__}: {exc}"
    return logic.short_paths(text, SERVER["ws"])


def frame(title: str):
    """Header with the main menu; returns the page's content column."""
    ui.page_title(f"manipcad · {title}")
    with ui.header(fixed=False).classes("items-center gap-4 bg-blue-grey-9"):
        ui.label("manipcad").classes("text-h6")
        for path, text in MENU:
            ui.link(text, path).classes("text-white")
    # plotly.js (4.5 MB, NiceGUI's full bundle) compiles once the page is idle, so the
    # first figure the designer opens does not wait for it (~1.8 s here, ~0.1 s after)
    ui.run_javascript("(window.requestIdleCallback || setTimeout)"
                      "(() => import('nicegui-plotly'))")
    col = ui.column().classes("w-full p-4 gap-3")
    S = state()
    with col:
        ui.label(title).classes("text-h5").props("data-testid=page-title").mark("page-title")
        with ui.row().classes("text-caption gap-1").props("data-testid=selection"):
            ui.label(f"workspace {Path(SERVER['ws']).resolve()} · robot")
            ui.label().bind_text_from(S, "robot")
            ui.label("· trajectory")
            ui.label().bind_text_from(S, "trajectory", lambda v: v or "-")
    return col


class JobPanel:
    """A page's background jobs of one kind (its :mod:`manipcad.ui.worker` spec type): a
    progress bar and a status line where the panel is made; :meth:`controls` adds the
    run and Cancel buttons (``data-testid`` ``TESTID-run``, ``TESTID-cancel``) and the
    timer that follows the latest such job of the tab, showing its progress and its end
    once (an error in the page's error line, whose ``show`` and ``clear`` of
    :func:`error_label` the panel is given)."""

    def __init__(self, testid: str, kind: type, show, clear) -> None:
        self.testid, self.kind, self.show, self.clear = testid, kind, show, clear
        self.bar = ui.linear_progress(value=0.0, show_value=False).classes("w-full")
        self.status = ui.label("").props(f"data-testid={testid}-status")
        self._shown: dict[str, Any] = {"job": None, "state": None}

    def mine(self) -> list:
        """This tab's jobs of the panel's kind, oldest first."""
        return [j for j in jobs() if isinstance(j.spec, self.kind)]

    def submit(self, spec, note: str = "starting the worker...") -> None:
        """Start a job of ``spec`` in the worker process."""
        jobs().append(SimulationJob(spec))
        self.status.text = note

    def cancel(self) -> None:
        for job in self.mine():
            if not job.finished:
                job.cancel()

    def tick(self, what, ended, done) -> None:
        """Follow the latest job: "WHAT STATE: N %" while it runs; at its end (once)
        ``ended(job)``, then ``done(job)`` if it succeeded, else its state (and error)."""
        mine = self.mine()
        if not mine:
            return
        job = mine[-1]
        state = job.poll()
        self.bar.value = job.fraction
        if state in ("starting", "running"):
            self.status.text = f"{what(job)}{state}: {100 * job.fraction:.0f} %"
            return
        if self._shown["job"] is job and self._shown["state"] == state:
            return
        self._shown["job"], self._shown["state"] = job, state
        if ended is not None:
            ended(job)
        if state == "done":
            done(job)
            return
        self.status.text = state
        if state == "error":
            self.show(ManipcadError(job.message))

    def start(self, make_spec, note) -> None:
        """Clear the error line, read the form into a job spec (``make_spec()``) and
        submit it, with the status ``note(spec)``; a form error (ManipcadError) goes to
        the error line instead."""
        self.clear()
        try:
            spec = make_spec()
        except ManipcadError as exc:
            self.show(exc)
            return
        self.submit(spec, note(spec))

    def controls(self, label: str, make_spec, done, *, what=lambda job: "", ended=None,
                 note=lambda spec: "starting the worker...", period: float = 0.25) -> None:
        """The run button (:meth:`start` of ``make_spec``, the page's form read into a
        job spec), Cancel, and the timer (every ``period`` s) that calls ``done(job)``
        when the latest job succeeds."""

        def start() -> None:
            self.start(make_spec, note)

        with ui.row():
            ui.button(label, on_click=start).props(f"data-testid={self.testid}-run") \
                .mark(f"{self.testid}-run")
            ui.button("Cancel", on_click=self.cancel, color="negative") \
                .props(f"data-testid={self.testid}-cancel")
        ui.timer(period, lambda: self.tick(what, ended, done))


def job_notes(job) -> None:
    """The warnings a finished job's run gave (a joint beyond its limits, ...), one
    caption line each, in the current container."""
    for note in getattr(job, "notes", ()):
        ui.label(f"note: {logic.short_paths(note, SERVER['ws'])}") \
            .classes("text-caption text-warning").props("data-testid=job-note")


def error_label():
    """A hidden error line; ``show(exc)`` fills it, ``clear()`` hides it."""
    lab = ui.label("").classes("text-negative text-body1").props("data-testid=error") \
        .mark("error")
    lab.set_visibility(False)

    def show(exc: Exception) -> None:
        lab.text = error_text(exc)
        lab.set_visibility(True)

    def clear() -> None:
        lab.set_visibility(False)

    return show, clear


async def off_loop(fn, *args: Any, **kwargs: Any) -> Any:
    """``fn(*args, **kwargs)`` in a worker thread: validating an upload, identifying a
    payload, ... may take seconds, during which the server keeps answering every tab
    (their bounds are the loaders' own work budgets). Open the workspace inside ``fn``
    (a workspace's index connection belongs to the thread that opened it)."""
    from nicegui import run  # deferred: start-up cost: nicegui loaded on first use

    return await run.io_bound(fn, *args, **kwargs)


def upload_refused(show, accept: str):
    """The ``on_rejected`` of an upload field: says why the browser refused the file."""
    return lambda: show(InputError("upload", "", f"refused: larger than the "
                                   f"{logic.MAX_UPLOAD:,} bytes accepted, or not a {accept} "
                                   "file"))


def numbers(text: str, field: str, source: str) -> list[float]:
    """Comma-separated numbers from a form field (InputError naming it otherwise)."""
    try:
        vals = [float(x) for x in str(text).replace(";", ",").split(",") if x.strip()]
    except ValueError:
        raise InputError(source, field, f"expected numbers separated by commas, got "
                         f"{text!r}") from None
    if not vals or not all(math.isfinite(v) for v in vals):
        raise InputError(source, field, f"expected finite numbers, got {text!r}")
    return vals
