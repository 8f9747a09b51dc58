"""One call computed in a forked child process while this process goes on.

A study that starts its own Dask cluster spends its first few tenths of a second on one
core: importing ``distributed`` (about 0.2 s) and starting the scheduler, before the
workers fork. :class:`ChildCall` puts the other core to work meanwhile: the call is
forked first, with everything this process has imported and compiled, and its result
comes back pickled through a pipe. Where fork is unavailable or unsafe
(:func:`manipcad.parallel.executor.start_method` is not "fork") the call simply runs in
this process when its result is asked for.

Example:
    >>> from manipcad.parallel.child import ChildCall
    >>> with ChildCall(sum, [1, 2, 3]) as call:
    ...     call.result()
    6
"""

from __future__ import annotations

import gc
import traceback
from collections.abc import Callable
from typing import Any

from manipcad.errors import ManipcadError
from manipcad.parallel.executor import start_method

#: how long :meth:`ChildCall.close` waits for a child that is still running, s
CLOSE_TIMEOUT = 5.0


class ChildTraceback(Exception):
    """The traceback of an error raised in a child process, as text: the ``__cause__`` of
    that error raised again in the parent (as :mod:`concurrent.futures` does)."""

    def __str__(self) -> str:
        return "\n" + self.args[0]


def _child(fn: Callable, args: tuple, conn) -> None:
    """In the child: ``fn(*args)`` sent back as ``(True, value, "")``, or ``(False, error,
    its traceback)``."""

    # the inherited objects are left alone by this process's collector (their pages
    # stay shared with the parent instead of being copied as a collection touches them)
    gc.freeze()
    try:
        out = (True, fn(*args), "")
    except BaseException as exc:  # noqa: BLE001 - re-raised in the parent
        out = (False, exc, traceback.format_exc())
    try:
        conn.send(out)
    except Exception as exc:  # noqa: BLE001 - an unpicklable value or error
        conn.send((False, ManipcadError(f"{getattr(fn, '__qualname__', fn)!s} in a child "
                                        f"process: its result could not be sent back "
                                        f"({type(exc).__name__}: {exc}); the result was "
                                        f"{out[1]!r:.300}"), out[2]))
    finally:
        conn.close()


class ChildCall:
    """``fn(*args)`` computed in a child process forked at construction.

    The child starts with this process's memory (imports, compiled kernels, the
    arguments) and runs on another core; :meth:`result` waits for it. Fork it before this
    process starts any thread that may hold a lock (e.g. before a Dask cluster is
    started): only the forking thread goes on in the child. Without fork (see
    :func:`manipcad.parallel.executor.start_method`) ``fn`` runs in this process at the
    first :meth:`result`. Use as a context manager (a child still running is stopped).

    Args:
        fn: the function (any callable: it is not pickled, the child has it).
        args: its positional arguments.

    Example: see the module.
    """

    def __init__(self, fn: Callable, *args: Any) -> None:

        self._fn, self._args = fn, args
        self._done: tuple[bool, Any, str] | None = None
        self._proc = self._conn = None
        if start_method() == "fork":
            import multiprocessing  # deferred: start-up cost: multiprocessing loaded on first use

            ctx = multiprocessing.get_context("fork")
            self._conn, send = ctx.Pipe(duplex=False)
            self._proc = ctx.Process(target=_child, args=(fn, args, send), daemon=True,
                                     name=f"manipcad-{getattr(fn, '__name__', 'call')}")
            self._proc.start()
            send.close()  # this process's copy: the child's end alone keeps the pipe open

    def result(self) -> Any:
        """The call's value (waits for the child), or its exception raised here (from a
        :class:`ChildTraceback`, the child's traceback).

        Raises:
            ManipcadError: the child ended without a result (killed, crashed, or stopped
                by :meth:`close` first).
        """
        if self._done is None:
            if self._proc is None:  # no fork: here and now
                try:
                    self._done = (True, self._fn(*self._args), "")
                except BaseException as exc:  # noqa: BLE001 - raised below, every time
                    self._done = (False, exc, "")
            else:
                try:
                    self._done = self._conn.recv()
                except (EOFError, OSError):  # no result sent, or the pipe closed here
                    self.close()
                    self._done = (False, ManipcadError(
                        f"{getattr(self._fn, '__qualname__', self._fn)!s} in a child "
                        f"process: it ended without a result (exit code "
                        f"{self._proc.exitcode})"), "")
                self.close()
        ok, value, trace = self._done
        if not ok:
            if trace:
                raise value from ChildTraceback(trace)
            raise value
        return value

    def close(self) -> None:
        """Wait for the child to exit: at once if its result came, else stop it (it is
        killed if it has not exited :data:`CLOSE_TIMEOUT` s later)."""
        if self._proc is None or self._conn.closed:
            return
        if self._done is None:
            self._proc.terminate()
        self._proc.join(CLOSE_TIMEOUT)
        if self._proc.exitcode is None:
            self._proc.kill()
            self._proc.join()
        self._conn.close()

    def __enter__(self) -> ChildCall:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
