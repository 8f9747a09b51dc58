"""The C ABI of the generated kernels for other compiled loops: signatures and a pointer cast.

A generated kernel wrapped by :meth:`manipcad.codegen.GeneratedDynamics.cfunc` takes the
addresses (``arr.ctypes.data``) of float64 buffers and returns an int64; its numba type,
``numba.types.FunctionType(CFUNC_SIGNATURES[name])``, is the same for every robot, so a
compiled caller (the simulator) compiles once and can be cached.
"""

from __future__ import annotations

import numba as nb
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
