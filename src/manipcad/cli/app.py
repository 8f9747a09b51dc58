"""The typer application and the error guard shared by every sub-command."""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from typing import Any

import typer
from rich.console import Console

from manipcad.errors import ManipcadError

app = typer.Typer(
    name="manipcad",
    help="Computer-aided design of high-accuracy control for robot manipulators.",
    no_args_is_help=True,
    add_completion=True,  # --install-completion / --show-completion (bash, zsh, fish)
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)


def _version(value: bool) -> None:
    if value:
        from manipcad import __version__

        typer.echo(f"manipcad {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="Print the version and exit.")) -> None:
    """Computer-aided design of high-accuracy control for robot manipulators."""


def guarded(func: Callable[..., Any]) -> Callable[..., Any]:
    """Run a command; bad input becomes one red line on stderr and exit status 2."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except ManipcadError as exc:
            err_console.print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
            raise typer.Exit(2) from None
        except KeyboardInterrupt as exc:
            # a save interrupted after its result was in place says so (store.SaveInterrupted)
            err_console.print(f"[bold red]{str(exc) or 'interrupted'}[/]", highlight=False)
            raise typer.Exit(130) from None

    return wrapper


def main() -> None:
    """Entry point for ``python -m manipcad``."""
    sys.exit(app())
