"""Shared file helpers: reading YAML, pydantic errors, atomic writes, JSON-safe values.

Every helper reports bad input as :class:`~manipcad.errors.InputError` naming
the file (``source``), the dotted field (``""`` for the whole file) and the
reason, as the rest of manipcad does, so that a loader built on them needs no
error handling of its own for the file itself:

- :func:`read_yaml`: a YAML file's data; no such file, not UTF-8, syntax errors
  (with line and column), duplicate keys and empty files become InputError;
- :func:`validation_error`: a pydantic ``ValidationError`` as an InputError
  naming the first problem's dotted field (``joints[2].link.mass``);
- :func:`atomic_write`, :func:`atomic_write_text`, :func:`atomic_write_bytes`:
  write to a temporary file beside the target and rename it over the target,
  so an interrupted or failed write leaves any earlier file intact;
- :func:`json_safe`: plain JSON values from numpy arrays and scalars, with nan
  as null and ±inf as the strings "inf"/"-inf" (JSON has no nan or infinity).
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable, Collection, Mapping, Sequence
from importlib.abc import Traversable
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np
import yaml

from manipcad.errors import InputError

if TYPE_CHECKING:
    from pydantic import ValidationError

# --------------------------------------------------------------------------- reading


class UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that rejects duplicate mapping keys (PyYAML keeps the last silently)."""


def _construct_mapping(loader: UniqueKeyLoader, node: yaml.MappingNode,
                       deep: bool = False) -> dict[Any, Any]:
    seen: set[Any] = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark)
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG,
                                _construct_mapping)


def read_yaml(path: str | Path | Traversable, what: str | None = None, *,
              label: str | None = None, unique_keys: bool = True) -> Any:
    """Read and parse a YAML file; every failure is an :class:`InputError` naming the file.

    Args:
        path: the file: a path, or an :mod:`importlib.resources` entry (the catalog).
        what: what the file should hold, for the error on an empty file (or one
            holding only ``null``): ``"a mapping with a 'type'"`` gives "empty
            file; expected a mapping with a 'type'". None: such a file gives None.
        label: how errors name the file (default ``str(path)``).
        unique_keys: reject a key given twice in one mapping, at its line
            ("duplicate key 'name'"); False keeps PyYAML's default (the last wins).

    Returns:
        The parsed data (a dict, list, str, number... as written).

    Raises:
        InputError: no such file, not a file, not UTF-8 text, cannot be read,
            "YAML syntax error at line L, column C: <problem>", duplicate key,
            empty file (when ``what`` is given).

    Example:
        >>> data = read_yaml("examples/fig3_laws.yaml", "a mapping with a 'type'")  # doctest: +SKIP
        >>> data["type"]  # doctest: +SKIP
        'cosine'
    """
    name = label or str(path)
    if isinstance(path, str):
        path = Path(path)
    if not path.is_file():
        present = path.exists() if isinstance(path, Path) else path.is_dir()
        raise InputError(name, "", "not a file" if present else "no such file")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(name, "", "no such file") from None
    except UnicodeDecodeError as exc:
        raise InputError(name, "", f"not a UTF-8 text file ({exc.reason})") from None
    except OSError as exc:
        raise InputError(name, "", f"cannot read: {exc.strerror or exc}") from None
    loader = UniqueKeyLoader if unique_keys else yaml.SafeLoader
    try:
        data = yaml.load(text, Loader=loader)  # noqa: S506 (SafeLoader or a subclass)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or getattr(exc, "context", None) or str(exc)
        raise InputError(name, "", f"YAML syntax error{where}: {problem}") from None
    if data is None and what is not None:
        raise InputError(name, "", f"empty file; expected {what}")
    return data


# --------------------------------------------------------------------------- pydantic


def field_path(loc: Sequence[Any], prefix: str = "", skip: Collection[str] = ()) -> str:
    """The dotted path of a pydantic error location, list entries as ``[i]``.

    Args:
        loc: the error's ``loc`` (field names and list indices).
        prefix: the path of the validated data inside the file ("" for all of it).
        skip: location parts to leave out: the branch names pydantic puts in
            the location of an error inside a union, e.g. ``{"str", "int"}`` for
            a ``list[str | int]`` field.

    Example:
        >>> field_path(("joints", 2, "link", "mass"))
        'joints[2].link.mass'
        >>> field_path(("joints", 1, "str"), prefix="regulators[0]", skip={"str", "int"})
        'regulators[0].joints[1]'
    """
    out = prefix
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif part not in skip:
            out += f".{part}" if out else str(part)
    return out


def describe_error(err: Mapping[str, Any]) -> str:
    """One pydantic error (an entry of ``ValidationError.errors()``) in words.

    "required field is missing", "unknown field", or pydantic's message (without
    its "Value error, " prefix) followed by the value given.
    """
    kind = err["type"]
    if kind == "missing":
        return "required field is missing"
    if kind == "extra_forbidden":
        return "unknown field"
    msg = str(err["msg"]).removeprefix("Value error, ")
    return f"{msg} (got {err.get('input')!r})"


def validation_error(source: str, exc: ValidationError,
                     reason: Callable[[Mapping[str, Any]], str] = describe_error, *,
                     prefix: str = "", skip: Collection[str] = ()) -> InputError:
    """A pydantic ``ValidationError`` as an :class:`InputError` naming its first problem.

    Args:
        source: the file (or argument) the data came from.
        exc: the error of ``Model.model_validate(data)``.
        reason: words for the first error (default :func:`describe_error`); a
            loader passes its own to name the allowed fields or the context.
        prefix: dotted path of the validated data inside the file, put before
            the error's own location ("" for the whole file).
        skip: location parts to leave out (union branch names, see :func:`field_path`).

    Returns:
        ``InputError(source, field, reason)``, the field dotted with ``[i]`` for
        list entries (:func:`field_path`); when other fields have problems too
        the reason ends "(and N more problem(s))". Raise it ``from None``.

    Example:
        >>> from pydantic import BaseModel, ValidationError
        >>> class Link(BaseModel):
        ...     mass: float
        >>> try:
        ...     Link.model_validate({})
        ... except ValidationError as exc:
        ...     print(validation_error("arm.yaml", exc, prefix="joints[0].link"))
        arm.yaml: joints[0].link.mass: required field is missing
    """
    errors = exc.errors(include_url=False)
    fields = [field_path(err["loc"], prefix, skip) for err in errors]
    text = reason(errors[0])
    more = len(set(fields)) - 1  # the branches of a union fail at one field: one problem
    if more:
        text += f" (and {more} more problem{'s' if more > 1 else ''})"
    return InputError(source, fields[0], text)


# --------------------------------------------------------------------------- writing


def writable_target(path: str | Path) -> Path:
    """Check that ``path`` may be written as a file: its folder exists and it is no folder.

    Raises:
        InputError: "folder '...' does not exist", or "is a folder".
    """
    p = Path(path)
    if not p.parent.is_dir():
        raise InputError(str(path), "", f"folder {str(p.parent)!r} does not exist")
    if p.is_dir():
        raise InputError(str(path), "", "is a folder")
    return p


def atomic_write(path: str | Path, write: Callable[[IO[Any]], Any], *,
                 binary: bool = False) -> Path:
    """Write a file atomically: to a temporary file beside it, then renamed over it.

    ``write`` gets the open temporary file (text in UTF-8, or binary); its data
    are flushed to disk before the rename. The new file keeps the permissions
    of the file it replaces (0o644 for a new one). If anything fails or the run
    is interrupted, the temporary file is removed and an existing file at
    ``path`` is left as it was.

    Args:
        path: the target file; its folder must exist.
        write: writes the content to the file object it is given.
        binary: open the file in binary mode (default text, UTF-8).

    Returns:
        The path written.

    Raises:
        InputError: the folder does not exist, ``path`` is a folder, or the
            file cannot be written (naming ``path``). Other errors of ``write``
            pass through unchanged.
    """
    src = str(path)
    p = writable_target(path)
    folder = p.parent
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise InputError(src, "", f"cannot write in {str(folder)!r}: {exc.strerror}") from None
    try:
        with (os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8")) as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, p.stat().st_mode & 0o777 if p.exists() else 0o644)
        os.replace(tmp, p)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            raise InputError(src, "", f"cannot write: {exc.strerror or exc}") from None
        raise
    return p


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_write`)."""
    return atomic_write(path, lambda fh: fh.write(text))


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_write`)."""
    return atomic_write(path, lambda fh: fh.write(data), binary=True)


# --------------------------------------------------------------------------- JSON


def json_safe(x: Any) -> Any:
    """Plain JSON values for ``json.dumps`` (with ``allow_nan=False`` if wanted).

    nan becomes None (null) and ±inf the strings "inf"/"-inf"; numpy arrays
    become nested lists and numpy scalars Python numbers (units unchanged);
    tuples become lists, mapping keys text, complex numbers [re, im] and paths
    text. Anything else is returned as it is.

    Example:
        >>> import numpy as np
        >>> json_safe({"peak": np.array([1.5, np.nan, np.inf]), "n": np.int64(3)})
        {'peak': [1.5, None, 'inf'], 'n': 3}
    """
    if isinstance(x, Mapping):
        return {k if isinstance(k, str) else str(k): json_safe(v) for k, v in x.items()}
    if isinstance(x, np.ndarray):
        x = x.tolist()
    if isinstance(x, list | tuple):
        return [json_safe(v) for v in x]
    if isinstance(x, bool | np.bool_):
        return bool(x)
    if isinstance(x, int | np.integer):
        return int(x)
    if isinstance(x, float | np.floating):
        x = float(x)
        if math.isnan(x):
            return None
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return x
    if isinstance(x, complex | np.complexfloating):
        return [json_safe(x.real), json_safe(x.imag)]
    if isinstance(x, Path):
        return str(x)
    return x


__all__ = [
    "read_yaml", "UniqueKeyLoader", "field_path", "describe_error", "validation_error",
    "writable_target", "atomic_write", "atomic_write_text", "atomic_write_bytes", "json_safe",
]
