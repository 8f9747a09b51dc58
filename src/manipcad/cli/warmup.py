"""``manipcad warmup``: compile the numba kernels once, ahead of the first real run.

The compiled kernels (dynamics, drive equations, the closed-loop simulator and
the regulators) are cached on disk, keyed by the hash of their sources
(:mod:`manipcad._numba_cache`), so they compile once per installed version:
on a cold cache the first ``simulate`` takes tens of seconds, the first
``size`` a few. ``manipcad warmup`` does that work up front with a progress
bar; the commands that need the kernels call :func:`ensure_warm` first, which
runs the same steps with a one-line "compiling kernels (once)" message when
the cache is cold and does nothing when it is warm.

A step is warm when its marker file ``warm-<step>`` exists in the kernel
cache folder (``$NUMBA_CACHE_DIR``, by default
``~/.cache/manipcad/numba-<hash>``): a change of any kernel source gives a new
folder, hence a cold cache again.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import typer
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

import manipcad
from manipcad.cli.app import app, console, err_console, guarded
from manipcad.control import pid
from manipcad.drives.model import DriveModel
from manipcad.sim import simulate

MARKER = "warm"


def _dynamics() -> None:


    arm = manipcad.load_robot("cylindrical")
    q = np.full((2, arm.n), 0.1)
    manipcad.inverse_dynamics(arm, q, q, q, drives=True)
    manipcad.inverse_dynamics(arm, q[0], q[0], q[0], drives=False)
    manipcad.mass_matrix(arm, q)
    manipcad.forward_dynamics(arm, q, q, q)


def _drives() -> None:

    arm_drive = _arm().drives[0]
    DriveModel(arm_drive, H_ii=1.0).simulate(2e-4, 1e-4, U=1.0)


def _simulator() -> None:

    arm = _arm()
    regs = [pid(j, kp=10.0, kd=1.0) for j in range(arm.n)]
    simulate(arm, t_end=2e-3, dt=1e-3, regulators=regs, drives=True, joint_limits="ignore")
    simulate(arm, t_end=2e-3, dt=1e-3, regulators=regs, drives=True, order=2,
             joint_limits="ignore")


def _arm():

    return manipcad.load_robot("cylindrical")


#: the warm-up steps in order: name -> (what, function)
STEPS: dict[str, tuple[str, Callable[[], None]]] = {
    "dynamics": ("dynamics (inverse, mass matrix, forward)", _dynamics),
    "drives": ("drive equations", _drives),
    "simulator": ("closed-loop simulator and regulators", _simulator),
}


def cache_dir() -> Path | None:
    """The kernel cache folder in use, or None when numba's default (next to the
    sources) applies."""

    d = os.environ.get("NUMBA_CACHE_DIR")
    return Path(d) if d else None


def _marker(step: str) -> Path | None:
    d = cache_dir()
    return None if d is None else d / f"{MARKER}-{step}"


def is_warm(steps=None) -> bool:
    """True when the kernels of these steps (default all) were compiled for this
    source version already."""
    markers = [_marker(s) for s in (tuple(STEPS) if steps is None else steps)]
    return all(m is not None and m.is_file() for m in markers)


def run_steps(steps=None, show: bool = True) -> list[str]:
    """Run warm-up steps (names of :data:`STEPS`, default all) with a progress bar
    on stderr; return the failures as "step: reason" lines (a failed step does
    not stop the others). Marks each step that passed as warm."""
    steps = tuple(STEPS) if steps is None else steps
    failures: list[str] = []
    with Progress(TextColumn("  {task.description}"), BarColumn(), TextColumn(
            "{task.completed}/{task.total}"), TimeElapsedColumn(), console=err_console,
            transient=True, disable=not show) as progress:
        task = progress.add_task("compiling", total=len(steps))
        for name in steps:
            what, step = STEPS[name]
            progress.update(task, description=what)
            try:
                step()
            except Exception as exc:  # noqa: BLE001 - reported, and the rest still runs
                failures.append(f"{what}: {type(exc).__name__}: {exc}")
            else:
                marker = _marker(name)
                if marker is not None:
                    try:
                        marker.write_text(time.strftime("%Y-%m-%dT%H:%M:%S\n"))
                    except OSError:
                        pass
            progress.advance(task)
    return failures


def ensure_warm(*steps: str) -> None:
    """Compile the kernels of some steps (names of :data:`STEPS`; default all)
    first if the cache is cold for them, saying so in one line on stderr
    ("compiling kernels (once)") with a progress bar; silent when warm.
    Commands that run compiled kernels call this before their work, e.g.
    ``ensure_warm("dynamics")`` for sizing."""
    steps = steps or tuple(STEPS)
    cold = tuple(s for s in steps if not is_warm((s,)))
    if not cold:
        return
    err_console.print("compiling kernels (once; later runs start at once) ...",
                      highlight=False)
    t0 = time.perf_counter()
    failures = run_steps(cold)
    for line in failures:
        err_console.print(f"[yellow]warmup step failed:[/] {line}", highlight=False)
    err_console.print(f"kernels ready in {time.perf_counter() - t0:.1f} s", highlight=False)


@app.command("warmup")
@guarded
def warmup(
    force: bool = typer.Option(False, "--force", help="Run the steps even if the cache is "
                               "already warm (they then only load from the cache)."),
) -> None:
    """Compile the numba kernels once (dynamics, drives, simulator), with progress.

    The first command that needs them does this by itself; run it ahead to
    have every later command start at once. Exit 1 if a step fails."""
    d = cache_dir()
    if is_warm() and not force:
        console.print(f"kernels already compiled (cache {d})", highlight=False)
        return
    console.print("compiling kernels (once) ...", highlight=False)
    t0 = time.perf_counter()
    failures = run_steps()
    for line in failures:
        err_console.print(f"[red]failed:[/] {line}", highlight=False)
    console.print(f"{len(STEPS) - len(failures)} of {len(STEPS)} steps done in "
                  f"{time.perf_counter() - t0:.1f} s; cache {d}", highlight=False)
    if failures:
        raise typer.Exit(1)
