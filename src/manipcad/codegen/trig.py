"""sin and cos of a joint angle together, the same numbers in numba (scalar and vectorized) and C.

The generated kernels spend about half of a batch's time in libm's ``sin`` and ``cos``
(Panda inverse dynamics: 87 of 166 ns per state), which a compiler cannot vectorize.
This is fdlibm's algorithm without branches: the reduction by π/2 in two parts plus a
tail (``__ieee754_rem_pio2``'s medium case) and the kernels ``__kernel_sin`` /
``__kernel_cos`` with the tail, the quadrant chosen by selects. Over |x| <= 1e5 it agrees
with glibc's ``sin``/``cos`` within 1 ulp (tested); beyond, and for inf/NaN, libm's own
``sin``/``cos`` are called. Written with floor only (no other libm), so the batch loop
:func:`sincos_many` vectorizes (about 1.9 ns per angle against 11.8 ns with libm), and the
C twin :data:`C_SOURCE` (the generated C's ``<prefix>_sincos``) performs the same IEEE
operations, so one-state calls, batches and the C give the same numbers bit for bit.

Example:
    >>> import math
    >>> from manipcad.codegen.trig import sincos
    >>> s, c = sincos(0.5)
    >>> abs(s - math.sin(0.5)) <= 1.2e-16 and abs(c - math.cos(0.5)) <= 1.2e-16
    True
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: beyond this |x| (rad) libm's sin and cos are used
LIMIT = 1.0e5

# fdlibm's constants: 2/π, π/2 in two 33-bit parts and the tail of the second
_INVPIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e+00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_2T = 2.02226624879595063154e-21
_S = (-1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04,
      2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10)
_C = (4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05,
      -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11)
S1, S2, S3, S4, S5, S6 = _S
C1, C2, C3, C4, C5, C6 = _C


@nb.njit(cache=True, inline="always")
def _reduced(x):
    """(sin x, cos x) for |x| <= LIMIT, branch-free."""
    fn = math.floor(x * _INVPIO2 + 0.5)
    t = x - fn * _PIO2_1
    w = fn * _PIO2_2
    r = t - w
    w = fn * _PIO2_2T - ((t - r) - w)
    y = r - w
    tail = (r - y) - w
    z = y * y
    v = z * y
    rs = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))
    s = y - ((z * (0.5 * tail - v * rs) - tail) - v * S1)
    rc = z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))))
    hz = 0.5 * z
    ww = 1.0 - hz
    c = ww + (((1.0 - ww) - hz) + (z * rc - y * tail))
    q = np.int64(fn) & 3
    odd = (q & 1) == 1
    s1 = c if odd else s
    c1 = -s if odd else c
    neg = (q & 2) == 2
    return (-s1 if neg else s1), (-c1 if neg else c1)


@nb.njit(cache=True, inline="always")
def sincos(x):
    """(sin x, cos x) of one angle x (rad); within 1 ulp of libm (its own beyond 1e5 rad)."""
    if not (x <= LIMIT and x >= -LIMIT):
        return math.sin(x), math.cos(x)
    return _reduced(x)


@nb.njit(cache=True, inline="always")
def sincos_block(X, S, C):
    """S[i], C[i] = sin X[i], cos X[i], inlined (numba IR) into the caller; also the body
    of :func:`sincos_many`. For the few angles of ONE state in a small fixed-size block
    (the generated single-state kernels put a joint's angles, padded to a multiple of 4,
    in :func:`manipcad.codegen.cabi.stack_vector` buffers), the loop's trip count is a
    constant and LLVM vectorizes it with no remainder. The same numbers as
    :func:`sincos`.

    Example:
        >>> import numba as nb
        >>> from manipcad.codegen.cabi import stack_vector
        >>> from manipcad.codegen.trig import sincos, sincos_block
        >>> @nb.njit
        ... def f(a, b):
        ...     X, S, C = stack_vector(4), stack_vector(4), stack_vector(4)
        ...     X[0], X[1], X[2], X[3] = a, b, 0.0, 0.0
        ...     sincos_block(X, S, C)
        ...     return S[1], C[1]
        >>> f(0.3, 2.5) == sincos(2.5)
        True
    """
    for i in range(X.shape[0]):
        s, c = _reduced(X[i])
        S[i] = s
        C[i] = c
    ok = True
    for i in range(X.shape[0]):
        ok = ok & (abs(X[i]) <= LIMIT)  # false for NaN too
    if not ok:
        for i in range(X.shape[0]):
            x = X[i]
            if not (x <= LIMIT and x >= -LIMIT):
                S[i] = math.sin(x)
                C[i] = math.cos(x)


@nb.njit(cache=True)
def sincos_many(X, S, C):
    """S[i], C[i] = sin X[i], cos X[i] for float64 vectors (rad): a vectorized loop, then
    libm for the entries beyond 1e5 rad or not finite. The same numbers as :func:`sincos`
    (the loop is :func:`sincos_block`'s, compiled here as a function of its own)."""
    sincos_block(X, S, C)


def _lit(v: float) -> str:
    return repr(float(v))


#: the C twin (``@PREFIX@`` replaced by the prefix): no libm but sin and cos beyond 1e5 rad
C_SOURCE = f"""\
/* sin and cos of an angle together: fdlibm's reduction and kernels without branches
   (manipcad.codegen.trig), within 1 ulp of libm; libm's own beyond 1e5 rad. */
static inline void @PREFIX@_sincos(double x, double *sp, double *cp)
{{
    double fn, t, w, r, y, tail, z, v, rs, s, rc, hz, ww, c, s1, c1;
    long i, q;
    if (!(x <= {_lit(LIMIT)} && x >= -{_lit(LIMIT)})) {{
        *sp = sin(x);
        *cp = cos(x);
        return;
    }}
    t = x * {_lit(_INVPIO2)} + 0.5;
    i = (long)t;
    if ((double)i > t)
        i -= 1;
    fn = (double)i;
    t = x - fn * {_lit(_PIO2_1)};
    w = fn * {_lit(_PIO2_2)};
    r = t - w;
    w = fn * {_lit(_PIO2_2T)} - ((t - r) - w);
    y = r - w;
    tail = (r - y) - w;
    z = y * y;
    v = z * y;
    rs = {_lit(S2)} + z * ({_lit(S3)} + z * ({_lit(S4)} + z * ({_lit(S5)} + z * {_lit(S6)})));
    s = y - ((z * (0.5 * tail - v * rs) - tail) - v * ({_lit(S1)}));
    rc = z * ({_lit(C1)} + z * ({_lit(C2)} + z * ({_lit(C3)} + z * ({_lit(C4)} + z * ({_lit(C5)}
         + z * ({_lit(C6)}))))));
    hz = 0.5 * z;
    ww = 1.0 - hz;
    c = ww + (((1.0 - ww) - hz) + (z * rc - y * tail));
    q = i & 3;
    s1 = (q & 1) ? c : s;
    c1 = (q & 1) ? -s : c;
    *sp = (q & 2) ? -s1 : s1;
    *cp = (q & 2) ? -c1 : c1;
}}
"""
