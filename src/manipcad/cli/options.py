"""The options several commands share, declared once.

Each is an ``Annotated`` type for a command's parameter, as Typer reads it; the
ones whose help depends on the command take that help as their argument::

    @app.command()
    def run(ws: ws_option("Workspace: the inputs may be its item names.") = None,
            workers: Workers = None, scheduler: Scheduler = None) -> None: ...
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer


def option(kind, names: str, help: str):
    """A command's option: its type ``kind`` (e.g. ``str | None``), its ``names``
    separated by spaces (``"--trajectory -t"``) and its help, one line in a signature.

    Example:
        >>> def size(dt: option(float, "--dt", "Sampling step, s.") = 1e-3): ...
    """
    return Annotated[kind, typer.Option(*names.split(), help=help)]


#: ``--workers N``: the local Dask cluster's worker processes
Workers = Annotated[int | None, typer.Option(
    "--workers", help="Worker processes of a local Dask cluster (default one per core; "
    "1: serial, no cluster).")]
#: ``--scheduler ADDRESS``: a running Dask scheduler instead of a local cluster
Scheduler = Annotated[str | None, typer.Option(
    "--scheduler", help="Address of a running Dask scheduler, tcp://HOST:PORT.")]


def ws_option(help: str):
    """``--ws DIR``, a workspace folder; ``help`` says what the command does with it."""
    return Annotated[Path | None, typer.Option("--ws", help=help)]


def json_flag(help: str = "Print JSON instead of tables."):
    """``--json``: print the result as JSON."""
    return Annotated[bool, typer.Option("--json", help=help)]


def dt_option(help: str = "Integration step, s."):
    """``--dt S``: the integration or sampling step, s."""
    return Annotated[float, typer.Option("--dt", help=help)]


def t_end_option(help: str):
    """``--t-end S``: the end of the run, s."""
    return Annotated[float | None, typer.Option("--t-end", help=help)]


def payload_option(help: str):
    """``--payload KG``: a payload mass, kg."""
    return Annotated[float | None, typer.Option("--payload", help=help)]


def progress_flag(of: str):
    """``--progress/--no-progress``: a progress bar of ``of`` (e.g. "the runs")."""
    return Annotated[bool, typer.Option("--progress/--no-progress",
                                        help=f"Show a progress bar of {of}.")]


def force_flag(help: str):
    """``--force``: replace what is there."""
    return Annotated[bool, typer.Option("--force", help=help)]


def strict_flag(help: str = "A check that is unknown counts as failed."):
    """``--strict``: a stricter verdict (``help`` says how)."""
    return Annotated[bool, typer.Option("--strict", help=help)]


#: the robot a command works on, the first argument
RobotArgument = Annotated[str, typer.Argument(
    help="A catalog robot name (see 'manipcad robots list'), a robot file (DH, URDF + drives "
    "or tree form, docs/robot-files.md) or a .urdf file.")]
