"""The generated kernels' straight-line statements lowered to LLVM IR in one step.

numba compiles a function by interpreting its bytecode, typing every operation (each
``a*b`` searches the templates of ``operator.mul``) and lowering each one: about 2–4 ms
of CPU per arithmetic operation, 2–5 s for one kernel of a 6–9 joint arm. The generated
kernels are straight-line float64 code whose types are known in advance, so
:func:`lowered` turns the plain Python function holding a kernel's statements into a
numba intrinsic: the jitted kernel calls it once (one typing step), and its code
generation walks the function's syntax tree and emits each operation with numba's own
implementation of that operation on float64 (``context.get_function``), in the order
Python evaluates the expression. The machine code is the one numba would make of the same
text (no fast-math, no contraction; the results are bit for bit the same), compiled in
a fraction of the time.

The statements accepted are those :mod:`manipcad.codegen.emit` prints: assignments to a
name or an array element, ``+=`` and ``-=``, ``if``/``elif``/``else`` on a comparison,
``not``, or a boolean argument, and ``return`` of an integer (a name or a constant);
expressions of ``+ - * /``, unary minus, float constants, names, array elements with
integer indices (constants, names, ``+`` and ``*`` of them) and ``math.sqrt``.
"""

from __future__ import annotations

import ast
import inspect
import math
import operator
import textwrap

from numba.core import cgutils, types
from numba.core.extending import intrinsic
from numba.core.typing import signature

from manipcad.errors import ManipcadError

_F = types.float64
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv}
_COMPARE = {ast.Gt: operator.gt, ast.Lt: operator.lt, ast.GtE: operator.ge,
            ast.LtE: operator.le}


def _statements(fn) -> tuple[list[str], list]:
    """(parameter names, statement nodes) of a plain function's source."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    node = tree.body[0]
    if not isinstance(node, ast.FunctionDef):
        raise ManipcadError(f"{fn!r}: not a function")
    body = node.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
        body = body[1:]  # the docstring
    return [a.arg for a in node.args.args], body


class _Emitter:
    """Emits one statement list into a builder (see :func:`lowered`)."""

    def __init__(self, context, builder, names, argtypes, args) -> None:
        self.context, self.builder = context, builder
        self.impl: dict = {}
        self.arrays: dict = {}
        self.env: dict = {}
        for name, ty, value in zip(names, argtypes, args, strict=True):
            if isinstance(ty, types.Array):
                self.arrays[name] = (ty, context.make_array(ty)(context, builder, value))
            else:
                self.env[name] = value
        i64 = types.int64
        self.result = cgutils.alloca_once_value(builder, context.get_constant(i64, -1))
        self.exit = builder.append_basic_block("statements_end")
        self.ff = signature(_F, _F, _F)

    def function(self, op, sig):
        key = (op, sig)
        f = self.impl.get(key)
        if f is None:
            f = self.impl[key] = self.context.get_function(op, sig)
        return f

    def pointer(self, node):
        ty, ary = self.arrays[node.value.id]
        idx = node.slice
        indices = [self.integer(e) for e in (idx.elts if isinstance(idx, ast.Tuple) else [idx])]
        return cgutils.get_item_pointer(self.context, self.builder, ty, ary, indices,
                                        wraparound=False)

    def integer(self, e):
        b = self.builder
        if isinstance(e, ast.Constant) and type(e.value) is int:
            return self.context.get_constant(types.intp, e.value)
        if isinstance(e, ast.UnaryOp) and isinstance(e.op, ast.USub):
            return b.neg(self.integer(e.operand))
        if isinstance(e, ast.Name):
            return self.env[e.id]
        if isinstance(e, ast.BinOp) and type(e.op) in (ast.Add, ast.Mult):
            a, c = self.integer(e.left), self.integer(e.right)
            return b.add(a, c) if isinstance(e.op, ast.Add) else b.mul(a, c)
        raise ManipcadError(f"generated code: unsupported index {ast.unparse(e)!r}")

    def value(self, e):
        if isinstance(e, ast.Name):
            return self.env[e.id]
        if isinstance(e, ast.Constant) and type(e.value) in (float, int):
            return self.context.get_constant(_F, float(e.value))
        if isinstance(e, ast.BinOp) and type(e.op) in _BINARY:
            a, c = self.value(e.left), self.value(e.right)
            return self.function(_BINARY[type(e.op)], self.ff)(self.builder, (a, c))
        if isinstance(e, ast.UnaryOp) and isinstance(e.op, ast.USub):
            return self.function(operator.neg, signature(_F, _F))(
                self.builder, (self.value(e.operand),))
        if isinstance(e, ast.UnaryOp) and isinstance(e.op, ast.Not):
            return self.builder.not_(self.value(e.operand))
        if isinstance(e, ast.Compare) and len(e.ops) == 1 and type(e.ops[0]) in _COMPARE:
            return self.function(_COMPARE[type(e.ops[0])], signature(types.boolean, _F, _F))(
                self.builder, (self.value(e.left), self.value(e.comparators[0])))
        if isinstance(e, ast.Call) and ast.unparse(e.func) == "math.sqrt" and len(e.args) == 1:
            return self.function(math.sqrt, signature(_F, _F))(
                self.builder, (self.value(e.args[0]),))
        if isinstance(e, ast.Subscript):
            return self.builder.load(self.pointer(e))
        raise ManipcadError(f"generated code: unsupported expression {ast.unparse(e)!r}")

    def run(self, stmts) -> bool:
        """Emit ``stmts``; True when they end in a return (the block is closed)."""
        b = self.builder
        for s in stmts:
            if isinstance(s, ast.Assign) and len(s.targets) == 1:
                v = self.value(s.value)
                t = s.targets[0]
                if isinstance(t, ast.Name):
                    self.env[t.id] = v
                else:
                    b.store(v, self.pointer(t))
            elif isinstance(s, ast.AugAssign) and type(s.op) in (ast.Add, ast.Sub):
                v = self.value(s.value)
                op = self.function(_BINARY[type(s.op)], self.ff)
                t = s.target
                if isinstance(t, ast.Name):
                    self.env[t.id] = op(b, (self.env[t.id], v))
                else:
                    p = self.pointer(t)
                    b.store(op(b, (b.load(p), v)), p)
            elif isinstance(s, ast.Return) and s.value is not None:
                b.store(self.integer(s.value), self.result)
                b.branch(self.exit)
                return True
            elif isinstance(s, ast.If):
                self.branch(s)
            else:
                raise ManipcadError(f"generated code: unsupported statement {ast.unparse(s)!r}")
        return False

    def branch(self, s) -> None:
        """``if``/``else``: the names either arm assigns meet in phi nodes."""
        b = self.builder
        cond = self.value(s.test)
        before = dict(self.env)
        then_bb, else_bb, join = (b.append_basic_block() for _ in range(3))
        b.cbranch(cond, then_bb, else_bb)
        arms = []
        for block, stmts in ((then_bb, s.body), (else_bb, s.orelse)):
            b.position_at_end(block)
            self.env = dict(before)
            returned = self.run(stmts)
            if not returned:
                b.branch(join)
            arms.append((None if returned else self.env, b.block))
        b.position_at_end(join)
        (env_a, end_a), (env_b, end_b) = arms
        if env_a is None and env_b is None:  # both arms return: nothing follows
            b.unreachable()
            b.position_at_end(b.append_basic_block())
            self.env = before
            return
        if env_a is None or env_b is None:
            self.env = env_b if env_a is None else env_a
            return
        self.env = {}
        for k in env_a.keys() & env_b.keys():
            x, y = env_a[k], env_b[k]
            if x is y:
                self.env[k] = x
                continue
            phi = b.phi(x.type)
            phi.add_incoming(x, end_a)
            phi.add_incoming(y, end_b)
            self.env[k] = phi


def lowered(fn):
    """A numba intrinsic running the statements of the plain function ``fn``.

    Args:
        fn: a Python function whose body holds the statements (see the module
            docstring); its parameters are arrays, booleans or integers.

    Returns:
        An intrinsic taking the same arguments and returning an int64: the value of
        the ``return`` reached, or -1 when the statements run to their end.

    Example:
        >>> import numpy as np, numba as nb
        >>> def _body(x, y):
        ...     t = x[0]*x[1] - x[2]
        ...     if t > 0.0:
        ...         y[0] = math.sqrt(t)
        ...     else:
        ...         return 0
        >>> body = lowered(_body)
        >>> @nb.njit
        ... def kernel(x, y):
        ...     return body(x, y)
        >>> y = np.zeros(1)
        >>> kernel(np.array([2.0, 3.0, 2.0]), y), float(y[0])
        (-1, 2.0)
        >>> kernel(np.array([2.0, 3.0, 9.0]), y)
        0
    """
    parsed: list = []

    def typer(typingctx, *args):
        sig = types.int64(*args)

        def codegen(context, builder, sg, llargs):
            if not parsed:
                parsed.append(_statements(fn))
            names, stmts = parsed[0]
            em = _Emitter(context, builder, names, sg.args, llargs)
            if not em.run(stmts):
                builder.branch(em.exit)
            builder.position_at_end(em.exit)
            return builder.load(em.result)

        return sig, codegen

    names = list(inspect.signature(fn).parameters)
    params = ", ".join(names)
    ns = {"typer": typer}
    exec(f"def {fn.__name__}_lowered(typingctx, {params}):\n"
         f"    return typer(typingctx, {params})\n", ns)
    return intrinsic(ns[f"{fn.__name__}_lowered"])
