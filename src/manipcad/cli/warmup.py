"""``manipcad warmup``: compile the numba kernels once, ahead of the first real run.

The compiled kernels (dynamics, drive equations, the closed-loop simulator's cores for
every integrator, the regulators) are cached on disk, keyed by the hash of their
sources (:mod:`manipcad._numba_cache`), so they compile once per installed version.
The work is split into the steps of :mod:`manipcad.sim.warm`, shared out over two
processes on two cores or more. ``manipcad warmup`` does all of it up front; the
commands that need kernels call :func:`ensure_warm` with the steps they need (a
simulation: its integrator's core and the callees), which compiles the cold ones with a
one-line "compiling kernels (once)" message and does nothing when they are warm.

A step is warm when its marker file ``warm-<step>`` exists in the kernel cache folder
(``$NUMBA_CACHE_DIR``, by default ``~/.cache/manipcad/numba-<copy>-<hash>``: the hash of
the package's folder, then of its kernel sources): a change of any kernel source, or
another copy of the package, gives a new folder, hence a cold cache again. A new folder
starts with the kernels shipped in the package where they fit this numba, Python and
CPU family (:mod:`manipcad._shipped_kernels`): then nothing compiles at all.
"""

from __future__ import annotations

import time

import typer

from manipcad._shipped_kernels import CPU, ORIGIN, why_not
from manipcad.cli.app import app, console, err_console, guarded
from manipcad.sim import warm
from manipcad.sim.warm import STEPS, cache_dir, is_warm, needs

#: names for the steps a command family needs: the dynamics (sizing, selection) and a
#: simulation with the fixed-step RK4
GROUPS = {"dynamics": ("inverse dynamics", "forward dynamics"), "simulator": needs("rk4")}


def _expand(steps) -> tuple[str, ...]:
    out: list[str] = []
    for s in steps:
        for name in GROUPS.get(s, (s,)):
            if name not in out:
                out.append(name)
    return tuple(out)


def start_warm(*steps: str) -> warm.Compile:
    """Start compiling the cold ones of ``steps`` (names of :data:`STEPS` or
    :data:`GROUPS`; default all) in the helper process, in the background; the caller does
    other work, then :func:`finish_warm` with the result."""
    return warm.Compile(_expand(steps or tuple(STEPS))).start()


def finish_warm(job: warm.Compile) -> None:
    """Compile this process's share of ``job``'s steps and wait for the helper, saying so
    in one line on stderr with the step in progress; silent when all were warm."""
    if not job.steps:
        return
    why = why_not(cache_dir())
    err_console.print(f"compiling kernels (once; later runs start at once) on {job.workers} "
                      f"process{'es' if job.workers > 1 else ''}"
                      + (f" ({why})" if why else "") + " ...", highlight=False)
    t0 = time.perf_counter()
    for line in _finish(job):
        err_console.print(f"[yellow]warmup step failed:[/] {line}", highlight=False)
    err_console.print(f"kernels ready in {time.perf_counter() - t0:.1f} s", highlight=False)


def _finish(job: warm.Compile) -> list[str]:
    """``job.finish`` with the step in progress on a status line (stderr); its failures."""
    with err_console.status("compiling") as status:
        return job.finish(lambda what: status.update(f"compiling: {what}"))


def ensure_warm(*steps: str) -> None:
    """Compile the kernels of some steps (names of :data:`STEPS` or :data:`GROUPS`; default
    all) first if the cache is cold for them, saying so in one line on stderr
    ("compiling kernels (once)"); silent when warm. Commands that run compiled kernels
    call this before their work, e.g. ``ensure_warm("dynamics")`` for sizing or
    ``ensure_warm(*needs(integrator))`` for a simulation."""
    finish_warm(start_warm(*steps))


@app.command("warmup")
@guarded
def warmup(
    force: bool = typer.Option(False, "--force", help="Run the steps even if the cache is "
                               "already warm (they then only load from the cache)."),
) -> None:
    """Compile the numba kernels once (dynamics, drives, regulators, the simulator's cores
    for every integrator), on two processes where there are two cores.

    A new install usually has them already (shipped with the package for
    x86-64-v3 CPUs), and this only says so. Elsewhere the first command that
    needs them does its part by itself; run this ahead to have every later
    command start at once. Exit 1 if a step fails."""
    d = cache_dir()
    if is_warm() and not force:
        shipped = d is not None and (d / ORIGIN).is_file()
        console.print("kernels already compiled" + (
            f" (shipped with manipcad, built for {CPU}; MANIPCAD_SHIPPED_KERNELS=0 and a "
            "new cache folder compile them for this one)" if shipped else "")
            + f"; cache {d}", highlight=False)
        return
    if force and d is not None:
        for name in STEPS:
            warm.marker(name).unlink(missing_ok=True)
    job = warm.Compile()
    console.print(f"compiling kernels (once) on {job.workers} process"
                  f"{'es' if job.workers > 1 else ''} ...", highlight=False)
    t0 = time.perf_counter()
    failures = _finish(job)
    for line in failures:
        err_console.print(f"[red]failed:[/] {line}", highlight=False)
    console.print(f"{len(STEPS) - len(failures)} of {len(STEPS)} steps done in "
                  f"{time.perf_counter() - t0:.1f} s; cache {d}", highlight=False)
    if failures:
        raise typer.Exit(1)
