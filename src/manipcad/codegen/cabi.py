"""The C ABI of the generated kernels for other compiled loops: signatures and a pointer cast.

A generated kernel wrapped by :meth:`manipcad.codegen.GeneratedDynamics.cfunc` takes the
addresses (``arr.ctypes.data``) of float64 buffers and returns an int64; its numba type,
``numba.types.FunctionType(CFUNC_SIGNATURES[name])``, is the same for every robot, so a
compiled caller (the simulator) compiles once and can be cached.
"""

from __future__ import annotations

import numba as nb
from numba.core import cgutils
from numba.core.extending import intrinsic

_ADDR = nb.types.uintp
#: signatures of :meth:`GeneratedDynamics.cfunc` (arguments: buffer addresses)
CFUNC_SIGNATURES = {
    "inverse_dynamics": nb.types.int64(_ADDR, _ADDR, _ADDR, _ADDR),
    "mass_matrix": nb.types.int64(_ADDR, _ADDR),
    "moment_components": nb.types.int64(_ADDR, _ADDR, _ADDR, _ADDR, _ADDR),
    "forward_dynamics": nb.types.int64(_ADDR, _ADDR, _ADDR, _ADDR),
}


@intrinsic
def f64_ptr(typingctx, addr):
    """The address (an integer) as a ``double *`` (for ``numba.carray``)."""
    sig = nb.types.CPointer(nb.types.float64)(addr)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(signature.return_type))

    return sig, codegen


@intrinsic(prefer_literal=True)
def stack_vector(typingctx, size):
    """A float64 vector of ``size`` entries (a literal int) in the calling function's stack
    frame: no allocation and no reference count (the array has no owner), uninitialised.

    For small fixed-size scratch inside a compiled kernel (the generated single-state
    kernels' angle block, :func:`manipcad.codegen.trig.sincos_block`); the vector must not
    outlive the function that made it (never return or store it).

    Example:
        >>> import numba as nb
        >>> from manipcad.codegen.cabi import stack_vector
        >>> @nb.njit
        ... def f(x):
        ...     v = stack_vector(4)
        ...     for i in range(4):
        ...         v[i] = x * i
        ...     return v.sum()
        >>> f(2.0)
        12.0
    """
    if not isinstance(size, nb.types.IntegerLiteral) or size.literal_value < 1:
        return None
    k = size.literal_value
    rty = nb.types.Array(nb.types.float64, 1, "C")
    sig = rty(size)

    def codegen(context, builder, signature, args):
        ety = context.get_value_type(nb.types.float64)
        ptr = cgutils.alloca_once(builder, ety, size=k)  # in the entry block
        out = context.make_array(rty)(context, builder)
        item = context.get_constant(nb.types.intp, 8)
        context.populate_array(out, data=ptr,
                               shape=cgutils.pack_array(builder, [
                                   context.get_constant(nb.types.intp, k)]),
                               strides=cgutils.pack_array(builder, [item]), itemsize=item,
                               meminfo=None)
        return out._getvalue()

    return sig, codegen
