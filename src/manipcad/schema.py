"""Shared pieces of manipcad's YAML file schemas (robot, motor, gear, requirement files).

- numbers: a numeric field may be a number or a small arithmetic expression
  over :data:`CONSTANTS` (``-pi/2``, ``3060*gcm2``, ``6500*rpm``), evaluated to
  SI by :func:`evaluate`; :data:`Num`, :data:`OptNum` and :data:`Friction` are
  the pydantic field types that accept them;
- :func:`problem`: a pydantic error of a schema in words (naming the allowed
  keys of an unknown one).

Example:
    >>> evaluate("6500*rpm")  # rad/s
    680.6784082777884
"""

from __future__ import annotations

import ast
import math
import operator
import typing
from collections.abc import Callable, Mapping
from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator

# --------------------------------------------------------------------------- numbers

#: Named constants usable in numeric fields (SI values).
CONSTANTS: dict[str, float] = {
    "pi": math.pi,
    "deg": math.pi / 180.0,  # rad per degree
    "rpm": 2.0 * math.pi / 60.0,  # rad/s per rev/min
    "inch": 0.0254,  # m
    "mm": 1e-3,  # m
    "gcm2": 1e-7,  # kg·m² per g·cm²
}
_BINOPS: dict[type, Callable[[float, float], float]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
    ast.Div: operator.truediv, ast.Pow: operator.pow,
}
_UNARY: dict[type, Callable[[float], float]] = {ast.USub: operator.neg, ast.UAdd: operator.pos}


#: the longest numeric expression a file may hold, characters
MAX_EXPRESSION = 200


def evaluate(text: str) -> float:
    """Evaluate a numeric field written as text: a number or an arithmetic
    expression over numbers and :data:`CONSTANTS` with ``+ - * / **`` and
    parentheses (e.g. ``"-pi/2"``, ``"26.45*inch"``). Raises ValueError."""
    allowed = (f"only numbers, + - * / ** ( ) and the constants "
               f"{', '.join(CONSTANTS)} are allowed")

    def fail(detail: str) -> ValueError:
        shown = text if len(text) <= 60 else f"{text[:40]}...({len(text)} characters)"
        return ValueError(f"expected a number, got {shown!r}: {detail}")

    if len(text) > MAX_EXPRESSION:  # bounds the parser's and ev's recursion and time
        raise fail(f"expression too long ({len(text)} characters; at most {MAX_EXPRESSION})")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise fail(allowed) from None

    def ev(node: ast.AST) -> float:
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id in CONSTANTS:
            return CONSTANTS[node.id]
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](ev(node.operand))
        if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
            left, right = ev(node.left), ev(node.right)
            if isinstance(node.op, ast.Pow) and abs(right) > 64:
                raise fail("exponent too large")
            try:
                return _BINOPS[type(node.op)](left, right)
            except ZeroDivisionError:
                raise fail("division by zero") from None
            except OverflowError:
                raise fail("overflow") from None
        if isinstance(node, ast.Name):
            raise fail(f"unknown name {node.id!r} ({allowed})")
        raise fail(allowed)

    value = ev(tree.body)
    if isinstance(value, complex):  # e.g. (-1)**0.5
        raise fail("not a real number")
    return float(value)


def to_float(v: Any) -> float:
    if isinstance(v, bool) or v is None:
        raise ValueError(f"expected a number, got {v!r}")
    if isinstance(v, int | float):
        try:
            x = float(v)
        except OverflowError:  # an integer of hundreds of digits
            raise ValueError(f"expected a number, got an integer too large for a float "
                             f"({len(str(v))} digits)") from None
    elif isinstance(v, str):
        x = evaluate(v)
    else:
        raise ValueError(f"expected a number, got {type(v).__name__} {v!r}")
    if math.isnan(x):
        raise ValueError("expected a number, got nan")
    return x


def opt_float(v: Any) -> float | None:
    return None if v is None else to_float(v)


def number_or_pair(v: Any, what: str,
                   single: Callable[[float], tuple[float, float]] = lambda x: (x, x),
                   ) -> tuple[float, float] | None:
    """A field given as one number or a pair of numbers, as a pair (None stays None).

    Args:
        v: the field's value.
        what: what the field may be, for the error ("one number or a [positive,
            negative] pair").
        single: the pair one number stands for (default: the number twice).

    Example:
        >>> number_or_pair(2, "a stiffness or a [stiffness, damping] pair", lambda k: (k, 0.0))
        (2.0, 0.0)
    """
    if v is None:
        return None
    if isinstance(v, list | tuple):
        if len(v) != 2:
            raise ValueError(f"expected {what}, got {v!r}")
        return to_float(v[0]), to_float(v[1])
    return single(to_float(v))


def _friction(v: Any) -> tuple[float, float] | None:
    """M_f: one number (both directions) or a [positive, negative] pair, N·m."""
    return number_or_pair(v, "one number or a [positive, negative] pair")


Num = Annotated[float, BeforeValidator(to_float)]
OptNum = Annotated[float | None, BeforeValidator(opt_float)]
Friction = Annotated[tuple[float, float] | None, BeforeValidator(_friction)]

# --------------------------------------------------------------------------- errors in words

def _inner_model(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _inner_model(arg)
        if found is not None:
            return found
    return None


def _model_at(root: type[BaseModel], loc: tuple[Any, ...]) -> type[BaseModel] | None:
    model: type[BaseModel] | None = root
    for part in loc:
        if isinstance(part, int):
            continue
        if model is None or part not in model.model_fields:
            return None
        model = _inner_model(model.model_fields[part].annotation)
    return model


def problem(err: Mapping[str, Any], root: type[BaseModel]) -> str:
    """One pydantic error of a ``root`` schema in words: a missing field, an unknown key
    (with the keys allowed there), a wrong value or type."""
    kind, value = err["type"], err.get("input")
    if kind == "missing":
        return "required field is missing"
    if kind == "extra_forbidden":
        model = _model_at(root, err["loc"][:-1])
        allowed = f"; allowed keys: {', '.join(model.model_fields)}" if model else ""
        return f"unknown key {err['loc'][-1]!r}{allowed}"
    if kind == "literal_error":
        return f"unknown value {value!r}; expected {err['ctx']['expected']}"
    if kind in ("model_type", "dict_type", "model_attributes_type"):
        return f"expected a mapping of keys to values, got {value!r}"
    if kind == "list_type":
        return f"expected a list, got {value!r}"
    if kind == "string_type":
        return f"expected text, got {value!r}"
    if kind == "int_type" or kind.startswith("int_"):
        return f"expected a whole number, got {value!r}"
    msg = str(err["msg"])
    return msg.removeprefix("Value error, ")


__all__ = ["CONSTANTS", "MAX_EXPRESSION", "evaluate", "to_float", "opt_float", "Num", "OptNum",
           "Friction", "problem"]
