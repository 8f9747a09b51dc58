"""The typer application and the error guard shared by every sub-command."""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable
from typing import Any

import click
import typer
from rich.console import Console
from rich.markup import escape

from manipcad.errors import ManipcadError
from manipcad.version import __version__

app = typer.Typer(
    name="manipcad",
    help="Computer-aided design of high-accuracy control for robot manipulators.",
    no_args_is_help=True,
    add_completion=True,  # --install-completion / --show-completion (bash, zsh, fish)
    pretty_exceptions_enable=False,
)
#: the width output to a file or a pipe is laid out for (characters): wide enough that
#: no table is cut and no line is wrapped
PIPE_WIDTH = 2000


class _Console(Console):
    """A console that lays out output to a file or pipe at :data:`PIPE_WIDTH` (rich
    takes the width of a terminal on another stream, or 80, and cuts table cells to it)
    unless COLUMNS says otherwise; on a terminal, the terminal's width."""

    @property
    def size(self):  # noqa: D102 - rich's
        dims = super().size
        if self._width is None and "COLUMNS" not in self._environ and not self.is_terminal:
            return dims._replace(width=PIPE_WIDTH)
        return dims

    @size.setter
    def size(self, new_size) -> None:
        Console.size.fset(self, new_size)


console = _Console(emoji=False)  # ":fire:" in a file name or "0:100:10" stays text
err_console = _Console(stderr=True, emoji=False)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"manipcad {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="Print the version and exit.")) -> None:
    """Computer-aided design of high-accuracy control for robot manipulators."""


def describe_exception(exc: BaseException) -> str:
    """One line for an error that reached the command line's edge: its path and a reason.

    - :class:`ManipcadError`: its own message (file, field, reason).
    - OSError: the path(s) it names and the system's reason, e.g.
      "/out/fig3: cannot write: Read-only file system" or "No space left on device".
    - MemoryError: "out of memory" with numpy's words when it gives them
      (the shape and bytes it could not allocate).
    - anything else (a bug, or a numerical error the checks missed): its type and
      message, marked as unexpected, with how to see the traceback.

    Example:
        >>> describe_exception(PermissionError(13, "Permission denied", "/out/x.png"))
        '/out/x.png: cannot write or read: Permission denied'
    """
    if isinstance(exc, ManipcadError):
        return str(exc)
    if isinstance(exc, OSError):
        where = " -> ".join(str(f) for f in (exc.filename, exc.filename2) if f is not None)
        reason = exc.strerror or str(exc) or type(exc).__name__
        return f"{where}: cannot write or read: {reason}" if where else f"system error: {reason}"
    if isinstance(exc, MemoryError):
        detail = str(exc)
        return ("out of memory" + (f" ({detail})" if detail else "")
                + "; use a larger step, a shorter run or keep fewer samples")
    return (f"unexpected {type(exc).__name__}: {exc} (a manipcad bug or an unchecked input; "
            "set MANIPCAD_DEBUG=1 to see the traceback)")


def guarded(func: Callable[..., Any]) -> Callable[..., Any]:
    """Run a command; any error becomes one red line on stderr and exit status 2.

    Bad input (:class:`ManipcadError`), an unwritable or full output folder
    (OSError), running out of memory (MemoryError) and any other exception are
    caught at this edge and reported by :func:`describe_exception`, never as a
    traceback (``MANIPCAD_DEBUG=1`` re-raises the unexpected ones). Ctrl-C
    exits with status 130. Exits requested by the command (typer.Exit, click's
    own usage errors) pass through.
    """

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except (typer.Exit, typer.Abort, click.exceptions.ClickException):
            raise
        except Exception as exc:  # noqa: BLE001 - the edge: every error becomes one line
            if (os.environ.get("MANIPCAD_DEBUG", "") not in ("", "0")
                    and not isinstance(exc, ManipcadError)):
                raise
            err_console.print(f"[bold red]error:[/] {escape(describe_exception(exc))}",
                              highlight=False, soft_wrap=True)
            raise typer.Exit(2) from None
        except KeyboardInterrupt as exc:
            # a save interrupted after its result was in place says so (store.SaveInterrupted)
            err_console.print(f"[bold red]{escape(str(exc) or 'interrupted')}[/]", highlight=False)
            raise typer.Exit(130) from None

    return wrapper


def main() -> None:
    """Entry point for ``python -m manipcad``."""
    sys.exit(app())
