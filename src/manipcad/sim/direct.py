"""Call a compiled function's specialization without numba's argument typing every call.

Each call of a numba dispatcher types its arguments to choose the compiled
specialization. Arrays and tuples of arrays have a fast C path (a *fingerprint*
of each value: dtype, dimensions, layout and flags of each array, the class name
and fields of a named tuple); a value numba cannot fingerprint — a tuple holding a
compiled C callback (:class:`numba.core.ccallback.CFunc`), as the simulator's
:class:`~manipcad.sim.loop.Plant` holds the robot's generated kernels — is typed in
Python instead, some 7 µs per array field: about 0.1 ms of every
:func:`manipcad.simulate` call for the Plant alone (docs/performance.md).

:class:`DirectCall` keeps, per *key* of the arguments, the entry point of the
specialization the dispatcher chose for them, and calls it directly when the
key is seen again. The key determines the arguments' numba types completely:

- a value numba fingerprints: its type and its fingerprint (what numba's own
  dispatch goes by);
- a tuple it cannot: its type and the key of each field;
- a :class:`~numba.core.ccallback.CFunc`: the object itself (its numba type is its
  fixed signature; the key holds the object, so its identity cannot be reused);
- anything else: no key, and the call goes through the dispatcher.

A key is cached only when the dispatcher holds a specialization for exactly the
arguments' types (``dispatcher.overloads``); otherwise, and for any key not seen
before, the call is the dispatcher's own (typing, conversion or compilation as usual).

Example:
    >>> import numba as nb, numpy as np
    >>> from manipcad.sim.direct import DirectCall
    >>> @nb.njit
    ... def total(a, k):
    ...     return a.sum() * k
    >>> f = DirectCall(total)
    >>> f(np.ones(3), 2), f(np.ones(4), 3)      # the first call types, the second goes direct
    (6.0, 12.0)
    >>> f(np.ones(3, dtype=np.int64), 2)       # a new key: numba's dispatch, a new specialization
    6
"""

from __future__ import annotations

import threading

from numba._dispatcher import compute_fingerprint
from numba.core.ccallback import CFunc


class _NoKey(Exception):
    """A value whose numba type the key cannot determine."""


def _key(value):
    try:
        return type(value), compute_fingerprint(value)
    except Exception:  # numba: NotImplementedError (or other) for a value it cannot fingerprint
        pass
    if isinstance(value, tuple):
        return type(value), tuple(_key(v) for v in value)
    if type(value) is CFunc:
        return CFunc, value
    raise _NoKey


class DirectCall:
    """``dispatcher(*args)``, with the specialization's entry point cached per argument key.

    Args:
        dispatcher: a numba ``@njit`` function (a :class:`numba.core.dispatcher.Dispatcher`).
        size: keys kept (the oldest dropped beyond; each holds the key's values, e.g.
            C callbacks, and the entry point).

    The result, the exceptions and any compilation are the dispatcher's: a call whose
    key is new or cannot be made goes through ``dispatcher(*args)``.
    """

    def __init__(self, dispatcher, size: int = 16) -> None:
        self.dispatcher = dispatcher
        self.size = int(size)
        self._entry: dict = {}
        self._lock = threading.Lock()

    def __call__(self, *args):
        try:
            key = tuple(_key(a) for a in args)
        except _NoKey:
            return self.dispatcher(*args)
        entry = self._entry.get(key)
        if entry is not None:
            return entry(*args)
        out = self.dispatcher(*args)
        self._remember(key, args)
        return out

    def _remember(self, key, args) -> None:
        """Cache the entry point of the specialization for exactly these arguments' types."""
        d = self.dispatcher
        sig = tuple(d.typeof_pyval(a) for a in args)
        cres = d.overloads.get(sig)
        if cres is None or getattr(cres, "objectmode", False):
            return
        with self._lock:  # threads may remember keys at once (the lookup needs no lock)
            if len(self._entry) >= self.size:
                self._entry.pop(next(iter(self._entry)))
            self._entry[key] = cres.entry_point

    def __repr__(self) -> str:
        return f"DirectCall({getattr(self.dispatcher, '__name__', self.dispatcher)!r})"


__all__ = ["DirectCall"]
