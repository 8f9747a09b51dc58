"""Views and addresses without reference counts, for the simulator's hot loop.

numba counts references atomically (``lock inc``/``lock dec``) on every array view it
makes (``a[j]`` of a 2-D array) and on every ``arr.ctypes``; profiled with ``perf`` on the
benchmark's closed loop (PUMA 560, RK4, dt 1e-4 s) those two instructions of
``NRT_incref``/``NRT_decref`` took 42 % of the run. Inside one compiled call the parent
arrays outlive every view made of them, so the views need no count: :func:`row` gives row
``i`` of a C-contiguous 2-D array as a 1-D view with no owner (numba skips the count of a
null owner) and :func:`address` the address of an array's data.

A compiled function also counts a reference to every array of every argument when it
is called (a tuple of arrays: each of them): passing the simulator's named structures
(:class:`~manipcad.sim.loop.Plant` alone holds some twenty arrays) to the functions
called at every sample and step cost the adaptive integrator some 40 % of its time on
the UR5 job (``perf``: ``NRT_incref``/``NRT_decref`` 34 % of the whole process).
:func:`borrowed` gives such a structure (an argument of the compiled call, which its
caller keeps alive) with every array in it holding no reference.

Example:
    >>> import numba as nb, numpy as np
    >>> from manipcad.sim.borrow import address, row
    >>> @nb.njit
    ... def f(a):
    ...     return row(a, 1).sum(), address(a) == a.ctypes.data
    >>> f(np.arange(6.0).reshape(2, 3))
    (12.0, True)
"""

from __future__ import annotations

import numba as nb
from numba import types
from numba.core import cgutils
from numba.core.extending import intrinsic

#: the decorator of a compiled function that only other compiled functions call: numba
#: builds no Python entry for it (the wrapper that unboxes every argument from Python
#: objects; for a callee taking the simulator's structures, some 80 % of its compile
#: time: 0.30 s against 0.06 s of CPU for a three-line function taking the
#: :class:`~manipcad.sim.loop.Plant`) and no C entry. Such a function cannot be called
#: from Python; ``.compile(signature)`` and the cache work as for any other.
callee = nb.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)


@intrinsic
def row(typingctx, arr, i):
    """Row ``i`` of a C-contiguous 2-D array as a 1-D view that holds no reference (the
    caller keeps ``arr`` alive while the view is used; no bounds check)."""
    if not (isinstance(arr, types.Array) and arr.ndim == 2 and arr.layout == "C"
            and isinstance(i, types.Integer)):
        return None
    rty = types.Array(arr.dtype, 1, "C")
    sig = rty(arr, i)

    def codegen(context, builder, signature, args):
        aty = signature.args[0]
        a = context.make_array(aty)(context, builder, args[0])
        k = context.cast(builder, args[1], signature.args[1], types.intp)
        ncols = builder.extract_value(a.shape, 1)
        ptr = builder.gep(a.data, [builder.mul(k, ncols)])
        out = context.make_array(rty)(context, builder)
        size = context.get_constant(types.intp,
                                    context.get_abi_sizeof(context.get_data_type(aty.dtype)))
        context.populate_array(out, data=ptr, shape=cgutils.pack_array(builder, [ncols]),
                               strides=cgutils.pack_array(builder, [size]), itemsize=size,
                               meminfo=None)
        return out._getvalue()

    return sig, codegen


@intrinsic
def address(typingctx, arr):
    """The address of an array's first element (as ``arr.ctypes.data``, without a count)."""
    if not isinstance(arr, types.Array):
        return None
    sig = types.uintp(arr)

    def codegen(context, builder, signature, args):
        a = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.ptrtoint(a.data, context.get_value_type(types.uintp))

    return sig, codegen


def _strip(context, builder, ty, val):
    """``val`` of type ``ty`` with the owner (meminfo) of every array in it set to null."""
    if isinstance(ty, types.Array):
        a = context.make_array(ty)(context, builder, val)
        a.meminfo = cgutils.get_null_value(a.meminfo.type)
        return a._getvalue()
    if isinstance(ty, types.BaseTuple):
        out = val
        for k, ety in enumerate(ty.types):
            out = builder.insert_value(
                out, _strip(context, builder, ety, builder.extract_value(val, k)), k)
        return out
    return val


@intrinsic
def borrowed(typingctx, obj):
    """``obj`` (an array, or a tuple or named tuple of arrays and other values, nested)
    with every array in it a view that holds no reference: passed on to other compiled
    functions, its arrays cost no atomic count. The caller keeps ``obj`` alive while the
    result is used (an argument of the running compiled call is)."""
    if not isinstance(obj, types.Array | types.BaseTuple):
        return None
    sig = obj(obj)

    def codegen(context, builder, signature, args):
        out = _strip(context, builder, signature.args[0], args[0])
        # the result is a new reference: the values left as they were (a structure
        # reference, say) are counted once more, as the caller will release them
        context.nrt.incref(builder, signature.return_type, out)
        return out

    return sig, codegen


@intrinsic
def keep(typingctx, obj):
    """Nothing, but a use of ``obj``: numba releases a variable after its last use, so
    ``keep(owner)`` after the last use of a :func:`borrowed` view of it keeps the owner
    (and the view's data) alive until there."""
    sig = types.none(obj)

    def codegen(context, builder, signature, args):
        return context.get_dummy_value()

    return sig, codegen
