"""From symbolic outputs to straight-line code: cse, printing (Python/numba and C99), counting.

The code of one function is a list of statements (:class:`Let`, :class:`Store`,
:class:`AddTo`, :class:`Friction`, :class:`Check`, :class:`IfDrives`) printed
for either language by :func:`lines`. Expressions are printed without ever
expanding them: a negative term of a sum becomes a subtraction, a product by
-1 a negation folded into the sum around it, ``x**2`` a product, ``x**-1`` a
division and ``x**(1/2)`` ``sqrt``. The ``t = -x`` statements that cse leaves
are folded into their uses (so are copies ``t = x``).

Operation counts are read from the printed Python source (:func:`count_ops`):
every ``*`` and ``/`` is a multiplication, every ``+`` and ``-`` between two
operands (and ``+=``, ``-=``) an addition, calls of ``sin``/``cos`` are the
trigonometric calls and ``sqrt`` is counted apart; unary minus is free (it
folds into the neighbouring operation in the compiled code).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field

import symengine as se

from manipcad.errors import ManipcadError


# ------------------------------------------------------------------ statements
@dataclass
class Let:
    """A local ``name = expr`` (``mutable``: C declares it without ``const``)."""

    name: str
    expr: object
    mutable: bool = False


@dataclass
class Store:
    """``target = expr``; target is (array, index...) naming an output element."""

    target: tuple
    expr: object


@dataclass
class AddTo:
    """``target += expr``; target is (array, index...) or a local's name."""

    target: tuple | str
    expr: object


@dataclass
class Friction:
    """Dry friction |i_r|·M_f·sign(q̇) added to ``target`` (N·m or N)."""

    target: tuple | str
    qd: str
    pos: float
    neg: float


@dataclass
class Check:
    """Stop with the failure value unless ``name`` (a pivot of the factorization) is > 0."""

    name: str
    joint: int


@dataclass
class IfDrives:
    """Statements run only with the drive terms (a ``drives`` flag of the function)."""

    body: list = field(default_factory=list)


# ------------------------------------------------------------------ cse
def cse(exprs: list) -> tuple[list, list]:
    """Common subexpressions of a list of expressions: (lets, reduced expressions).

    ``t = -x`` and ``t = x`` (x a symbol or a number) are folded into their uses.
    """
    reps, red = se.cse(exprs)
    fold: dict = {}
    lets = []
    for sym, e in reps:
        if fold:
            e = e.xreplace(fold)
        if _is_atomic(e) or (isinstance(e, se.Mul) and len(e.args) == 2
                             and e.args[0] == -1 and _is_atomic(e.args[1])):
            fold[sym] = e
            continue
        lets.append(Let(str(sym), e))
    if fold:
        red = [e.xreplace(fold) for e in red]
    return lets, list(red)


def _is_atomic(e) -> bool:
    return isinstance(e, se.Symbol) or e.is_Number


# ------------------------------------------------------------------ printing
def _num(v: float) -> str:
    s = repr(float(v))
    if s in ("inf", "-inf", "nan"):
        raise ManipcadError(f"a model constant is not finite ({s}): cannot generate code")
    return s


def _sign_split(e):
    """(negative, magnitude) of a term of a sum."""
    if e.is_Number:
        v = float(e)
        return v < 0, (se.RealDouble(-v) if v < 0 else e)
    if isinstance(e, se.Mul):
        c = e.args[0]
        if c.is_Number and float(c) < 0:
            return True, se.Mul(*((-c,) + tuple(e.args[1:]))) if float(c) != -1 \
                else se.Mul(*e.args[1:])
    return False, e


def expr_str(e, lang: str) -> str:
    """``e`` printed for ``lang`` ("python" or "c"), never expanded."""
    sqrt = "math.sqrt" if lang == "python" else "sqrt"

    def atom(x) -> str:
        s = p(x)
        return s if isinstance(x, se.Symbol) or (x.is_Number and float(x) >= 0) \
            or isinstance(x, se.Pow) and _pow_is_call(x) else f"({s})"

    def power(b, k: int) -> str:
        return "*".join([atom(b)] * k)

    def p(x) -> str:
        if isinstance(x, se.Symbol):
            return str(x)
        if x.is_Number:
            return _num(float(x))
        if isinstance(x, se.Add):
            parts = []
            for i, t in enumerate(x.args):
                neg, mag = _sign_split(t)
                s = p(mag)
                if i == 0:
                    parts.append(f"-{s}" if neg and not isinstance(mag, se.Add) else
                                 f"-({s})" if neg else s)
                else:
                    parts.append((" - " if neg else " + ") + (f"({s})" if neg and isinstance(
                        mag, se.Add) else s))
            return "".join(parts)
        if isinstance(x, se.Mul):
            neg, mag = _sign_split(x)
            if neg:
                return f"-{atom(mag)}" if not isinstance(mag, se.Mul) else f"-{p(mag)}"
            num_, den = [], []
            for a in x.args:
                if isinstance(a, se.Pow) and a.args[1].is_Number and float(a.args[1]) < 0:
                    den.append(se.Pow(a.args[0], -a.args[1]))
                else:
                    num_.append(a)
            top = "*".join(atom(a) for a in num_) if num_ else "1.0"
            for d in den:
                top += f"/{atom(d)}"
            return top
        if isinstance(x, se.Pow):
            b, k = x.args
            kv = float(k)
            if kv == 0.5:
                return f"{sqrt}({p(b)})"
            if kv == -0.5:
                return f"1.0/{sqrt}({p(b)})"
            if kv == int(kv) and kv >= 1:
                return power(b, int(kv))
            if kv == int(kv) and kv <= -1:
                return "1.0/" + (atom(b) if kv == -1 else f"({power(b, int(-kv))})")
            raise ManipcadError(f"cannot print the power {x}")
        raise ManipcadError(f"cannot print {type(x).__name__} {x}")

    return p(e)


def _pow_is_call(x) -> bool:
    return abs(float(x.args[1])) == 0.5 and float(x.args[1]) > 0


def _target(t, lang: str, fmt: dict) -> str:
    if isinstance(t, str):
        return t
    return fmt[t[0]](*t[1:])


def lines(stmts: list, lang: str, fmt: dict, indent: str, fail: str,
          drives_flag: bool = True) -> list[str]:
    """Source lines of ``stmts`` for ``lang``.

    Args:
        stmts: statements.
        lang: "python" or "c".
        fmt: array name -> function of the indices giving the element's text.
        indent: the indentation of the block.
        fail: the value a failed :class:`Check` returns (text).
        drives_flag: :class:`IfDrives` tests a ``drives`` argument; False: always run.
    """
    out = []
    end = ";" if lang == "c" else ""
    for s in stmts:
        if isinstance(s, Let):
            decl = "" if lang == "python" else ("double " if s.mutable else "const double ")
            out.append(f"{indent}{decl}{s.name} = {expr_str(s.expr, lang)}{end}")
        elif isinstance(s, Store):
            out.append(f"{indent}{_target(s.target, lang, fmt)} = {expr_str(s.expr, lang)}{end}")
        elif isinstance(s, AddTo):
            neg, mag = _sign_split(s.expr)
            op = "-=" if neg else "+="
            out.append(f"{indent}{_target(s.target, lang, fmt)} {op} {expr_str(mag, lang)}{end}")
        elif isinstance(s, Friction):
            t = _target(s.target, lang, fmt)
            if lang == "python":
                if s.pos:
                    out.append(f"{indent}if {s.qd} > 0.0:")
                    out.append(f"{indent}    {t} += {_num(s.pos)}")
                if s.neg:
                    out.append(f"{indent}{'elif' if s.pos else 'if'} {s.qd} < 0.0:")
                    out.append(f"{indent}    {t} -= {_num(s.neg)}")
            else:
                if s.pos:
                    out.append(f"{indent}if ({s.qd} > 0.0) {t} += {_num(s.pos)};")
                if s.neg:
                    out.append(f"{indent}{'else ' if s.pos else ''}if ({s.qd} < 0.0) "
                               f"{t} -= {_num(s.neg)};")
        elif isinstance(s, Check):
            if lang == "python":
                out.append(f"{indent}if not {s.name} > 0.0:")
                out.append(f"{indent}    return {fail.format(j=s.joint)}")
            else:
                out.append(f"{indent}if (!({s.name} > 0.0)) return {fail.format(j=s.joint)};")
        elif isinstance(s, IfDrives):
            if not s.body:
                continue
            if drives_flag and lang == "python":
                out.append(f"{indent}if drives:")
                out += lines(s.body, lang, fmt, indent + "    ", fail, drives_flag)
            elif drives_flag:
                out.append(f"{indent}if (drives) {{")
                out += lines(s.body, lang, fmt, indent + "    ", fail, drives_flag)
                out.append(f"{indent}}}")
            else:
                out += lines(s.body, lang, fmt, indent, fail, drives_flag)
        else:  # pragma: no cover - a programming error
            raise TypeError(s)
    return out


# ------------------------------------------------------------------ counting
def count_ops(source: str, function: str) -> dict[str, int]:
    """Operations in one function of generated Python source.

    Args:
        source: the module's source text.
        function: the function's name.

    Returns:
        ``{"mul": ..., "add": ..., "trig": ..., "sqrt": ...}`` (divisions count as
        multiplications, subtractions as additions; unary minus is not counted;
        ``s, c = sincos(x)`` counts as the trigonometric values it gives, ``_`` not, and
        so does each read ``s0 = TS[p]`` / ``c0 = TC[p]`` of the single-state kernels'
        vectorized angle block (the unused entries of the block are not counted). A
        function's count includes the statements it runs as an intrinsic made by
        ``X = lowered(_f)`` (:mod:`manipcad.codegen.lower`): those of ``_f``.

    Example:
        >>> count_ops("def f(a, b):\\n    return a*b - a/b + math.sin(a)\\n", "f")
        {'mul': 2, 'add': 2, 'trig': 1, 'sqrt': 0}
    """
    tree = ast.parse(source)
    funcs = {f.name: f for f in ast.walk(tree) if isinstance(f, ast.FunctionDef)}
    fn = funcs.get(function)
    if fn is None:
        raise ManipcadError(f"no function {function!r} in the generated source")
    c = _count(fn.body)
    # the statements it runs through an intrinsic made by ``X = lowered(_f)``
    # (manipcad.codegen.lower): counted as its own
    made = {a.targets[0].id: a.value.args[0].id for a in tree.body
            if isinstance(a, ast.Assign) and isinstance(a.value, ast.Call)
            and isinstance(a.value.func, ast.Name) and a.value.func.id == "lowered"}
    for node in ast.walk(fn):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                and node.func.id in made:
            for k, v in _count(funcs[made[node.func.id]].body).items():
                c[k] += v
    return c


def _count(nodes) -> dict[str, int]:
    """Operations on the longest path through ``nodes``: a branch counts its larger arm."""
    c = {"mul": 0, "add": 0, "trig": 0, "sqrt": 0}

    def merge(d):
        for k in c:
            c[k] += d[k]

    for node in nodes if isinstance(nodes, list) else [nodes]:
        if isinstance(node, ast.If):
            merge(_count(node.test))
            a, b = _count(node.body), _count(node.orelse)
            merge(a if (a["mul"] + a["add"], a["mul"]) >= (b["mul"] + b["add"], b["mul"]) else b)
            continue
        if isinstance(node, (ast.BinOp, ast.AugAssign)):
            if isinstance(node.op, (ast.Mult, ast.Div)):
                c["mul"] += 1
            elif isinstance(node.op, (ast.Add, ast.Sub)):
                c["add"] += 1
        elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Call) \
                and isinstance(node.value.func, ast.Name) and node.value.func.id == "sincos":
            # s, c = sincos(x): counted as the sin and the cos it gives that are used
            c["trig"] += sum(1 for t in node.targets[0].elts if t.id != "_")
            merge(_count(node.value.args))
            continue
        elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Subscript) \
                and isinstance(node.value.value, ast.Name) and node.value.value.id in ("TS",
                                                                                    "TC"):
            # s0 = TS[p]: a sine (cosine) of the single-state kernels' angle block
            c["trig"] += 1
            continue
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            if node.func.attr in ("sin", "cos"):
                c["trig"] += 1
            elif node.func.attr == "sqrt":
                c["sqrt"] += 1
        merge(_count(list(ast.iter_child_nodes(node))))
    return c
