"""Argument checks and fast paths shared by the public dynamics functions (they run per call)."""

from __future__ import annotations

import os
import threading

import numba as nb
import numpy as np
from numba import types as nt

from manipcad.dynamics.aba import aba_vector
from manipcad.dynamics.crba import crba_vector
from manipcad.dynamics.forward_crba import crba_fd_vector
from manipcad.dynamics.rnea import rnea_vector
from manipcad.errors import ManipcadError

#: the dummy external wrenches of a call without them
NO_FEXT = np.zeros((1, 1, 6))


def as_states(n: int, **arrays) -> tuple[list[np.ndarray], bool]:
    """Coerce joint arrays to (N, n) float64; return them and whether the input was one state.

    Raises ManipcadError naming the argument when a shape is wrong. NaN propagates
    to the result as in numpy (no per-call scan: this runs on every call).
    """
    out = []
    shape = None
    for name, x in arrays.items():
        a = x if type(x) is np.ndarray and x.dtype == np.float64 else as_floats(name, x)
        if a.ndim == 1:
            a = a.reshape(1, -1)
        elif a.ndim != 2:
            raise ManipcadError(f"{name} must have shape (n,) or (N, n) with n = {n}, "
                                f"got {np.shape(x)}")
        if a.shape[1] != n:
            raise ManipcadError(f"{name} must have n = {n} columns (one per joint), "
                                f"got shape {np.shape(x)}")
        if shape is None:
            shape, single = a.shape, np.ndim(x) == 1
        elif a.shape != shape or (np.ndim(x) == 1) != single:
            raise ManipcadError(f"{name} has shape {np.shape(x)}, the first argument "
                                f"{shape[1:] if single else shape}")
        out.append(writable_c(a))
    return out, single


def writable_c(a: np.ndarray) -> np.ndarray:
    """``a`` itself if C-contiguous and writable, else a C-contiguous copy.

    The compiled kernels are specialized on their arrays' layout and writability: a
    readonly or strided state array would compile every kernel it reaches a second time
    (5-15 s each on a cold cache) for no gain; the copy costs microseconds.

    Example:
        >>> a = np.zeros(3); a.setflags(write=False)
        >>> writable_c(a).flags.writeable
        True
    """
    if a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.array(a, order="C", copy=True)


def as_floats(name: str, x) -> np.ndarray:
    """``x`` as a float64 array; anything that is not real numbers (text, None, complex,
    ragged lists) raises ManipcadError naming the argument ``name``."""
    try:
        a = np.asarray(x)
        reason = "" if a.dtype.kind in "biuf" else f"values of type {a.dtype}"
    except (ValueError, TypeError) as exc:  # ragged nesting
        reason = str(exc)
    if reason:
        shown = repr(x)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        raise ManipcadError(f"{name} must be real numbers (an array of floats), got "
                            f"{shown}: {reason}")
    return a.astype(np.float64, copy=False)


def as_gravity(robot, gravity) -> np.ndarray:
    """The gravity vector (3,), m/s²: the robot's unless one is given."""
    if gravity is None:
        return robot.gravity
    g = as_floats("gravity", gravity)
    if g.shape != (3,) or not np.isfinite(g).all():
        raise ManipcadError("gravity must be a finite vector of shape (3,), "
                            f"got {np.shape(gravity)}")
    return g


def as_fext(n: int, N: int, single: bool, f_ext) -> tuple[np.ndarray, bool]:
    """External wrenches as (N, n, 6) [force N, moment N·m] per link, or a dummy when None."""
    if f_ext is None:
        return NO_FEXT, False
    f = as_floats("f_ext", f_ext)
    if f.shape == (n, 6):
        f = np.broadcast_to(f, (N, n, 6))
    elif f.shape != (N, n, 6) or single:
        want = f"({n}, 6)" if single else f"({n}, 6) or ({N}, {n}, 6)"
        raise ManipcadError(f"f_ext must have shape {want}: [force, moment] per link, "
                            f"got {f.shape}")
    if not np.isfinite(f).all():
        raise ManipcadError("f_ext holds NaN or infinite values")
    return writable_c(f), True


# ------------------------------------------------------------------ fast paths

#: batches with fewer joint-states (N·n) than this run on one thread (about a
#: millisecond of work): a parallel region costs microseconds when cores are
#: free, and up to a scheduler time slice when other processes hold them
#: (see docs/performance.md)
PARALLEL_MIN_WORK = 20000
_parallel_lock = threading.Lock()
#: False in a process forked from the one that imported this module (e.g. a Dask worker
#: forked by :mod:`manipcad.parallel`): numba's thread pools are not fork-safe (a forked
#: child's pool has no threads behind it), so a forked process runs every batch serially
_threads_usable = [True]


def _forked() -> None:
    _threads_usable[0] = False


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forked)


def batch_runner(serial, parallel, states_arg: int):
    """A caller of a batch kernel that runs large batches on numba's threads.

    ``serial(*args)`` and ``parallel(*args, chunks)`` take the same arguments,
    the model table first and the (N, n) states at position ``states_arg``.
    One parallel batch runs at a time (numba's fallback thread pool does not
    allow concurrent launches); a call that finds one running goes serial.
    """

    def run(*args):
        N, n = args[states_arg].shape
        threads = nb.get_num_threads()
        if (threads > 1 and N >= 2 * threads and N * n >= PARALLEL_MIN_WORK
                and _threads_usable[0]):
            if _parallel_lock.acquire(blocking=False):
                old = nb.set_parallel_chunksize(1)  # each chunk to whichever thread is free
                try:
                    return parallel(*args, min(N, 8 * threads))
                finally:
                    nb.set_parallel_chunksize(old)
                    _parallel_lock.release()
        return serial(*args)

    return run


def vector_kernel(store: dict, name: str):
    """The compiled one-state kernel ``name`` (rnea, mass, aba, crba), made on first use.

    Fixed argument types, those the batch path passes, so that both run one
    compiled loop: the (readonly) model table, C-contiguous float64 vectors,
    the drives flag, a float64 output made by the caller, and (dynamics only)
    the external wrenches and their flag, passed as ``NO_FEXT, False`` (from
    Python, so that numba does not compile the loop again for a literal).
    Other types (readonly or strided vectors too) raise TypeError at the call,
    lengths other than n ValueError: the caller then takes the checked path.
    """


    table = nt.Array(nt.float64, 2, "C", readonly=True)
    vec = nt.float64[::1]
    state = (table, vec, vec, vec, vec, nt.boolean, vec, nt.float64[:, :, ::1], nt.boolean)
    func, sig = {
        "rnea": (rnea_vector, nt.int64(*state)),
        "aba": (aba_vector, nt.int64(*state)),
        "crba": (crba_fd_vector, nt.int64(*state)),
        "mass": (crba_vector, nt.void(table, vec, nt.boolean, nt.float64[:, ::1])),
    }[name]
    kernel = nb.njit([sig], cache=True, nogil=True)(func)
    store[name] = kernel
    return kernel
