"""Atomic folder writing: a folder is built beside its place and installed whole.

The one writer of every folder manipcad saves (result folders, studies, the
workspace's items and bundles). ``with write_folder(DIR) as tmp:`` yields an empty
hidden sibling folder (``.DIR.partial-PID-XXXX``); the files written into it are
flushed to disk (:func:`fsync_tree`) and the folder is then installed as DIR
(:func:`install_folder`):

- DIR absent: one ``rename``.
- DIR present (``force=True``): one ``renameat2(RENAME_EXCHANGE)`` (Linux,
  through ctypes) swaps the two folders in a single step, so DIR is at every
  instant either the old folder or the new one; the old one, now under the
  temporary name, is then deleted.
- Where the exchange is not available (other systems, some file systems), DIR
  is a symbolic link to a versioned folder ``.DIR.v-PID-XXXX`` beside it and
  the link is replaced atomically (``rename`` of a new link over it). An
  existing real folder is replaced there by two renames through
  ``.DIR.old-PID-XXXX``; a writer killed between them leaves DIR missing and
  the next write (or :func:`clean_stale`) renames the old folder back.

A writer killed at any moment (SIGKILL, SIGTERM) leaves DIR complete (old or
new) and at worst a hidden ``.DIR.partial-*``/``.DIR.old-*``/``.DIR.v-*``
folder; each name holds the writer's process id, and :func:`clean_stale`
(called by every write into the same folder) removes those of dead writers
(and versions older than the one the link points to, whoever made them).
An interrupted (Ctrl-C) or failed write removes its temporary folder and leaves
DIR as it was; Ctrl-C after the new folder is in place raises
:class:`SaveInterrupted`, which says so. Setting ``MANIPCAD_NO_RENAME_EXCHANGE``
turns the exchange off (to exercise the fallback).

Example:
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "study"
    >>> with write_folder(out) as tmp:
    ...     _ = (tmp / "a.json").write_text("{}")
    >>> sorted(p.name for p in out.iterdir())
    ['a.json']
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import re
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from manipcad.errors import InputError

#: renameat2 flag: swap two names atomically (Linux >= 3.15, most local file systems)
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100
_EXCHANGE_OFF = os.environ.get("MANIPCAD_NO_RENAME_EXCHANGE", "") not in ("", "0")

#: hidden names made beside a folder: .NAME.TAG-PID-RANDOM
_LEFTOVER = re.compile(r"^\.(?P<name>.+)\.(?P<tag>partial|old|v|link)-(?P<pid>\d+)-[^-/]+$")
#: the same of an earlier manipcad, without a process id (writer taken as dead)
_LEGACY = re.compile(r"^\.(?P<name>.+)\.(?P<tag>partial|old)-[^-/]+$")
#: the older study writer's ".NAME.XXXXXXXX.tmp" (no process id), removed when older than
#: :data:`LEGACY_TMP_AGE`
_LEGACY_TMP = re.compile(r"^\.(?P<name>.+)\.[a-z0-9_]{8}\.tmp$")
LEGACY_TMP_AGE = 3600.0


class SaveInterrupted(KeyboardInterrupt):
    """Ctrl-C after the new folder was installed: it is complete; only the old copy
    was still being removed (it goes on the next write)."""

    def __str__(self) -> str:  # KeyboardInterrupt prints nothing by default
        return str(self.args[0]) if self.args else "interrupted"


@contextlib.contextmanager
def write_folder(out: str | Path, *, force: bool = True) -> Iterator[Path]:
    """Write a folder whole and install it atomically: readers see the old or the new one.

    Yields an empty hidden folder beside ``out``; write every file into it. When
    the block ends normally the folder is flushed and installed as ``out``
    (:func:`install_folder`, the module docstring's steps). Leftovers of dead
    writers of ``out`` are removed first. If the block fails or is interrupted,
    the temporary folder is removed and ``out`` is left as it was.

    Args:
        out: the folder to write (its parent must exist).
        force: replace an existing non-empty ``out`` (False: that is an error).

    Raises:
        InputError: the parent folder does not exist, ``out`` is a file, it is a
            non-empty folder and ``force`` is False, or the disk refuses (read-only,
            full: "cannot write: No space left on device").
        SaveInterrupted: Ctrl-C after the new folder was installed.
    """
    out = Path(out)
    parent = _parent(out)
    if not parent.is_dir():
        raise InputError(str(out), "", f"folder {str(parent)!r} does not exist")
    clean_stale(parent, out.name)
    check_replaceable(out, force=force)
    try:
        tmp = temp_dir(out)
    except OSError as exc:
        raise InputError(str(out), "", f"cannot write in {str(parent)!r}: "
                         f"{exc.strerror or exc}") from None
    with _discard_on_failure(tmp, out, "write"):
        yield tmp
    install_folder(tmp, out, force=force)


def check_replaceable(out: str | Path, *, force: bool = False) -> None:
    """Refuse to write folder ``out`` where it is a file, or a non-empty folder without
    ``force`` (InputError naming ``out``)."""
    out = Path(out)
    if os.path.lexists(out) and not out.is_dir():
        raise InputError(str(out), "", "exists and is not a folder")
    if not force and out.is_dir() and any(out.iterdir()):
        raise InputError(str(out), "", "folder exists and is not empty; use --force "
                         "(force=True) to replace it")


def temp_dir(out: str | Path, tag: str = "partial") -> Path:
    """A new hidden folder ``.OUT.TAG-PID-XXXX`` beside ``out`` (mode 0o755; the parent
    made if missing) to build its next content in (see :func:`install_folder`); its name
    marks it as this process's, so :func:`clean_stale` removes it if the process dies."""
    out = Path(out)
    parent = _parent(out)
    parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.{tag}-{os.getpid()}-", dir=parent))
    os.chmod(tmp, 0o755)
    return tmp


def install_folder(tmp: str | Path, out: str | Path, *, force: bool = False) -> Path:
    """Flush the complete folder ``tmp`` to disk and install it as ``out`` atomically
    (the module docstring's steps).

    ``tmp`` must be a sibling of ``out`` (same file system). On failure or
    Ctrl-C before the new folder is in place, ``tmp`` is deleted and ``out``
    is left as it was.

    Args:
        tmp: the complete new folder (e.g. made by :func:`temp_dir`).
        out: the target folder (or link, in the versioned layout).
        force: replace a non-empty existing ``out``.

    Returns:
        ``out``.

    Raises:
        InputError: ``out`` is a file, or a non-empty folder without ``force``,
            or the disk refuses the write.
        SaveInterrupted: Ctrl-C after the new folder was installed.
    """
    tmp, out = Path(tmp), Path(out)
    with _discard_on_failure(tmp, out, "install"):
        fsync_tree(tmp)
        old = _install(tmp, out, force)
    if old is not None:
        try:
            _remove(old)
        except KeyboardInterrupt:
            raise SaveInterrupted(f"interrupted after {out} was written whole; the old "
                                  f"copy {old.name} is removed on the next write") from None
    return out


def fsync_tree(root: Path) -> None:
    """Flush every file and folder under ``root`` to disk (before it is renamed in place)."""
    for folder, _, files in os.walk(root):
        for f in files:
            fd = os.open(os.path.join(folder, f), os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def exchange(a: str | Path, b: str | Path) -> bool:
    """Swap two existing paths in one atomic step (Linux ``renameat2(RENAME_EXCHANGE)``);
    off when ``MANIPCAD_NO_RENAME_EXCHANGE`` is set.

    Returns:
        True when swapped; False when the system or file system cannot do it
        (then nothing changed).

    Raises:
        OSError: any other failure of the call (permissions, a read-only disk).
    """
    if _EXCHANGE_OFF:
        return False
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    rc = fn(_AT_FDCWD, os.fsencode(str(a)), _AT_FDCWD, os.fsencode(str(b)), _RENAME_EXCHANGE)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EXDEV):
        return False
    raise OSError(err, os.strerror(err), str(a), None, str(b))


def exchange_supported(folder: str | Path) -> bool:
    """Whether :func:`exchange` works in ``folder`` (tried once on two empty folders)."""
    folder = Path(folder)
    key = str(folder.resolve())
    if key not in _SUPPORTED:
        a = b = None
        try:
            a = Path(tempfile.mkdtemp(prefix=f".probe.partial-{os.getpid()}-", dir=folder))
            b = Path(tempfile.mkdtemp(prefix=f".probe.partial-{os.getpid()}-", dir=folder))
            _SUPPORTED[key] = exchange(a, b)
        except OSError:
            _SUPPORTED[key] = False
        finally:
            for p in (a, b):
                if p is not None:
                    shutil.rmtree(p, ignore_errors=True)
    return _SUPPORTED[key]


_SUPPORTED: dict[str, bool] = {}


def leftovers(folder: str | Path, name: str | None = None) -> list[tuple[Path, str, bool]]:
    """The hidden temporary entries of the writers in a folder.

    Args:
        folder: the folder holding the written folders.
        name: only those of this folder name (None: all).

    Returns:
        (path, tag, writer_alive) per entry; tag is "partial", "old", "v"
        (a version of the versioned layout), "link" or "tmp" (the older study
        writer's, "alive" while younger than :data:`LEGACY_TMP_AGE`). Entries of an
        earlier manipcad without a process id in the name count as of a dead writer.
    """
    out = []
    folder = Path(folder)
    try:
        entries = list(folder.iterdir())
    except OSError:
        return []
    for p in entries:
        m = _LEFTOVER.match(p.name)
        if m is not None:
            tag, alive = m["tag"], _alive(int(m["pid"]))
        elif (m := _LEGACY.match(p.name)) is not None:
            tag, alive = m["tag"], False
        elif (m := _LEGACY_TMP.match(p.name)) is not None:
            tag = "tmp"
            try:
                alive = time.time() - p.lstat().st_mtime <= LEGACY_TMP_AGE
            except OSError:
                continue
        else:
            continue
        if name is None or m["name"] == name:
            out.append((p, tag, alive))
    return out


def clean_stale(folder: str | Path, name: str | None = None) -> list[str]:
    """Remove the leftovers of dead writers in ``folder``; repair a half swap.

    A folder NAME found missing while a dead writer's ``.NAME.old-*`` exists (a
    kill between the two renames of the fallback swap) gets that folder back (the
    newest, if several). Versions of the versioned layout no link points to are
    removed.

    Args:
        folder: the folder holding the written folders.
        name: only the leftovers of this folder name (None: all).

    Returns:
        One line per action taken ("removed .r.partial-12-ab", "restored r from ...").
    """
    folder = Path(folder)
    done: list[str] = []
    found = leftovers(folder, name)
    found.sort(key=lambda e: (e[1] != "old", -_mtime(e[0])))  # the newest old copy first
    for p, tag, alive in found:
        if alive and not (tag == "v" and _superseded(p, folder)):
            continue
        m = _LEFTOVER.match(p.name) or _LEGACY.match(p.name) or _LEGACY_TMP.match(p.name)
        assert m is not None
        target = folder / m["name"]
        try:
            if tag == "old" and not target.exists() and not target.is_symlink():
                os.rename(p, target)
                done.append(f"restored {target.name} from {p.name}")
                continue
            if tag == "v":
                if target.is_symlink() and target.resolve() == p.resolve():
                    continue
                if not target.is_symlink() and not target.exists():
                    os.symlink(p.name, target)  # a link lost before it was made: keep data
                    done.append(f"restored {target.name} -> {p.name}")
                    continue
            _remove(p)
            done.append(f"removed {p.name}")
        except OSError:
            continue
    return done


# --------------------------------------------------------------------------- steps


def _parent(out: Path) -> Path:
    return out.parent if str(out.parent) else Path(".")


def _mtime(p: Path) -> float:
    try:
        return p.lstat().st_mtime
    except OSError:
        return 0.0


@contextlib.contextmanager
def _discard_on_failure(tmp: Path, out: Path, step: str):
    """Delete ``tmp`` if the block fails or is interrupted; OSError -> InputError on ``out``."""
    try:
        yield
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError):
            raise InputError(str(out), "", f"cannot {step}: {exc.strerror or exc}") from None
        raise


def _remove(path: Path) -> None:
    if path.is_symlink() or path.is_file():
        path.unlink(missing_ok=True)
    else:
        shutil.rmtree(path, ignore_errors=True)


def _install(tmp: Path, out: Path, force: bool) -> Path | None:
    """Install ``tmp`` as ``out``; return what is left to delete (the old copy) or None."""
    if out.is_symlink():  # the versioned layout: replace the link atomically
        check_replaceable(out, force=force)
        return _relink(tmp, out)
    if not out.exists():
        if exchange_supported(out.parent):
            try:
                os.rename(tmp, out)
                return None
            except OSError as exc:
                if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY):  # not a lost race
                    raise
                if not force:
                    raise InputError(str(out), "", "exists (another writer made it)") from None
        else:
            return _relink(tmp, out)
    check_replaceable(out, force=force)
    if not any(out.iterdir()):
        os.replace(tmp, out)  # POSIX rename may replace an empty folder
        return None
    if exchange(tmp, out):
        return tmp  # now holds the old folder
    # no exchange: two renames; a kill between them is repaired by clean_stale
    old = temp_dir(out, "old")
    os.rmdir(old)
    os.rename(out, old)
    try:
        os.rename(tmp, out)
    except BaseException:
        os.rename(old, out)
        raise
    return old


def _relink(tmp: Path, out: Path) -> Path | None:
    """The versioned layout: rename ``tmp`` to ``.NAME.v-PID-X`` and point the link at it."""
    version = temp_dir(out, "v")
    os.rmdir(version)
    os.rename(tmp, version)
    link = out.parent / f".{out.name}.link-{os.getpid()}-{version.name[-8:]}"
    try:
        os.symlink(version.name, link)
        previous = out.resolve() if out.is_symlink() else None
        os.replace(link, out)
    except BaseException:
        # an interrupt (SIGINT) can land after the replace returned, still in this
        # block: the link then already points at the new version, which must stay
        if not (out.is_symlink() and out.resolve() == version.resolve()):
            link.unlink(missing_ok=True)
            os.rename(version, tmp)
        raise
    if previous is not None and previous != version.resolve() and previous.parent == out.parent:
        return previous
    return None


def _superseded(version: Path, folder: Path) -> bool:
    """A version folder older than the one its link points to (no writer will link it)."""
    m = _LEFTOVER.match(version.name)
    link = folder / m["name"] if m else None
    if link is None or not link.is_symlink():
        return False
    try:
        current = link.resolve()
        return current != version.resolve() and (
            version.lstat().st_ctime_ns < current.lstat().st_ctime_ns)
    except OSError:
        return False


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (this one does)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


__all__ = ["write_folder", "install_folder", "temp_dir", "check_replaceable", "fsync_tree",
           "exchange", "exchange_supported", "leftovers", "clean_stale", "SaveInterrupted",
           "LEGACY_TMP_AGE"]
