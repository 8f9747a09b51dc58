"""Item kinds and safe item names: nothing a user types can point outside the workspace."""

from __future__ import annotations

import re
from pathlib import Path

from manipcad.errors import InputError

#: the workspace's folders, one per kind of item
KINDS = ("robots", "motors", "gears", "trajectories", "regulators", "results", "studies")

#: kinds stored as one file (the others are folders)
FILE_KINDS = ("robots", "motors", "gears", "trajectories", "regulators")

_SINGULAR = {"robot": "robots", "motor": "motors", "gear": "gears", "trajectory": "trajectories",
             "regulator": "regulators", "result": "results", "study": "studies"}

#: a name: letters, digits, '.', '_', '-'; starts with a letter or digit; <= 100 characters
NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,99}$")


def kind_of(text: str, source: str = "--kind") -> str:
    """The plural kind for "robot", "robots", "Robot", ...

    Raises:
        InputError: not a kind (naming ``source`` and listing the kinds).

    Example:
        >>> kind_of("trajectory")
        'trajectories'
    """
    k = str(text).strip().lower()
    k = _SINGULAR.get(k, k)
    if k not in KINDS:
        raise InputError(source, "", f"unknown kind {text!r}; kinds: {', '.join(KINDS)}")
    return k


def check_name(name: str, source: str = "--name") -> str:
    """Check an item name: a plain name that stays inside its kind's folder.

    Refused: empty, path separators, absolute paths, ``..``, leading dots,
    characters outside letters, digits, ``.``, ``_``, ``-``, more than 100 characters.

    Raises:
        InputError: naming ``source`` and the reason.

    Example:
        >>> check_name("ur5-fast")
        'ur5-fast'
        >>> check_name("../etc")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: --name: '../etc': a name may not contain '/' ...
    """
    if not isinstance(name, str) or not name:
        raise InputError(source, "", "empty name")
    if "/" in name or "\\" in name or Path(name).is_absolute():
        raise InputError(source, "", f"{name!r}: a name may not contain '/' or '\\\\' (it "
                         "names an item inside the workspace, not a path)")
    if ".." in name:
        raise InputError(source, "", f"{name!r}: a name may not contain '..'")
    if not NAME_RE.match(name):
        raise InputError(source, "", f"{name!r}: use letters, digits, '.', '_' and '-', "
                         "starting with a letter or digit, at most 100 characters")
    return name


def name_from_file(path: Path) -> str:
    """A default item name from a file name: its stem, other characters as '-'.

    Example:
        >>> name_from_file(Path("/tmp/My Arm (v2).yaml"))
        'My-Arm-v2'
    """
    stem = path.name if path.is_dir() else path.stem
    clean = re.sub(r"[^A-Za-z0-9._-]+", "-", stem).strip("-._")
    return clean[:100] or "item"


def inside(path: Path, folder: Path) -> bool:
    """Whether ``path``, links followed, lies inside ``folder`` (links followed)."""
    try:
        return path.resolve().is_relative_to(folder.resolve())
    except (OSError, RuntimeError):
        return False
