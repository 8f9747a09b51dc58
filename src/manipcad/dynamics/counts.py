"""Operation counts of our dynamics kernels, obtained by running them.

The kernels are written in scalar arithmetic, so their plain-Python source
(``kernel.py_func``) runs on arrays of :class:`Counted` numbers: every
multiplication (or division) and addition (or subtraction) between values
that depend on the state is counted. Sine and cosine of the joint angles are
not counted, as in the paper. Model constants (the placement rotation, the
link's mass and inertia) are Counted too, so a product by a constant counts:
it is what the compiled code executes.
"""

from __future__ import annotations

import math
import types
from functools import cache

import numpy as np

from manipcad.dynamics.aba import ABA_WORK, aba_one
from manipcad.dynamics.crba import CRBA_WORK, crba_one
from manipcad.dynamics.rnea import RNEA_WORK, rnea_one
from manipcad.errors import ManipcadError
from manipcad.model.dh import rot_x
from manipcad.model.robot import Robot


class _Tally:
    mul = 0
    add = 0
    func = 0  # square roots and exponentials (sine and cosine of joint angles are not counted)


class Counted:
    """A float that counts the arithmetic done with it into a tally."""

    __slots__ = ("v",)
    tally = _Tally()

    def __init__(self, v: float) -> None:
        self.v = float(v)

    @staticmethod
    def _val(x):
        return x.v if isinstance(x, Counted) else x

    def __add__(self, o):
        Counted.tally.add += 1
        return Counted(self.v + Counted._val(o))

    __radd__ = __add__

    def __sub__(self, o):
        Counted.tally.add += 1
        return Counted(self.v - Counted._val(o))

    def __rsub__(self, o):
        Counted.tally.add += 1
        return Counted(Counted._val(o) - self.v)

    def __mul__(self, o):
        Counted.tally.mul += 1
        return Counted(self.v * Counted._val(o))

    __rmul__ = __mul__

    def __truediv__(self, o):
        Counted.tally.mul += 1
        return Counted(self.v / Counted._val(o))

    def __rtruediv__(self, o):
        Counted.tally.mul += 1
        return Counted(Counted._val(o) / self.v)

    def __neg__(self):
        return Counted(-self.v)

    def __abs__(self):
        return Counted(abs(self.v))

    def __float__(self):
        return self.v

    def __int__(self):
        return int(self.v)

    def __eq__(self, o):
        return self.v == Counted._val(o)

    def __ne__(self, o):
        return self.v != Counted._val(o)

    def __lt__(self, o):
        return self.v < Counted._val(o)

    def __le__(self, o):
        return self.v <= Counted._val(o)

    def __gt__(self, o):
        return self.v > Counted._val(o)

    def __ge__(self, o):
        return self.v >= Counted._val(o)

    __hash__ = None  # type: ignore[assignment]


def _func(f):
    def counted(x):
        Counted.tally.func += 1
        return Counted(f(float(x)))
    return counted


_counting_math = types.SimpleNamespace(
    cos=lambda x: Counted(math.cos(float(x))),
    sin=lambda x: Counted(math.sin(float(x))),
    sqrt=_func(math.sqrt),
    exp=_func(math.exp),
    isfinite=lambda x: math.isfinite(float(x)),
    inf=math.inf,
    nan=math.nan,
)


def _plain(func, seen: dict | None = None):
    """The pure-Python twin of a compiled kernel whose compiled callees are twins too."""
    seen = {} if seen is None else seen
    py = getattr(func, "py_func", func)
    if py in seen:
        return seen[py]
    g = dict(py.__globals__)
    twin = types.FunctionType(py.__code__, g, py.__name__, py.__defaults__, py.__closure__)
    seen[py] = twin
    for name in py.__code__.co_names:
        obj = g.get(name)
        if hasattr(obj, "py_func"):
            g[name] = _plain(obj, seen)
    g["math"] = _counting_math
    return twin


def _counted(a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    out = np.empty(a.shape, dtype=object)
    for idx, v in np.ndenumerate(a):
        out[idx] = Counted(v)
    return out


def _chain(n: int):
    """A generic n-joint chain of revolute joints with general placements and full inertias."""

    rng = np.random.default_rng(0)
    Rs = np.array([rot_x(a) for a in rng.uniform(-1.5, 1.5, n)])
    ps = rng.uniform(-0.5, 0.5, (n, 3))
    A = rng.normal(size=(n, 3, 3))
    inertia = A @ A.transpose(0, 2, 1) * 0.01 + np.eye(3) * 0.01
    return Robot.from_arrays(f"chain{n}", ["revolute"] * n, np.arange(n) - 1, Rs, ps,
                             rng.uniform(1, 5, n), rng.uniform(-0.2, 0.2, (n, 3)), inertia)


@cache
def operation_counts(algorithm: str, n: int) -> dict[str, int]:
    """Multiplications and additions our kernel performs for an n-joint revolute chain.

    Counted by running the kernel's own source on counting numbers (see the
    module docstring), with gravity, without drives and external forces.

    Args:
        algorithm: "rnea" (inverse dynamics), "crba" (mass matrix) or "aba"
            (O(n) forward dynamics).
        n: number of joints (>= 1).

    Returns:
        ``{"mul": ..., "add": ...}``; divisions count as multiplications and
        subtractions as additions.

    Example:
        >>> from manipcad import operation_counts
        >>> operation_counts("rnea", 6)["mul"] > 0
        True
    """

    if algorithm not in ("rnea", "crba", "aba") or int(n) < 1:
        raise ManipcadError(f"operation_counts needs algorithm rnea|crba|aba and n >= 1, "
                            f"got {algorithm!r}, {n}")
    robot = _chain(int(n))
    rng = np.random.default_rng(1)
    table = _counted(robot.table)
    g = _counted(robot.gravity)
    q, qd, x = (_counted(rng.uniform(-1, 1, n)) for _ in range(3))
    fext = _counted(np.zeros((n, 6)))
    out = np.empty(n, dtype=object)
    Counted.tally = _Tally()
    if algorithm == "rnea":
        work = np.empty((n, RNEA_WORK), dtype=object)
        _plain(rnea_one)(table, g, q, qd, x, fext, False, False, work, out)
    elif algorithm == "crba":
        work = np.empty((n, CRBA_WORK), dtype=object)
        tmp = np.empty((8, 3), dtype=object)
        _plain(crba_one)(table, q, False, work, tmp, np.empty((n, n), dtype=object))
    else:
        work = np.empty((n, ABA_WORK), dtype=object)
        _plain(aba_one)(table, g, q, qd, x, fext, False, False, work, out)
    return {"mul": Counted.tally.mul, "add": Counted.tally.add}
