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
import re
import stat
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

#: Limits of every YAML file manipcad reads (robot, motor, gear, trajectory,
#: regulator, requirement files): larger or deeper files are refused with an
#: :class:`InputError` before they can take unbounded memory or time.
MAX_FILE_BYTES = 16 * 2**20
#: nodes (scalars, lists, mappings) of the data, counted with every alias expanded
MAX_NODES = 200_000
#: nesting depth of lists and mappings, counted with every alias expanded
MAX_DEPTH = 100

# One float rule for every file: YAML 1.1 floats (PyYAML's rule, which needs a
# dot and a signed exponent) plus YAML 1.2's "1e-1", "1e5", "1.0e12", "-.5".
_FLOAT = re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+
    |[-+]?\.[0-9][0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.VERBOSE)
_FLOAT_TAG = "tag:yaml.org,2002:float"
# integers: decimal, 0x hex, 0b binary; not YAML 1.1's base 60 ("1:30" was 90) nor its
# octal ("010" was 8): such text stays text, which a number field refuses by name
_INT = re.compile(r"""^(?:[-+]?0b[0-1_]+
    |[-+]?(?:0|[1-9][0-9_]*)
    |[-+]?0x[0-9a-fA-F_]+)$""", re.VERBOSE)
_INT_TAG = "tag:yaml.org,2002:int"


class _Refused(yaml.MarkedYAMLError):
    """A YAML file refused for its content (duplicate key, size limits, aliases)."""


class _Constructor(yaml.constructor.SafeConstructor):
    """SafeConstructor (no Python objects) that refuses a key given twice in one mapping."""

    def construct_mapping(self, node: Any, deep: bool = False) -> dict[Any, Any]:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    dup = key in seen
                    seen.add(key)
                except TypeError:
                    raise _Refused("while reading a mapping", node.start_mark,
                                   f"a key must be text or a number, got {type(key).__name__}",
                                   key_node.start_mark) from None
                if dup:
                    raise _Refused(None, None, f"duplicate key {key!r}", key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


class _Resolver(yaml.resolver.Resolver):
    """PyYAML's resolver with the one float rule (:data:`_FLOAT`) and integers without
    YAML 1.1's base-60 and octal forms (:data:`_INT`)."""

    yaml_implicit_resolvers = {
        first: [(_FLOAT_TAG, _FLOAT) if tag == _FLOAT_TAG else (_INT_TAG, _INT)
                if tag == _INT_TAG else (tag, rx) for tag, rx in rules]
        for first, rules in yaml.resolver.Resolver.yaml_implicit_resolvers.items()}
    for _first in "0123456789-+.":
        _rules = yaml_implicit_resolvers.setdefault(_first, [])
        if not any(tag == _FLOAT_TAG for tag, _ in _rules):
            _rules.insert(0, (_FLOAT_TAG, _FLOAT))
    del _first, _rules


if getattr(yaml, "__with_libyaml__", False):
    class SafeYamlLoader(yaml.cyaml.CParser, _Constructor, _Resolver):
        """The one YAML loader of manipcad (libyaml's parser; see :func:`parse_yaml`)."""

        def __init__(self, stream: Any) -> None:
            yaml.cyaml.CParser.__init__(self, stream)
            _Constructor.__init__(self)
            _Resolver.__init__(self)
else:  # pragma: no cover - PyYAML built without libyaml
    class SafeYamlLoader(yaml.reader.Reader, yaml.scanner.Scanner,  # type: ignore[no-redef]
                         yaml.parser.Parser, yaml.composer.Composer, _Constructor, _Resolver):
        """The one YAML loader of manipcad (pure Python; see :func:`parse_yaml`)."""

        def __init__(self, stream: Any) -> None:
            yaml.reader.Reader.__init__(self, stream)
            yaml.scanner.Scanner.__init__(self)
            yaml.parser.Parser.__init__(self)
            yaml.composer.Composer.__init__(self)
            _Constructor.__init__(self)
            _Resolver.__init__(self)


def _prescan(text: str) -> None:
    """Refuse text of more than MAX_NODES values or nested deeper than MAX_DEPTH, as
    written (before composing, whose recursion follows the nesting)."""
    loader = SafeYamlLoader(text)
    try:
        depth = count = 0
        while loader.check_event():
            event = loader.get_event()
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > MAX_DEPTH:
                    raise _Refused(None, None, f"nested deeper than {MAX_DEPTH} levels",
                                   event.start_mark)
            elif not isinstance(event, yaml.NodeEvent):
                depth -= isinstance(event, yaml.CollectionEndEvent)
                continue
            count += 1
            if count > MAX_NODES:
                raise _Refused(None, None, f"more than {MAX_NODES:,} values",
                               event.start_mark)
    finally:
        loader.dispose()


def _measure(root: yaml.Node) -> None:
    """Refuse a node graph that expands (aliases followed) to more than MAX_NODES
    nodes or MAX_DEPTH levels, or in which an alias refers to a node containing it.
    Linear in the graph's size: each node is measured once."""
    memo: dict[int, tuple[int, int]] = {}  # id -> (expanded nodes, nested collections)
    active: set[int] = set()

    def walk(node: yaml.Node, above: int) -> tuple[int, int]:
        key = id(node)
        if key in active:
            raise _Refused(None, None, "an alias refers to the node that contains it "
                           "(recursive data)", node.start_mark)
        if key not in memo:
            active.add(key)
            if isinstance(node, yaml.SequenceNode):
                kids = node.value
            elif isinstance(node, yaml.MappingNode):
                kids = [k for pair in node.value for k in pair]
            else:
                kids = []
            count, height = 1, int(not isinstance(node, yaml.ScalarNode))
            for kid in kids:
                c, h = walk(kid, above + 1)
                count, height = count + c, max(height, h + 1)
                if count > MAX_NODES:
                    raise _Refused(None, None, f"more than {MAX_NODES:,} values once "
                                   "aliases are expanded", node.start_mark)
            active.discard(key)
            memo[key] = count, height
        count, height = memo[key]
        if above + height > MAX_DEPTH:
            raise _Refused(None, None, f"nested deeper than {MAX_DEPTH} levels once aliases "
                           "are expanded", node.start_mark)
        return count, height

    walk(root, 0)


class _Dumper(yaml.SafeDumper):
    """SafeDumper that quotes every text :class:`SafeYamlLoader` or YAML 1.1 (PyYAML's
    own loader) would read as something else: ``1e0``, ``1e3`` (floats here), ``1:30``
    (90 in YAML 1.1), ``010``."""

    yaml_implicit_resolvers = {
        first: list(_Resolver.yaml_implicit_resolvers.get(first, []))
        + list(yaml.resolver.Resolver.yaml_implicit_resolvers.get(first, []))
        for first in set(_Resolver.yaml_implicit_resolvers)
        | set(yaml.resolver.Resolver.yaml_implicit_resolvers)}


def dump_yaml(data: Any, **kwargs: Any) -> str:
    """YAML text of plain data (``yaml.safe_dump``'s options) that reads back the same
    with :func:`parse_yaml`: text that looks like a number (a joint named ``1e0``) is
    quoted.

    Example:
        >>> print(dump_yaml({"joints": ["1e0", "1:30", "elbow"], "ratio": 30.0}), end="")
        joints:
        - '1e0'
        - '1:30'
        - elbow
        ratio: 30.0
    """
    return yaml.dump(data, Dumper=_Dumper, **kwargs)


#: the name older callers use for :class:`SafeYamlLoader`
UniqueKeyLoader = SafeYamlLoader


def check_readable(path: str | Path | Traversable, name: str | None = None) -> None:
    """Check that ``path`` names a regular file that may be read, else say what it is.

    Args:
        path: a path, or an :mod:`importlib.resources` entry (the catalog).
        name: how errors name the file (default ``str(path)``).

    Raises:
        InputError: "empty file name", "no such file", "is a directory, not a file",
            "is a FIFO (named pipe), not a file", "is a socket / device, not a file",
            "cannot read: <reason>" (e.g. permission denied), or
            "is N bytes, more than the limit of M bytes".

    Example:
        >>> check_readable("/")
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: /: is a directory, not a file
    """
    label = str(path) if name is None else name
    if isinstance(path, str) and not path.strip():
        raise InputError(repr(path), "", "empty file name")
    if not isinstance(path, str | Path):  # a resource entry
        if not path.is_file():
            raise InputError(label, "", "is a directory, not a file" if path.is_dir()
                             else "no such file")
        return
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError(label, "", "no such file") from None
    except NotADirectoryError:
        raise InputError(label, "", "no such file (a part of the path is not a folder)") from None
    except OSError as exc:
        raise InputError(label, "", f"cannot read: {exc.strerror or exc}") from None
    mode = st.st_mode
    for test, what in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device")):
        if test(mode):
            raise InputError(label, "", f"is {what}, not a file")
    if st.st_size > MAX_FILE_BYTES:
        raise InputError(label, "", f"is {st.st_size:,} bytes, more than the limit of "
                         f"{MAX_FILE_BYTES:,} bytes")


def read_bytes(path: str | Path | Traversable, name: str | None = None) -> bytes:
    """The bytes of a file; every failure is an :class:`InputError` naming it.

    Checks the file first (:func:`check_readable`: not a directory, FIFO or
    device, which would block or fail, and at most :data:`MAX_FILE_BYTES`).

    Raises:
        InputError: as :func:`check_readable`, or "cannot read: <reason>".
    """
    label = str(path) if name is None else name
    check_readable(path, label)
    if isinstance(path, str):
        path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise InputError(label, "", "no such file") from None
    except OSError as exc:
        raise InputError(label, "", f"cannot read: {exc.strerror or exc}") from None
    if len(data) > MAX_FILE_BYTES:  # grew since the check
        raise InputError(label, "", f"more than the limit of {MAX_FILE_BYTES:,} bytes")
    return data


class _XmlStop(Exception):
    """Ends :func:`scan_xml` at the root element."""


def scan_xml(text: str | bytes, source: str,
             element: Callable[[str, dict[str, str]], None] | None = None) -> None:
    """Check XML text before a parser that expands entities (ElementTree) reads it.

    Any entity declaration (internal, external, parameter or unparsed) is refused, so
    no entity is ever expanded: not the 'billion laughs' bomb (which expat would expand
    up to its amplification limit), not a file named by an external entity.
    ``element(tag, attributes)`` is called for every element in document order (it may
    raise :class:`InputError`); without it the scan ends at the root element (the
    prolog, where entities are declared, is all it reads).

    Raises:
        InputError: an entity declaration (naming it), malformed XML (line and column),
            or what ``element`` raises; naming ``source``.

    Example:
        >>> scan_xml('<!DOCTYPE r [<!ENTITY a "b">]><r>&a;</r>', "f.urdf")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: f.urdf: declares the XML entity 'a': entity ...
    """
    from xml.parsers import expat  # deferred: start-up cost: xml loaded on first use

    parser = expat.ParserCreate()

    def declared(name: str, *_: Any) -> None:
        raise InputError(source, "", f"declares the XML entity {name!r}: entity declarations "
                         "are refused (no entity is expanded)")

    def start(tag: str, attrs: dict[str, str]) -> None:
        if element is None:
            raise _XmlStop
        element(tag, attrs)

    parser.EntityDeclHandler = declared
    parser.UnparsedEntityDeclHandler = declared
    parser.StartElementHandler = start
    try:
        parser.Parse(text, True)
    except _XmlStop:
        pass
    except expat.ExpatError as exc:
        raise InputError(source, "", f"malformed XML: {exc}") from None


def read_text(path: str | Path | Traversable, name: str | None = None, *,
              encoding: str = "utf-8") -> str:
    """The text of a file (UTF-8; ``"utf-8-sig"`` drops a byte-order mark), read by
    :func:`read_bytes`; every failure is an :class:`InputError` naming the file.

    Raises:
        InputError: as :func:`read_bytes`, or "not a UTF-8 text file (<reason> at byte N)".
    """
    label = str(path) if name is None else name
    data = read_bytes(path, label)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise InputError(label, "", f"not a UTF-8 text file ({exc.reason} at byte "
                         f"{exc.start})") from None


def parse_yaml(text: str, name: str, what: str | None = None) -> Any:
    """Parse YAML text with :class:`SafeYamlLoader`; every failure is an :class:`InputError`.

    Args:
        text: the YAML text.
        name: how errors name its source (a file path, or e.g. ``"<string>"``).
        what: what the data should be, for the error on empty data (see :func:`read_yaml`).

    Returns:
        The parsed data (dict, list, str, int, float, bool, None...).

    Raises:
        InputError: "YAML syntax error at line L, column C: <problem>", or
            "refused at line L, column C: <reason>" for a duplicate key, data
            too large or too deep, a recursive alias; "bad value at line L...:
            <reason>" for a value YAML cannot build (a date like 2020-02-30, an
            integer of more than 4300 digits); "empty file; expected <what>".

    Example:
        >>> parse_yaml("dt: 1e-4\\ngains: [1.0e3, .5]", "<string>")
        {'dt': 0.0001, 'gains': [1000.0, 0.5]}
        >>> parse_yaml("a: 1\\na: 2", "<string>")
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: <string>: refused at line 2, column 1: duplicate key 'a'
    """
    if len(text) > MAX_FILE_BYTES:
        raise InputError(name, "", f"more than the limit of {MAX_FILE_BYTES:,} characters")
    try:
        _prescan(text)
        loader = SafeYamlLoader(text)
        try:
            node = loader.get_single_node()
            if node is not None:
                _measure(node)
            data = None if node is None else loader.construct_document(node)
        finally:
            loader.dispose()
    except _Refused as exc:
        raise InputError(name, "", f"refused{_where(exc)}: {exc.problem}") from None
    except yaml.reader.ReaderError as exc:
        raise InputError(name, "", f"not YAML text: character #x{exc.character:04x} at "
                         f"position {exc.position} is not allowed") from None
    except yaml.YAMLError as exc:
        problem = getattr(exc, "problem", None) or str(exc)
        if "nesting depth" in problem:
            # PyYAML >= 6.0.4 refuses deep flow nesting in its scanner, before the prescan
            # sees the events: the same refusal, in this reader's words
            raise InputError(name, "", f"refused{_where(exc)}: nested deeper than "
                             f"{MAX_DEPTH} levels") from None
        if getattr(exc, "context", None):
            problem = f"{exc.context}: {problem}"
        raise InputError(name, "", f"YAML syntax error{_where(exc)}: {problem}") from None
    except (ValueError, OverflowError, TypeError) as exc:
        # a value YAML's own constructors fail on (dates, huge integers, base64)
        raise InputError(name, "", f"bad value: {exc}") from None
    except RecursionError:
        raise InputError(name, "", f"refused: nested too deeply (limit {MAX_DEPTH})") from None
    if data is None and what is not None:
        raise InputError(name, "", f"empty file; expected {what}")
    return data


def _where(exc: yaml.YAMLError) -> str:
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    return f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""


def read_yaml(path: str | Path | Traversable, what: str | None = None, *,
              label: str | None = None, unique_keys: bool = True) -> Any:
    """Read and parse a YAML file; every failure is an :class:`InputError` naming the file.

    The one reader of every YAML file kind (robot, motor, gear, trajectory,
    regulator, requirement files): :func:`read_text` then :func:`parse_yaml`
    (duplicate keys refused, node count, depth and size limited, one float rule).

    Args:
        path: the file: a path, or an :mod:`importlib.resources` entry (the catalog).
        what: what the file should hold, for the error on an empty file (or one
            holding only ``null``): ``"a mapping with a 'type'"`` gives "empty
            file; expected a mapping with a 'type'". None: such a file gives None.
        label: how errors name the file (default ``str(path)``).
        unique_keys: kept for older callers and ignored: a duplicate key is
            refused in every file.

    Returns:
        The parsed data (a dict, list, str, number... as written).

    Raises:
        InputError: as :func:`read_text` and :func:`parse_yaml`.

    Example:
        >>> from manipcad.model.load import CATALOG
        >>> data = read_yaml(CATALOG / "robots" / "cylindrical.yaml", "a robot")
        >>> data["name"]
        'cylindrical arm (paper Fig. 2)'
    """
    del unique_keys
    name = label or str(path)
    return parse_yaml(read_text(path, name), name, what)


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
        ``InputError(source, field, reason)`` for the first problem, the field dotted with
        ``[i]`` for list entries (:func:`field_path`); when other fields have problems too
        the reason ends "(and N more problem(s): FIELD: REASON; ...)", naming every one.
        Raise it ``from None``.

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
    # every other field with a problem, each named with its reason (the branches of a
    # union fail at one field: one problem)
    others: dict[str, str] = {}
    for f, err in zip(fields, errors, strict=True):
        if f != fields[0] and f not in others:
            others[f] = reason(err)
    if others:
        more = len(others)
        text += (f" (and {more} more problem{'s' if more > 1 else ''}: "
                 + "; ".join(f"{f or '(top level)'}: {r}" for f, r in others.items()) + ")")
    return InputError(source, fields[0], text)


# --------------------------------------------------------------------------- writing


def _kind_of(mode: int) -> str | None:
    """What a non-regular file is ("a FIFO (named pipe)", ...), None for a regular file."""
    for test, what in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device")):
        if test(mode):
            return what
    return None if stat.S_ISREG(mode) else "not a regular file"


def writable_target(path: str | Path) -> Path:
    """Check that ``path`` may be written as a file: its folder exists and, if it
    exists, it is a regular file (followed through a symbolic link).

    A folder, a FIFO, a socket or a device (``/dev/null``) is refused, never replaced
    by a regular file nor written into: every file manipcad writes goes through here
    (:func:`atomic_write`).

    Raises:
        InputError: "folder '...' does not exist", "is a folder", or "is a FIFO (named
            pipe) / a character device / ..., not a regular file: refused".

    Example:
        >>> writable_target("/dev/null")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: /dev/null: is a character device, not a regular file: ...
    """
    p = Path(path)
    if not str(path).strip():
        raise InputError(repr(str(path)), "", "empty file name")
    if not p.parent.is_dir():
        raise InputError(str(path), "", f"folder {str(p.parent)!r} does not exist")
    try:
        mode = os.stat(p).st_mode
    except FileNotFoundError:
        return p  # absent (or a dangling link): a new file
    except OSError as exc:
        raise InputError(str(path), "", f"cannot write: {exc.strerror or exc}") from None
    what = _kind_of(mode)
    if what == "a folder":
        raise InputError(str(path), "", "is a folder")
    if what is not None:
        raise InputError(str(path), "", f"is {what}, not a regular file: refused "
                         "(manipcad writes only regular files)")
    return p


def writable_folder(path: str | Path) -> Path:
    """Check that ``path`` may be written as a whole folder (:func:`write_folder`): its
    parent exists and it is not a file. A study checks this before it computes.

    Raises:
        InputError: "exists and is not a directory", or "the parent directory ... does
            not exist".

    Example:
        >>> import tempfile, pathlib
        >>> writable_folder(pathlib.Path(tempfile.mkdtemp()) / "out").name
        'out'
    """
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise InputError(str(out), "", "exists and is not a directory")
    if not out.parent.is_dir():
        raise InputError(str(out), "", f"the parent directory {str(out.parent)!r} does not exist")
    return out


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
        writable_target(p)  # again: a FIFO or device made meanwhile is not replaced
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


def file_number(source: str, where: str, v: Any, *, positive: bool = False,
                allow_inf: bool = False) -> float:
    """A number read from a file: one InputError naming the file, the field and why.

    Args:
        source: the file (or what was read).
        where: the dotted field.
        v: the value read (bools and non-numbers are refused).
        positive: require > 0.
        allow_inf: let ±inf through (NaN never).

    Returns:
        float(v).

    Example:
        >>> from manipcad.fileio import file_number
        >>> file_number("reg.yaml", "groups[0].period_s", "1e-3", positive=True)
        0.001
    """
    if isinstance(v, bool) or not isinstance(v, int | float | str):
        raise InputError(source, where, f"expected a number, got {type(v).__name__}")
    try:
        x = float(v)
    except ValueError:
        raise InputError(source, where, f"expected a number, got {v!r}") from None
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        raise InputError(source, where, f"must be finite, got {v}")
    if positive and not x > 0:
        raise InputError(source, where, f"must be > 0, got {v}")
    return x


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
    "read_yaml", "read_text", "read_bytes", "parse_yaml", "dump_yaml", "check_readable",
    "SafeYamlLoader",
    "UniqueKeyLoader", "MAX_FILE_BYTES", "MAX_NODES", "MAX_DEPTH", "field_path",
    "describe_error", "validation_error",
    "writable_target", "atomic_write", "atomic_write_text", "atomic_write_bytes", "json_safe",
]
