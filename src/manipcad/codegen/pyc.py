"""Portable C99 from the numba kernels themselves: a partial evaluator of their Python AST.

The compiled regulator updates (``law(p, s, sig, j, Ts)``) and the helper kernels they
call are written in a small subset of Python (scalar float/int arithmetic, comparisons,
``if``/``else``, ``for ... in range(...)``, tuples, array indexing and slicing, calls of
other ``numba.njit`` functions, ``abs``/``min``/``max``/``int``/``float`` and
``math.sqrt``/``sin``/``cos``). :class:`Translator` turns such a function into C99 for
given arguments, so the C a drive controller runs comes from the same source the
simulator runs — there is no second, hand-written copy of a law.

Every argument is either known at generation time (a number, or an array whose contents
are fixed, such as a regulator's parameter block) or a run-time input (a C parameter).
Whatever depends only on known values is computed here, in Python's IEEE double
arithmetic, which is the arithmetic the C performs: known branches are taken or dropped,
loops with a known trip count are unrolled, and calls whose arguments are all known are
folded to numbers. That is how ``math.exp`` and the other functions beyond the allowed
libm set (``sin``, ``cos``, ``sqrt``) reach the C: only as numbers, e.g. an ACE filter's
e^(−T_s/T_1). A run-time argument to such a function is refused with an error naming the
function, file and line. Each helper is emitted as a ``static`` C function specialized on
its known arguments; functions returning tuples return a small struct.

Not supported (a clear :class:`~manipcad.errors.ManipcadError` naming file and line):
``while``, ``break``/``continue``, a ``for`` whose trip count is not known, ``//``, ``%``,
``**`` other than a known integer power of at most 4, a run-time value flowing into a
known-only libm function, writes into a known (constant) array.

Example:
    >>> import numba as nb
    >>> @nb.njit
    ... def f(x, k):
    ...     return x * k if k > 0.0 else -x
    >>> t = Translator("ex")
    >>> name, ret, params = t.function(f, [Dyn("x", "double"), Known(2.0)])
    >>> print(t.source().split("static ")[-1].strip())
    double ex_f_0(double x) {
        (void)x;
        return (x * 2.0);
    }
"""

from __future__ import annotations

import ast
import inspect
import math
import re
import struct
import textwrap
import types
from dataclasses import dataclass, field

import numpy as np

from manipcad.errors import ManipcadError

#: libm functions the emitted C may call on run-time values (the rest must fold)
RUNTIME_MATH = {"sqrt": "sqrt", "sin": "sin", "cos": "cos"}
#: helpers put at the top of every emitted file (no libm: bit operations and comparisons)
PREAMBLE = """\
static inline double mc_fabs(double x) {
    union { double d; uint64_t u; } v;
    v.d = x;
    v.u &= 0x7fffffffffffffffULL;
    return v.d;
}
static inline double mc_fmin(double a, double b) { return b < a ? b : a; }
static inline double mc_fmax(double a, double b) { return b > a ? b : a; }
static inline long mc_lmin(long a, long b) { return b < a ? b : a; }
static inline long mc_lmax(long a, long b) { return b > a ? b : a; }
static inline long mc_labs(long a) { return a < 0 ? -a : a; }
"""


# ---------------------------------------------------------------- abstract values


@dataclass(frozen=True)
class Known:
    """A value known at generation time (float, int or bool)."""

    value: object


@dataclass(frozen=True)
class Dyn:
    """A run-time value: a C expression and its C type ('double', 'long' or 'int')."""

    code: str
    ctype: str


@dataclass(frozen=True)
class Tup:
    """A tuple of abstract values."""

    items: tuple


@dataclass
class Arr:
    """An array: its C base name, known contents (or None), offset, shape.

    ``data`` is the array's contents when known at generation time (then reads at a
    known index fold to numbers, and the array must never be written); ``name`` is the
    C name of its first element's storage; ``offset`` (int or :class:`Dyn`) where this
    view starts; ``shape`` the shape of the view (2-D: row-major, the row length known);
    ``row`` (2-D only) the one row the code may read (a drive controller's own signals:
    the C array is that row alone); ``ctype`` of the elements.
    """

    name: str
    data: np.ndarray | None
    shape: tuple
    ctype: str = "double"
    offset: object = 0
    row: int | None = None
    written: list = field(default_factory=lambda: [False])


def _flt(v) -> str:
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, int | np.integer):
        return f"{int(v)}L" if abs(int(v)) > 2**31 - 1 else str(int(v))
    v = float(v)
    if math.isnan(v):
        return "NAN"
    if math.isinf(v):
        return "INFINITY" if v > 0 else "(-INFINITY)"
    s = repr(v)
    return f"({s})" if s.startswith("-") else s


def literal(a) -> str:
    """C literal of a :class:`Known` (or a plain number): exact (shortest round-trip)."""
    return _flt(a.value if isinstance(a, Known) else a)


def _ctype_of_known(v) -> str:
    if isinstance(v, bool | np.bool_):
        return "int"
    if isinstance(v, int | np.integer):
        return "long"
    return "double"


def ctype(a) -> str:
    """C type of a scalar abstract value."""
    return _ctype_of_known(a.value) if isinstance(a, Known) else a.ctype


def code(a) -> str:
    """C expression of a scalar abstract value."""
    if isinstance(a, Known):
        return literal(a)
    if isinstance(a, Dyn):
        return a.code
    raise TypeError(a)


def _unify(types_: list[str]) -> str:
    if "double" in types_:
        return "double"
    if "long" in types_:
        return "long"
    return "int"


def _same_known(a, b) -> bool:
    if not (isinstance(a, Known) and isinstance(b, Known)):
        return False
    if type(a.value) is not type(b.value):
        return False
    if isinstance(a.value, float):
        return struct.pack("<d", a.value) == struct.pack("<d", b.value)
    return a.value == b.value


_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_.]*$")


@dataclass
class _Spec:
    cname: str
    rettype: str | None  # None: void; "struct" for tuples
    params: list  # (python param index, C declaration)
    folded: object = None  # a Known/Tup when the call folds to numbers


class _Return(Exception):
    pass


class _Ctx:
    """The emission state of one specialized function."""

    def __init__(self, tr: Translator, fn, src_file: str, line0: int) -> None:
        self.tr = tr
        self.fn = fn
        self.file = src_file
        self.line0 = line0
        self.lines: list[str] = []
        self.env: dict = {}
        self.returns: list = []
        self.depth = 0

    # ---- helpers
    def err(self, node, msg: str) -> ManipcadError:
        line = self.line0 + getattr(node, "lineno", 1) - 1
        return ManipcadError(f"cannot translate {self.fn.__name__} to C ({self.file}:{line}): "
                             f"{msg}")

    def tmp(self, base: str = "t") -> str:
        return self.tr.fresh(base)

    def emit(self, line: str) -> None:
        self.lines.append("    " * (self.depth + 1) + line)

    def materialize(self, a, base: str = "t"):
        """A run-time value held in a C variable (Known values stay known)."""
        if isinstance(a, Known) or (isinstance(a, Dyn) and _IDENT.match(a.code)):
            return a
        name = self.tmp(base)
        self.emit(f"{a.ctype} {name} = {a.code};")
        return Dyn(name, a.ctype)

    # ---- statements
    def block(self, stmts) -> bool:
        """Translate statements; True when every path returned."""
        for st in stmts:
            if self.stmt(st):
                return True
        return False

    def stmt(self, st) -> bool:
        if isinstance(st, ast.Expr):
            if isinstance(st.value, ast.Constant):
                return False  # docstring
            self.ev(st.value)
            return False
        if isinstance(st, ast.Pass):
            return False
        if isinstance(st, ast.Assign):
            val = self.ev(st.value)
            for tgt in st.targets:
                self.assign(tgt, val, st)
            return False
        if isinstance(st, ast.AnnAssign) and st.value is not None:
            self.assign(st.target, self.ev(st.value), st)
            return False
        if isinstance(st, ast.AugAssign):
            if isinstance(st.target, ast.Name):
                cur = self.load_name(st.target.id, st)
            else:
                cur = self.ev(st.target)
            val = self.binop(st.op, cur, self.ev(st.value), st)
            self.assign(st.target, val, st)
            return False
        if isinstance(st, ast.Return):
            val = Known(None) if st.value is None else self.ev(st.value)
            self.do_return(val, st)
            return True
        if isinstance(st, ast.If):
            return self.if_stmt(st)
        if isinstance(st, ast.For):
            return self.for_stmt(st)
        raise self.err(st, f"statement {type(st).__name__} is not supported")

    def assign(self, tgt, val, node) -> None:
        if isinstance(tgt, ast.Name):
            if tgt.id == "_":
                return
            if isinstance(val, Dyn) and not _IDENT.match(val.code):
                val = self.materialize(val, tgt.id)
            self.env[tgt.id] = val
            return
        if isinstance(tgt, ast.Tuple):
            if isinstance(val, Tup):
                items = val.items
            else:
                raise self.err(node, "unpacking a value that is not a tuple")
            if len(items) != len(tgt.elts):
                raise self.err(node, "tuple sizes differ")
            for t, v in zip(tgt.elts, items, strict=True):
                self.assign(t, v, node)
            return
        if isinstance(tgt, ast.Subscript):
            arr = self.ev(tgt.value)
            if not isinstance(arr, Arr):
                raise self.err(node, "subscript store into a non-array")
            if arr.data is not None:
                raise self.err(node, "writes into an array known at generation time "
                                     "(a parameter block is read-only)")
            flat = self.flat_index(arr, tgt.slice, node)
            arr.written[0] = True
            self.emit(f"{arr.name}[{code(flat)}] = {code(val)};")
            return
        raise self.err(node, f"assignment to {type(tgt).__name__}")

    def do_return(self, val, node) -> None:
        self.returns.append(val)
        self.emit(f"@@RET{len(self.returns) - 1}@@")

    def if_stmt(self, st) -> bool:
        cond = self.ev(st.test)
        if isinstance(cond, Known):
            return self.block(st.body if cond.value else st.orelse)
        if not isinstance(cond, Dyn):
            raise self.err(st, "condition is not a scalar")
        env0 = dict(self.env)
        outs = []
        for body in (st.body, st.orelse):
            self.env = dict(env0)
            saved = self.lines
            self.lines = []
            self.depth += 1
            term = self.block(body)
            self.depth -= 1
            outs.append((term, self.lines, self.env))
            self.lines = saved
        live = [o for o in outs if not o[0]]
        merged = dict(env0)
        decls = []
        if live:
            names = set()
            for _, _, env in live:
                names |= {k for k, v in env.items() if env0.get(k) is not v}
            for n in sorted(names):
                vals = [env.get(n) for _, _, env in live]
                if any(v is None for v in vals):
                    continue  # undefined on some path: not usable after the if
                if all(v is vals[0] for v in vals) or all(_same_known(v, vals[0]) for v in vals):
                    merged[n] = vals[0]
                    continue
                if not all(isinstance(v, Known | Dyn) for v in vals):
                    raise self.err(st, f"{n!r} takes different non-scalar values on the "
                                       "branches")
                ct = _unify([ctype(v) for v in vals])
                var = self.tmp(n)
                decls.append(f"{ct} {var} = 0;")
                for (_, lines, _env), v in zip(live, vals, strict=True):
                    lines.append("    " * (self.depth + 2) + f"{var} = {code(v)};")
                merged[n] = Dyn(var, ct)
        for d in decls:
            self.emit(d)
        self.emit(f"if ({cond.code}) {{")
        self.lines += outs[0][1]
        if outs[1][1]:
            self.emit("} else {")
            self.lines += outs[1][1]
        self.emit("}")
        self.env = merged
        return not live

    def for_stmt(self, st) -> bool:
        if st.orelse:
            raise self.err(st, "for ... else")
        it = st.iter
        if not (isinstance(it, ast.Call) and isinstance(it.func, ast.Name)
                and it.func.id == "range" and not it.keywords):
            raise self.err(st, "only `for x in range(...)` loops")
        args = [self.ev(a) for a in it.args]
        if not all(isinstance(a, Known) for a in args):
            raise self.err(st, "a loop whose trip count is not known at generation time")
        if not isinstance(st.target, ast.Name):
            raise self.err(st, "loop target must be a name")
        rng = range(*[int(a.value) for a in args])
        if len(rng) > 256:
            raise self.err(st, f"loop of {len(rng)} iterations (at most 256 are unrolled)")
        for i in rng:
            self.env[st.target.id] = Known(i)
            if self.block(st.body):
                return True
        return False

    # ---- expressions
    def load_name(self, name: str, node):
        if name in self.env:
            return self.env[name]
        g = self.fn.__globals__
        if name in g:
            obj = g[name]
        elif hasattr(__builtins__, name) if isinstance(__builtins__, types.ModuleType) \
                else name in __builtins__:
            obj = ("builtin", name)
        else:
            raise self.err(node, f"unknown name {name!r}")
        if isinstance(obj, bool | int | float | np.integer | np.floating):
            return Known(obj.item() if isinstance(obj, np.generic) else obj)
        return obj

    def ev(self, node):
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool | int | float):
                return Known(node.value)
            raise self.err(node, f"constant {node.value!r}")
        if isinstance(node, ast.Name):
            return self.load_name(node.id, node)
        if isinstance(node, ast.Attribute):
            base = self.ev(node.value)
            if isinstance(base, types.ModuleType):
                obj = getattr(base, node.attr)
                if isinstance(obj, bool | int | float):
                    return Known(obj)
                return obj
            raise self.err(node, f"attribute {node.attr!r}")
        if isinstance(node, ast.Tuple):
            return Tup(tuple(self.ev(e) for e in node.elts))
        if isinstance(node, ast.BinOp):
            return self.binop(node.op, self.ev(node.left), self.ev(node.right), node)
        if isinstance(node, ast.UnaryOp):
            v = self.ev(node.operand)
            if isinstance(v, Known):
                if isinstance(node.op, ast.USub):
                    return Known(-v.value)
                if isinstance(node.op, ast.UAdd):
                    return v
                if isinstance(node.op, ast.Not):
                    return Known(not v.value)
            elif isinstance(v, Dyn):
                if isinstance(node.op, ast.USub):
                    return Dyn(f"(-{v.code})", "long" if v.ctype == "int" else v.ctype)
                if isinstance(node.op, ast.UAdd):
                    return v
                if isinstance(node.op, ast.Not):
                    return Dyn(f"(!{v.code})", "int")
            raise self.err(node, f"unary {type(node.op).__name__}")
        if isinstance(node, ast.Compare):
            return self.compare(node)
        if isinstance(node, ast.BoolOp):
            return self.boolop(node)
        if isinstance(node, ast.IfExp):
            return self.ifexp(node)
        if isinstance(node, ast.Subscript):
            return self.subscript(node)
        if isinstance(node, ast.Call):
            return self.call(node)
        raise self.err(node, f"expression {type(node).__name__} is not supported")

    _OPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/"}

    def binop(self, op, a, b, node):
        if not (isinstance(a, Known | Dyn) and isinstance(b, Known | Dyn)):
            raise self.err(node, "arithmetic on a non-scalar")
        if isinstance(a, Known) and isinstance(b, Known):
            try:
                return Known({ast.Add: lambda x, y: x + y, ast.Sub: lambda x, y: x - y,
                              ast.Mult: lambda x, y: x * y, ast.Div: lambda x, y: x / y,
                              ast.Pow: lambda x, y: x ** y}[type(op)](a.value, b.value))
            except KeyError:
                raise self.err(node, f"operator {type(op).__name__}") from None
            except ZeroDivisionError:
                x, y = float(a.value), float(b.value)
                return Known(math.nan if x == 0 or math.isnan(x) else math.copysign(math.inf, x)
                             * math.copysign(1.0, y))
        if isinstance(op, ast.Pow):
            if isinstance(b, Known) and isinstance(b.value, int) and 1 <= b.value <= 4:
                x = self.materialize(a)
                return Dyn("(" + " * ".join([x.code] * b.value) + ")", ctype(x))
            raise self.err(node, "power other than a known integer power 1..4")
        sym = self._OPS.get(type(op))
        if sym is None:
            raise self.err(node, f"operator {type(op).__name__} is not supported")
        ta, tb = ctype(a), ctype(b)
        if sym == "/":
            ca = code(a) if ta == "double" or tb == "double" else f"(double){code(a)}"
            return Dyn(f"({ca} / {code(b)})", "double")
        ct = "double" if "double" in (ta, tb) else "long"
        return Dyn(f"({code(a)} {sym} {code(b)})", ct)

    _CMP = {ast.Lt: ("<", lambda x, y: x < y), ast.LtE: ("<=", lambda x, y: x <= y),
            ast.Gt: (">", lambda x, y: x > y), ast.GtE: (">=", lambda x, y: x >= y),
            ast.Eq: ("==", lambda x, y: x == y), ast.NotEq: ("!=", lambda x, y: x != y)}

    def compare(self, node):
        left = self.ev(node.left)
        parts = []
        for op, rnode in zip(node.ops, node.comparators, strict=True):
            right = self.ev(rnode)
            if type(op) not in self._CMP:
                raise self.err(node, f"comparison {type(op).__name__}")
            sym, fn = self._CMP[type(op)]
            if isinstance(left, Known) and isinstance(right, Known):
                parts.append(Known(bool(fn(left.value, right.value))))
            elif isinstance(left, Known | Dyn) and isinstance(right, Known | Dyn):
                parts.append(Dyn(f"({code(left)} {sym} {code(right)})", "int"))
            else:
                raise self.err(node, "comparison of non-scalars")
            left = right
        return self._and(parts)

    @staticmethod
    def _and(parts):
        dyn = []
        for p in parts:
            if isinstance(p, Known):
                if not p.value:
                    return Known(False)
            else:
                dyn.append(p.code)
        if not dyn:
            return Known(True)
        return Dyn(dyn[0] if len(dyn) == 1 else "(" + " && ".join(dyn) + ")", "int")

    def boolop(self, node):
        is_and = isinstance(node.op, ast.And)
        dyn = []
        for vnode in node.values:
            saved = len(self.lines)
            v = self.ev(vnode)
            if dyn and len(self.lines) != saved:
                raise self.err(node, "a short-circuit operand with side effects")
            if isinstance(v, Known):
                if bool(v.value) != is_and:  # decides the result
                    if not dyn:
                        return Known(bool(v.value))
                    dyn.append(literal(Known(bool(v.value))))
                    break
                continue
            if not isinstance(v, Dyn):
                raise self.err(node, "boolean operator on non-scalars")
            dyn.append(v.code)
        if not dyn:
            return Known(is_and)
        sym = " && " if is_and else " || "
        return Dyn(dyn[0] if len(dyn) == 1 else "(" + sym.join(dyn) + ")", "int")

    def ifexp(self, node):
        cond = self.ev(node.test)
        if isinstance(cond, Known):
            return self.ev(node.body if cond.value else node.orelse)
        arms = []
        for sub in (node.body, node.orelse):
            saved = self.lines
            self.lines = []
            self.depth += 1
            v = self.ev(sub)
            self.depth -= 1
            arms.append((v, self.lines))
            self.lines = saved
        (a, la), (b, lb) = arms
        if not (isinstance(a, Known | Dyn) and isinstance(b, Known | Dyn)):
            raise self.err(node, "conditional expression of non-scalars")
        ct = _unify([ctype(a), ctype(b)])
        if not la and not lb:
            return Dyn(f"({cond.code} ? {code(a)} : {code(b)})", ct)
        var = self.tmp("c")
        self.emit(f"{ct} {var} = 0;")
        self.emit(f"if ({cond.code}) {{")
        self.lines += la
        self.emit(f"    {var} = {code(a)};")
        self.emit("} else {")
        self.lines += lb
        self.emit(f"    {var} = {code(b)};")
        self.emit("}")
        return Dyn(var, ct)

    def flat_index(self, arr: Arr, sl, node):
        idx = sl.elts if isinstance(sl, ast.Tuple) else [sl]
        vals = [self.ev(i) for i in idx]
        if len(vals) != len(arr.shape):
            raise self.err(node, f"{len(vals)} indices into a {len(arr.shape)}-D array")
        for v in vals:
            if not (isinstance(v, Known) and isinstance(v.value, int | np.integer)
                    or isinstance(v, Dyn) and v.ctype in ("long", "int")):
                raise self.err(node, "array index is not an integer")
        if len(vals) == 2:
            i, k = vals
            if arr.row is not None:
                if not (isinstance(i, Known) and i.value == arr.row):
                    raise self.err(node, f"reads a row other than its own ({arr.row}) of a "
                                         "one-row signal array")
                flat = k
            else:
                flat = self.binop(ast.Add(), self.binop(ast.Mult(), i, Known(arr.shape[1]),
                                                        node), k, node)
        else:
            flat = vals[0]
        off = arr.offset if isinstance(arr.offset, Dyn) else Known(arr.offset)
        if not (isinstance(off, Known) and off.value == 0):
            flat = self.binop(ast.Add(), off, flat, node)
        if isinstance(flat, Known) and arr.shape and arr.row is None and len(vals) == 1 \
                and arr.shape[0] is not None and not 0 <= int(vals[0].value) < arr.shape[0]:
            raise self.err(node, f"index {vals[0].value} out of range {arr.shape[0]}")
        return flat

    def subscript(self, node):
        arr = self.ev(node.value)
        if not isinstance(arr, Arr):
            raise self.err(node, "subscript of a non-array")
        sl = node.slice
        if isinstance(sl, ast.Slice):
            if sl.step is not None or len(arr.shape) != 1:
                raise self.err(node, "only 1-D slices without a step")
            lo = Known(0) if sl.lower is None else self.ev(sl.lower)
            hi = Known(arr.shape[0]) if sl.upper is None else self.ev(sl.upper)
            off = arr.offset if isinstance(arr.offset, Dyn) else Known(arr.offset)
            new = self.binop(ast.Add(), off, lo, node) if not (
                isinstance(lo, Known) and lo.value == 0) else off
            n = (hi.value - lo.value) if isinstance(lo, Known) and isinstance(hi, Known) else None
            return Arr(arr.name, arr.data, (n,), arr.ctype,
                       new.value if isinstance(new, Known) else self.materialize(new, "o"),
                       None, arr.written)
        flat = self.flat_index(arr, sl, node)
        if arr.data is not None and isinstance(flat, Known):
            v = arr.data.reshape(-1)[int(flat.value)]
            return Known(int(v) if arr.ctype == "long" else float(v))
        val = Dyn(f"{arr.name}[{code(flat)}]", arr.ctype)
        if arr.data is None:  # a mutable array: read it now (Python's order of evaluation)
            return self.materialize(val)
        return val

    def call(self, node):
        if node.keywords:
            raise self.err(node, "keyword arguments")
        f = self.ev(node.func)
        args = [self.ev(a) for a in node.args]
        if isinstance(f, tuple) and f[0] == "builtin":
            return self.builtin(f[1], args, node)
        if isinstance(f, types.BuiltinFunctionType) and getattr(f, "__module__", "") == "math":
            return self.math_call(f.__name__, args, node)
        if hasattr(f, "py_func"):
            return self.tr.call(self, f, args, node)
        raise self.err(node, f"call of {getattr(f, '__name__', f)!r} is not supported")

    def math_call(self, name, args, node):
        if all(isinstance(a, Known) for a in args):
            return Known(getattr(math, name)(*[a.value for a in args]))
        if name in RUNTIME_MATH and len(args) == 1 and isinstance(args[0], Known | Dyn):
            return Dyn(f"{RUNTIME_MATH[name]}({code(args[0])})", "double")
        raise self.err(node, f"math.{name} of a run-time value: the C may call only "
                             f"{', '.join(sorted(RUNTIME_MATH))} at run time, other functions "
                             "only on values known at generation time (folded to numbers)")

    def builtin(self, name, args, node):
        if not all(isinstance(a, Known | Dyn) for a in args):
            raise self.err(node, f"{name}() of a non-scalar")
        if all(isinstance(a, Known) for a in args) and name in ("abs", "min", "max", "int",
                                                                  "float", "bool"):
            return Known({"abs": abs, "min": min, "max": max, "int": int, "float": float,
                          "bool": bool}[name](*[a.value for a in args]))
        if name == "int" and len(args) == 1:
            return Dyn(f"((long){code(args[0])})", "long")
        if name == "float" and len(args) == 1:
            return Dyn(f"((double){code(args[0])})", "double")
        if name == "abs" and len(args) == 1:
            if ctype(args[0]) == "double":
                return Dyn(f"mc_fabs({code(args[0])})", "double")
            return Dyn(f"mc_labs({code(args[0])})", "long")
        if name in ("min", "max") and len(args) == 2:
            ct = _unify([ctype(a) for a in args])
            fn = ("mc_f" if ct == "double" else "mc_l") + name
            return Dyn(f"{fn}({code(args[0])}, {code(args[1])})",
                       "double" if ct == "double" else "long")
        raise self.err(node, f"builtin {name}() with {len(args)} arguments")


class Translator:
    """Specializes numba kernels into C functions collected in one file.

    Args:
        prefix: a C identifier put before every emitted function's name.
    """

    def __init__(self, prefix: str) -> None:
        self.prefix = prefix
        self._specs: dict = {}
        self._funcs: list[str] = []
        self._n = 0
        self._src: dict = {}

    def fresh(self, base: str) -> str:
        self._n += 1
        return f"{re.sub(r'[^A-Za-z0-9_]', '_', base)}_{self._n}"

    def _parse(self, fn):
        py = fn.py_func
        if py not in self._src:
            try:
                src = textwrap.dedent(inspect.getsource(py))
            except (OSError, TypeError) as exc:
                raise ManipcadError(f"cannot read the source of {py.__name__}: {exc}") from None
            tree = ast.parse(src).body[0]
            fname = inspect.getsourcefile(py) or "?"
            self._src[py] = (tree, fname, py.__code__.co_firstlineno)
        return self._src[py]

    @staticmethod
    def _key(a):
        if isinstance(a, Known):
            v = a.value
            return ("K", type(v).__name__, struct.pack("<d", v) if isinstance(v, float) else v)
        if isinstance(a, Dyn):
            return ("D", a.ctype)
        if isinstance(a, Arr):
            if a.data is not None and not isinstance(a.offset, Dyn):
                return ("AK", a.name, a.offset, a.shape, a.row)
            return ("AD", a.ctype, a.shape[1:], a.row, a.data is not None)
        if isinstance(a, Tup):
            return ("T",) + tuple(Translator._key(x) for x in a.items)
        raise ManipcadError(f"cannot pass {a!r} to a translated function")

    def function(self, fn, args: list):
        """Specialize ``fn`` (a numba dispatcher) on abstract ``args``.

        Returns:
            (C name, return type or None, [indices of the arguments that are C parameters]),
            or (None, folded value, []) when the call folds to a known value.
        """
        key = (fn.py_func, tuple(self._key(a) for a in args))
        if key in self._specs:
            s = self._specs[key]
        else:
            s = self._specialize(fn, args, key)
        if s.folded is not None:
            return None, s.folded, []
        return s.cname, s.rettype, [i for i, _ in s.params]

    def _specialize(self, fn, args, key) -> _Spec:
        tree, fname, line0 = self._parse(fn)
        params = [a.arg for a in tree.args.args]
        if len(params) != len(args):
            raise ManipcadError(f"{fn.py_func.__name__} takes {len(params)} arguments, "
                                f"got {len(args)}")
        ctx = _Ctx(self, fn.py_func, fname, line0)
        cparams = []
        arrays = []
        for i, (pname, a) in enumerate(zip(params, args, strict=True)):
            if isinstance(a, Known):
                ctx.env[pname] = a
            elif isinstance(a, Dyn):
                ctx.env[pname] = Dyn(pname, a.ctype)
                cparams.append((i, f"{a.ctype} {pname}"))
            elif isinstance(a, Arr):
                if a.data is not None and not isinstance(a.offset, Dyn):
                    ctx.env[pname] = Arr(a.name, a.data, a.shape, a.ctype, a.offset, a.row,
                                         [False])
                else:
                    view = Arr(pname, None, a.shape, a.ctype, 0, a.row, [False])
                    ctx.env[pname] = view
                    arrays.append((i, pname, view, a.data is not None))
                    cparams.append((i, None))
            elif isinstance(a, Tup):
                ctx.env[pname] = a
            else:
                raise ManipcadError(f"argument {pname} of {fn.py_func.__name__}: {a!r}")
        cname = f"{self.prefix}_{fn.py_func.__name__}_{len(self._specs)}"
        spec = _Spec(cname, None, [])
        self._specs[key] = spec  # (no recursion in the kernels; set before the body)
        term = ctx.block(tree.body)
        if not term and not ctx.returns:
            ctx.do_return(Known(None), tree)
        vals = list(ctx.returns)
        body_lines = [ln for ln in ctx.lines if "@@RET" not in ln]
        if not body_lines and len(vals) == 1 and self._all_known(vals[0]) and not arrays:
            spec.folded = vals[0]
            return spec
        decl = {}
        for i, pname, view, _known in arrays:
            const = "" if view.written[0] else "const "
            decl[i] = f"{const}{view.ctype} *{pname}"
        spec.params = [(i, d if d is not None else decl[i]) for i, d in cparams]
        spec.rettype = self._return_type(vals, cname)
        out = []

        def ret(m):
            v = vals[int(m.group(1))]
            if spec.rettype is None:
                return "return;"
            if isinstance(v, Tup):
                return f"return ({cname}_ret){{" + ", ".join(code(x) for x in v.items) + "};"
            return f"return {code(v)};"

        ctx.lines = [re.sub(r"@@RET(\d+)@@", ret, ln) for ln in ctx.lines]
        lines = _drop_unused(ctx.lines)
        if lines and lines[-1].strip() == "return;":
            lines.pop()
        ret = {None: "void", "struct": f"{cname}_ret"}.get(spec.rettype, spec.rettype)
        sig = ", ".join(d for _, d in spec.params) or "void"
        if spec.rettype == "struct":
            tup = next(v for v in vals if isinstance(v, Tup))
            types_ = [_unify([ctype(v.items[k]) for v in vals]) for k in range(len(tup.items))]
            out.append("typedef struct { " + " ".join(f"{t} r{k};" for k, t in
                                                       enumerate(types_)) + f" }} {cname}_ret;")
            spec.fields = types_
        out.append(f"static {ret} {cname}({sig}) {{")
        for _, d in spec.params:
            out.append(f"    (void){d.split()[-1].lstrip('*')};")
        out += lines
        out.append("}")
        self._funcs.append("\n".join(out))
        return spec

    @staticmethod
    def _all_known(v) -> bool:
        if isinstance(v, Known):
            return True
        return isinstance(v, Tup) and all(isinstance(x, Known) for x in v.items)

    @staticmethod
    def _return_type(vals, cname):
        if all(isinstance(v, Known) and v.value is None for v in vals):
            return None
        if any(isinstance(v, Tup) for v in vals):
            n = {len(v.items) for v in vals if isinstance(v, Tup)}
            if len(n) != 1 or not all(isinstance(v, Tup) for v in vals):
                raise ManipcadError(f"{cname}: returns tuples of different sizes")
            return "struct"
        if not all(isinstance(v, Known | Dyn) and not (isinstance(v, Known) and v.value is None)
                   for v in vals):
            raise ManipcadError(f"{cname}: returns values of different kinds")
        return _unify([ctype(v) for v in vals])

    def call(self, ctx: _Ctx, fn, args, node):
        """A call of a numba kernel from translated code: folded, or a C call."""
        try:
            cname, ret, idx = self.function(fn, args)
        except ManipcadError:
            raise
        if cname is None:
            return ret
        spec = self._specs[(fn.py_func, tuple(self._key(a) for a in args))]
        cargs = []
        decls = dict(spec.params)
        for i in idx:
            a = args[i]
            if isinstance(a, Arr):
                if not decls[i].startswith("const"):
                    a.written[0] = True
                off = a.offset if isinstance(a.offset, Dyn) else Known(a.offset)
                if isinstance(off, Known) and off.value == 0:
                    cargs.append(a.name)
                else:
                    cargs.append(f"({a.name} + {code(off)})")
            else:
                cargs.append(code(a))
        call = f"{cname}({', '.join(cargs)})"
        if ret is None:
            ctx.emit(call + ";")
            return Known(None)
        var = ctx.tmp("r")
        if ret == "struct":
            ctx.emit(f"{cname}_ret {var} = {call};")
            return Tup(tuple(Dyn(f"{var}.r{k}", t) for k, t in enumerate(spec.fields)))
        ctx.emit(f"{ret} {var} = {call};")
        return Dyn(var, ret)

    def source(self) -> str:
        """The emitted functions (after :data:`PREAMBLE`), in definition order."""
        return "\n\n".join(self._funcs) + "\n"


_DECL = re.compile(r"^\s*(?:double|long|int) ([A-Za-z_]\w*) = (.*);$")
_CALL = re.compile(r"\b([A-Za-z_]\w*)\(")
_PURE = {"mc_fabs", "mc_fmin", "mc_fmax", "mc_lmin", "mc_lmax", "mc_labs", "sqrt", "sin", "cos"}


def _drop_unused(lines: list[str]) -> list[str]:
    """Drop declarations of C variables never read whose value has no side effect."""
    lines = list(lines)
    while True:
        text = "\n".join(lines)
        for k, ln in enumerate(lines):
            m = _DECL.match(ln)
            if (m and set(_CALL.findall(m.group(2))) <= _PURE
                    and len(re.findall(rf"\b{m.group(1)}\b", text)) == 1):
                del lines[k]
                break
        else:
            return lines
