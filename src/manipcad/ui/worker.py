"""Simulations of ``manipcad ui`` in a background worker process.

The page starts a :class:`SimulationJob`; the run happens in a separate process
(``spawn``), so the web server keeps answering other pages while it goes. A spare
worker is started ahead (:func:`prestart`, when a page that runs jobs is opened)
and does its imports while it waits, so a run does not wait for a new interpreter;
a worker serves one job after the other (the one that finished a job is the next
spare), so its imports and the compiled kernels it loaded are paid once. The
worker calls :func:`manipcad.simulate` with a ``progress=`` callback that reports
the fraction done and raises ``KeyboardInterrupt`` once cancel is asked, then
stores the result with :meth:`manipcad.workspace.Workspace.store_result` (a
cancelled or failed run stores nothing; a diverged one only when asked).

Messages from the worker (a queue), each after the job's number:
``("progress", fraction)``, ``("done", result name, metrics)``, ``("error", message)``,
``("cancelled", "")``.
"""

from __future__ import annotations

import itertools
import multiprocessing as mp
import queue
import shutil
import tempfile
import threading
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from manipcad.control import synthesize
from manipcad.design import DesignNotMet, run_design
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.model import load_robot
from manipcad.sim import SimulationDiverged, simulate
from manipcad.store.plan import NAMES
from manipcad.store.run import RunSpec, execute, prepare
from manipcad.study import run_fig3
from manipcad.study.claims import run_claims
from manipcad.ui.logic import (
    load_robot_ref,
    load_trajectory_ref,
    open_workspace,
    recommend_for,
    robot_source,
)
from manipcad.workspace import Workspace, check_name
from manipcad.workspace.runs import to_workspace


@dataclass
class SimSpec:
    """What to run (all references are workspace or catalog names, checked in the worker).

    Attributes:
        workspace: the workspace folder.
        robot: a catalog robot name or ``robots/NAME``.
        trajectory: a workspace trajectory name.
        regulators: workspace regulator names (joints in none get U = 0).
        t_end: simulated time, s (None: the trajectory's duration).
        dt: integration step, s.
        name: the result's name (None: generated).
        save_diverged: keep the partial result of a diverged run.
    """

    workspace: str
    robot: str
    trajectory: str
    regulators: list[str] = field(default_factory=list)
    t_end: float | None = None
    dt: float = 1e-4
    name: str | None = None
    save_diverged: bool = False


    def run(self, progress=None) -> tuple[str, dict[str, Any]]:
        """:func:`run_spec` of this spec."""
        return run_spec(self, progress)


@dataclass
class StudySpec:
    """A study to run and store as ``studies/NAME`` (what ``manipcad study fig3|claims
    --ws W --out NAME`` does, through the same functions).

    Attributes:
        workspace: the workspace folder.
        study: "fig3" (:func:`manipcad.study.run_fig3`) or "claims"
            (:func:`manipcad.study.claims.run_claims`).
        name: the study's name in the workspace.
        t_end: fig3: length of the laws (2) runs, s (None: 1.6).
        methods: fig3: comma-separated labels (None: all).
        grid: claims: "quick" (4 × 4 cells) or "full".
        dt: integration step, s.
    """

    workspace: str
    study: str
    name: str
    t_end: float | None = None
    methods: str | None = None
    grid: str = "quick"
    dt: float = 1e-4

    def run(self, progress=None) -> tuple[str, dict[str, Any]]:
        """Run the study into the workspace; returns ``(name, {"files": [...]})``.

        Raises:
            InputError: a bad name, kind or argument (the study functions' own checks).
        """


        check_name(self.name, "study name")
        if self.study not in ("fig3", "claims"):
            raise InputError("study form", "study", f"{self.study!r}: expected fig3 or claims")
        cb = progress if progress is not None else False
        space = Workspace(self.workspace)
        space.check_free("studies", self.name)                          # before the run
        # as `study ... --ws`: written into a temporary folder, then added (validated, indexed)
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp) / "study"
            if self.study == "fig3":

                run_fig3(folder, dt=self.dt, t_end=self.t_end, methods=self.methods,
                         progress=cb)
            else:

                run_claims(folder, grid=self.grid, workers=1, dt=self.dt, progress=cb)
            files = sorted(p.name for p in folder.iterdir() if p.is_file())
            space.add(folder, kind="study", name=self.name)
        return self.name, {"files": files}


@dataclass
class VerifySpec:
    """"Verify by simulation" of the requirement form: synthesize the top recommended
    methods, simulate them along the trajectory and re-rank by the measured error
    (what ``manipcad recommend --verify`` does, through :func:`manipcad.ui.logic.recommend_for`).

    Attributes:
        workspace: the workspace folder.
        robot: a catalog robot name or ``robots/NAME``.
        trajectory: a workspace trajectory name.
        form: the requirement form's fields (:func:`manipcad.ui.logic.recommend_for`).
    """

    workspace: str
    robot: str
    trajectory: str
    form: dict[str, Any]

    def run(self, progress=None) -> tuple[str, dict[str, Any]]:
        """Verify; returns ``("verified", Recommendations.to_dict())`` (plain data; the
        simulations report no progress).

        Raises:
            InputError: a bad reference or form field (the API's own checks).
        """

        ws = open_workspace(self.workspace)
        arm, _ = load_robot_ref(ws, self.robot)
        traj = load_trajectory_ref(ws, self.trajectory, arm)
        return "verified", recommend_for(self.form, arm, traj, verify=True).to_dict()


@dataclass
class DesignSpec:
    """The automated design (``manipcad design``), stored as ``studies/NAME``.

    Attributes:
        workspace: the workspace folder.
        robot: a catalog robot name or ``robots/NAME``.
        trajectories: workspace trajectory names (>= 1).
        requirements: the requirement fields (:class:`manipcad.expert.Requirements`).
        name: the design's name in the workspace (``studies/NAME``).
        payload_range: (low, high) gripped mass at the tool point, kg.
        uncertainty: relative parameter uncertainty, fraction in [0, 1).
        samples: uncertainty samples.
        counterbalance: "auto" or "none".
        period: control period, s; dt: integration step, s.
        max_methods: how many of the rules' methods are verified.
    """

    workspace: str
    robot: str
    trajectories: list[str]
    requirements: dict[str, Any]
    name: str
    payload_range: tuple[float, float] = (0.0, 0.0)
    uncertainty: float = 0.0
    samples: int = 5
    counterbalance: str = "none"
    period: float = 1e-3
    dt: float = 1e-4
    max_methods: int = 4

    def run(self, progress=None) -> tuple[str, dict[str, Any]]:
        """Design (serially, in this worker) into a temporary folder, then add it to the
        workspace; returns ``(name, {"status", "methods", "worst_case_error", "accuracy",
        "failure", "files"})``. A design that does not meet the requirements is stored
        too (its report says why).

        Raises:
            InputError: a bad name, reference or form field (the API's own checks).
        """


        check_name(self.name, "design name")
        ws = open_workspace(self.workspace)
        ws.check_free("studies", self.name)                          # before the run
        arm, _ = load_robot_ref(ws, self.robot)
        trajs = [load_trajectory_ref(ws, t, arm) for t in self.trajectories]

        def stage(text: str, frac: float) -> None:
            if progress is not None:
                progress(frac)

        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp) / "design"
            try:
                doc = run_design(self.requirements, arm, trajs, out=folder,
                                 payload_range=tuple(self.payload_range),
                                 uncertainty=self.uncertainty, samples=self.samples,
                                 counterbalance=self.counterbalance, period=self.period,
                                 dt=self.dt, max_methods=self.max_methods, workers=1,
                                 progress=stage,
                                 sources={"robot": self.robot,
                                          "trajectories": list(self.trajectories)})
            except DesignNotMet as exc:
                doc = exc.doc
            shutil.rmtree(folder / "cache", ignore_errors=True)
            ws.add(folder, kind="study", name=self.name)
        return self.name, {"status": doc["status"], "methods": doc["methods"],
                           "worst_case_error": doc["worst_case_error"],
                           "accuracy": doc["accuracy"], "failure": doc.get("failure"),
                           "files": ["report.html", "design.json", "robot.yaml",
                                     "regulators.yaml"]}


def run_spec(spec: SimSpec, progress=None) -> tuple[str, dict[str, Any]]:
    """Run one simulation and store it in the workspace (what the worker does).

    Args:
        spec: the run.
        progress: called with the fraction done (0..1); may raise to cancel.

    Returns:
        ``(name, metrics)``: the stored result's name and its indexed metrics.

    Raises:
        InputError: a bad reference or value; ManipcadError: the run failed
            (diverged at t, joint).
    """


    ws = open_workspace(spec.workspace)
    robot = robot_source(ws, spec.robot)
    check_name(spec.trajectory, "trajectory")
    for name in spec.regulators:
        check_name(name, "regulator")
    if spec.name:
        check_name(spec.name, "result name")
    # the same run description, checks and record stride as `manipcad simulate` (one
    # sample per period)
    run = RunSpec(robot, ws.resolve("trajectories", spec.trajectory),
                  tuple(ws.resolve("regulators", n) for n in spec.regulators),
                  dt=spec.dt, t_end=spec.t_end)
    prepared = prepare(run, sources={"robot": spec.robot, "trajectory": spec.trajectory},
                       names={**NAMES, "drives": "the Drives page to attach motors and gears"})
    for note in prepared.notes:  # the page shows them (a trajectory beyond the limits, ...)
        warnings.warn(note, ManipcadWarning, stacklevel=2)
    if spec.name:
        ws.check_free("results", spec.name)            # before the run, not after
    store = to_workspace(ws, spec.name, trajectory=spec.trajectory, regulators=spec.regulators)
    with warnings.catch_warnings():
        # said as `manipcad simulate` says them (a joint beyond its limits, ...): the
        # worker passes them to the page as the job's notes
        warnings.simplefilter("always", ManipcadWarning)
        try:
            done = execute(prepared, store, progress, save_diverged=spec.save_diverged)
        except SimulationDiverged as exc:
            if exc.stored is not None:
                raise ManipcadError(f"{exc}; the partial result is {exc.stored.name}") from None
            raise ManipcadError(f"{exc}; nothing was stored") from None
    return done.where.name, done.where.metrics


def _warm() -> None:
    """What a spare worker does while it waits: the imports of a run and a run of two
    steps (which loads the compiled kernels from their cache), so the designer's run
    starts at once. A failure here is left to the real run to report."""

    try:
        # deferred: the warm-up itself: what a run imports, loaded while the worker waits
        import manipcad.store.plan  # noqa: F401
        import manipcad.store.results  # noqa: F401
        import manipcad.store.run  # noqa: F401
        import manipcad.workspace  # noqa: F401

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ManipcadWarning)
            arm = load_robot("cylindrical")
            simulate(arm, t_end=2e-4, dt=1e-4, regulators=synthesize(arm, "all", "pid"))
    except Exception:  # noqa: BLE001, S110  the run itself reports what is wrong
        pass


def _work(inbox, out, cancel, done) -> None:
    """The worker process's body: import what a run needs, then run the jobs that come on
    ``inbox`` one after the other until ``None`` comes.

    One process serves many runs, so its interpreter start, imports and the compiled
    kernels it loaded are paid once, not per run. Each job comes as ``(number, spec)``;
    every message on ``out`` starts with that number. ``cancel.value`` holds the number
    of the job asked to stop (checked at each progress report); ``done.value`` is set to
    the number of each job just before its last message is sent (the worker is then
    free for the next job).
    """


    _warm()
    while True:
        msg = inbox.recv()
        if msg is None:            # the server stops
            return
        number, spec = msg

        def progress(frac: float, number: int = number) -> None:
            out.put((number, "progress", float(frac)))
            if cancel.value == number:
                raise KeyboardInterrupt

        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", ManipcadWarning)
                try:
                    name, metrics = spec.run(progress)
                finally:
                    _pass_notes(number, caught, out)
        except KeyboardInterrupt:
            last = (number, "cancelled", "")
        except ManipcadError as exc:
            last = (number, "error", str(exc))
        except Exception as exc:  # noqa: BLE001  the page shows any failure, with its type
            last = (number, "error", f"{type(exc).__name__}: {exc}")
        else:
            last = (number, "done", name, metrics)
        done.value = number        # free before its last word: the job that reads it finds
        out.put(last)              # the worker free (no new spare started)


def _pass_notes(number: int, caught, out) -> None:
    """A job's warnings: manipcad's own (a joint beyond its limits, ...) go to the page as
    ``(number, "note", text)`` messages, each text once (they used to reach the server's
    log only, with the module's install path); others to stderr as Python shows them."""


    said: set[str] = set()
    for w in caught:
        if issubclass(w.category, ManipcadWarning):
            text = str(w.message)
            if text not in said:
                said.add(text)
                out.put((number, "note", text))
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)


class _Worker:
    """A worker process: its inbox, its outbox, and which job it was given and finished
    (a job number; the worker is free when the two are equal)."""

    def __init__(self) -> None:
        ctx = mp.get_context("spawn")
        self.queue = ctx.Queue()
        self.cancel = ctx.Value("q", 0)
        self.done = ctx.Value("q", 0)
        self.given = 0
        self.inbox, send = ctx.Pipe(duplex=False)
        self.send = send
        self.mailbox: dict[int, list] = {}       # messages read, by job number
        self.process = ctx.Process(target=_work, args=(self.inbox, self.queue, self.cancel,
                                                       self.done), daemon=True)
        self.process.start()

    @property
    def free(self) -> bool:
        """Alive and not running a job (it may still be doing its imports)."""
        return self.done.value == self.given and self.process.is_alive()

    def read(self, number: int) -> list:
        """The messages of job ``number`` that arrived (each taken once)."""
        while True:
            try:
                msg = self.queue.get_nowait()
            except queue.Empty:
                break
            self.mailbox.setdefault(msg[0], []).append(msg[1:])
        return self.mailbox.pop(number, [])


_WORKERS: list[_Worker] = []
_LOCK = threading.Lock()
_NUMBER = itertools.count(1)


def prestart() -> None:
    """Have a free worker ready, so the next run does not wait for a new interpreter to
    import manipcad (the pages that run jobs call it when opened; a worker that finished
    a job is the next spare, so this starts one only when none is free)."""
    with _LOCK:
        _WORKERS[:] = [w for w in _WORKERS if w.process.is_alive()]
        free = [w for w in _WORKERS if w.free]
        for extra in free[1:]:         # after runs side by side: keep one spare
            extra.send.send(None)
            _WORKERS.remove(extra)
        if not free:
            _WORKERS.append(_Worker())


def stop_spare() -> None:
    """End the worker processes (``manipcad ui`` calls it at shutdown): a free one is
    told to stop, one still running a job (or its imports) is terminated after 1 s."""
    with _LOCK:
        workers, _WORKERS[:] = list(_WORKERS), []
    for w in workers:
        if w.free:
            w.send.send(None)
    deadline = time.monotonic() + 1.0
    for w in workers:
        w.process.join(timeout=max(0.0, deadline - time.monotonic()))
        if w.process.is_alive():
            w.process.terminate()
            w.process.join(timeout=1.0)


def _take(number: int) -> _Worker:
    """A free worker (the spare), or a new one when none is, given job ``number`` (marked
    busy under the lock, so no other caller takes it too)."""
    with _LOCK:
        _WORKERS[:] = [w for w in _WORKERS if w.process.is_alive()]
        w = next((w for w in _WORKERS if w.free), None)
        if w is None:
            w = _Worker()
            _WORKERS.append(w)
        w.given = number
        return w


class SimulationJob:
    """A simulation (:class:`SimSpec`), a study (:class:`StudySpec`), a verification
    (:class:`VerifySpec`) or a design (:class:`DesignSpec`) running in a worker process;
    once done, ``result`` and ``metrics`` are what the spec's ``run`` returned.

    Example (not run here: it starts a process)::

        job = SimulationJob(SimSpec("ws", "puma560", "move", ["asvs-all"], t_end=2.0))
        while job.poll() in ("starting", "running"):
            time.sleep(0.1)
        job.state, job.result
    """

    def __init__(self, spec: SimSpec | StudySpec | VerifySpec | DesignSpec) -> None:
        self.number = next(_NUMBER)
        self._worker = w = _take(self.number)
        self.spec = spec
        self.process = w.process
        self.state = "starting"
        self.fraction = 0.0
        self.result: str | None = None
        self.metrics: dict[str, Any] = {}
        self.message = ""
        self.notes: list[str] = []     # the run's warnings (manipcad's own), in order
        self.started = time.perf_counter()
        self.wall = float("nan")
        w.send.send((self.number, spec))
        # no new spare while this runs: its interpreter start and imports (1.5-2 s of CPU)
        # would take a core from this run on a 2-core machine; this worker is the next spare

    def poll(self) -> str:
        """Read what the worker said; returns the state: starting, running, done,
        error, cancelled."""
        if self.finished:
            return self.state
        self._take_messages()
        if not self.finished and not self.process.is_alive():
            self._take_messages()    # its last words, if any
            if not self.finished:
                self.state = "error"
                self.message = f"the worker process ended (exit code {self.process.exitcode})"
        if self.finished:
            self.wall = time.perf_counter() - self.started
            prestart()               # this worker is the spare again (a new one if it died)
        return self.state

    def _take_messages(self) -> None:
        """Apply the job's messages that arrived to its state."""
        for msg in self._worker.read(self.number):
            if msg[0] == "progress":
                self.state, self.fraction = "running", msg[1]
            elif msg[0] == "done":
                self.state, self.result, self.metrics = "done", msg[1], msg[2]
                self.fraction = 1.0
            elif msg[0] == "note":
                self.notes.append(msg[1])
            else:
                self.state, self.message = msg[0], msg[1]

    def cancel(self) -> None:
        """Ask the worker to stop this job at its next progress report (nothing is
        stored); nothing happens once the job is over."""
        if not self.finished and self._worker.given == self.number:
            self._worker.cancel.value = self.number

    @property
    def finished(self) -> bool:
        """Whether the run is over (done, error or cancelled)."""
        return self.state in ("done", "error", "cancelled")
