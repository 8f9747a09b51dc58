"""The classical fourth-order Runge–Kutta step, written once (compiled, inlined).

Both fixed-step integrators of manipcad call these two: the closed-loop simulator
(:func:`manipcad.sim.loop.run`) and the standalone drive model
(:func:`manipcad.drives.model.rk4_drive`). The caller evaluates its own right-hand
side at the stage states; the input (U) is held over the step.

For ẋ = f(x) and a step h, with K[s] = f(xs_s):

    xs_0 = x,  xs_1 = x + h/2·K[0],  xs_2 = x + h/2·K[1],  xs_3 = x + h·K[2]
    x(t + h) = x + h/6·(K[0] + 2·K[1] + 2·K[2] + K[3])

Example:
    >>> import numpy as np
    >>> from manipcad.rk4 import rk4_stage, rk4_update
    >>> x, K, xs = np.array([1.0]), np.empty((4, 1)), np.empty(1)
    >>> for st in range(4):  # one step of x' = -x, h = 0.1
    ...     rk4_stage(x, K, st, 0.1, xs)
    ...     K[st] = -xs
    >>> rk4_update(x, K, 0.1, x)
    >>> float(x[0])  # exp(-0.1) = 0.904837418...
    0.9048375
"""

from __future__ import annotations

import numba as nb


@nb.njit(cache=True, inline="always")
def rk4_stage(x, K, st, h, xs):
    """The state xs (nx,) at which stage ``st`` (0..3) of an RK4 step of h s from x
    evaluates the rate; K (4, nx) holds the rates of the stages before it."""
    nx = x.shape[0]
    if st == 0:
        for j in range(nx):
            xs[j] = x[j]
    elif st == 3:
        for j in range(nx):
            xs[j] = x[j] + h * K[2, j]
    else:
        h2 = 0.5 * h
        for j in range(nx):
            xs[j] = x[j] + h2 * K[st - 1, j]


@nb.njit(cache=True, inline="always")
def rk4_update(x, K, h, out):
    """out = x + h/6·(K[0] + 2·K[1] + 2·K[2] + K[3]): the state after the step (``out``
    may be ``x``)."""
    h6 = h / 6.0
    for j in range(x.shape[0]):
        out[j] = x[j] + h6 * (K[0, j] + 2.0 * K[1, j] + 2.0 * K[2, j] + K[3, j])
