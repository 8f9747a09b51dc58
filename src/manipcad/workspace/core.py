"""The designer's workspace: folders of robots, motors, gears, trajectories,
regulators, results and studies, and an SQLite index over them.

Layout (docs/workspace.md)::

    WS/manipcad-workspace.yaml     marker: format version
    WS/index.sqlite                the index (derived; ``reindex`` rebuilds it)
    WS/robots/NAME.yaml|.urdf|.xml one file per item of a file kind
    WS/motors/ gears/ trajectories/ regulators/
    WS/results/NAME/               a result folder (manipcad.store.results)
    WS/studies/NAME/               a study folder
    WS/.meta/KIND/NAME.json        what the files do not say: created time,
                                   manipcad version, source, provenance

Files are the truth: everything in the index can be rebuilt from them.
Writes are atomic (a temporary file or folder renamed into place, then one
SQLite transaction), so two writer processes lose no row and a killed
writer leaves at worst an unindexed item or a hidden leftover that ``check``
reports and ``reindex`` / the next write cleans.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import secrets
import shlex
import shutil
import tempfile
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from html import escape
from pathlib import Path
from typing import Any

from manipcad.catalog.files import PARTS
from manipcad.errors import InputError, ManipcadWarning
from manipcad.fileio import atomic_write_text, json_safe
from manipcad.folders import clean_stale, install_folder, leftovers, temp_dir
from manipcad.model.load import CATALOG, load_robot, referenced_files
from manipcad.model.tree_file import save_robot
from manipcad.store.results import load_result, save_result, write_csv
from manipcad.version import __version__
from manipcad.workspace.index import Index
from manipcad.workspace.kinds import (
    BUNDLE_MANIFEST,
    content_hash,
    detect_kind,
    file_hash,
    regulator_robot_name,
    result_metrics,
    validate_item,
)
from manipcad.workspace.names import FILE_KINDS, KINDS, check_name, inside, kind_of, name_from_file
from manipcad.workspace.where import parse_where, where_sql

MARKER = "manipcad-workspace.yaml"
INDEX = "index.sqlite"
META = ".meta"
ENV = "MANIPCAD_WORKSPACE"
DEFAULT_DIR = "manipcad-ws"
FORMAT = 1
#: why an item is refused when its name is taken (said the same from the CLI, Python and
#: the web application)
NAME_TAKEN = ("name taken in the workspace; choose another name, or replace the item "
              "(--force on the command line, force=True in Python)")

#: suffixes kept for file items (others are refused)
_SUFFIXES = (".yaml", ".yml", ".urdf", ".xml", ".mjcf")


def default_root(ws: str | Path | None = None) -> Path:
    """The workspace folder: ``ws`` if given, else ``$MANIPCAD_WORKSPACE``, else ``./manipcad-ws``.

    Example:
        >>> default_root("/tmp/ws")
        PosixPath('/tmp/ws')
    """
    if ws:
        return Path(ws)
    env = os.environ.get(ENV, "")
    return Path(env) if env else Path(DEFAULT_DIR)


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


@dataclass
class Item:
    """One indexed item.

    Attributes:
        kind: its kind (robots, motors, ...).
        name: its name, unique within the kind.
        path: its file or folder relative to the workspace.
        hash: SHA-256 of its content (:func:`manipcad.workspace.kinds.content_hash`).
        created: when it was added, ISO 8601 UTC.
        manipcad_version: the version that added it.
        source: where it came from (the file added, the command that made it).
        provenance: for results, role -> {kind, name, hash} of the inputs and
            the hash of the settings.
        status: a result's status ("ok", "diverged"); None for other kinds.
        metrics: a result's indexed metrics, "joint.metric" (or "metric" for the
            largest over the joints) -> value in SI units.
    """

    kind: str
    name: str
    path: str
    hash: str
    created: str
    manipcad_version: str
    source: str = ""
    provenance: dict[str, Any] = field(default_factory=dict)
    status: str | None = None
    metrics: dict[str, float] = field(default_factory=dict)

    @property
    def ref(self) -> str:
        """``kind/name``, unambiguous in every command."""
        return f"{self.kind}/{self.name}"

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready mapping (``ws list --json``)."""
        return json_safe({"kind": self.kind, "name": self.name, "path": self.path,
                          "hash": self.hash, "created": self.created,
                          "manipcad_version": self.manipcad_version, "source": self.source,
                          "provenance": self.provenance, "status": self.status,
                          "metrics": self.metrics})

    def _repr_html_(self) -> str:
        return ItemList([self])._repr_html_()


class ItemList(list):
    """A list of :class:`Item` that Jupyter shows as a table."""

    def _repr_html_(self) -> str:

        rows = "".join(
            f"<tr><td>{escape(i.kind)}</td><td>{escape(i.name)}</td>"
            f"<td>{escape(i.created)}</td><td>{escape(i.status or '')}</td>"
            f"<td>{'' if 'max_error' not in i.metrics else format(i.metrics['max_error'], '.3g')}"
            f"</td><td><code>{escape(i.hash[:12])}</code></td></tr>" for i in self)
        return ("<table><thead><tr><th>kind</th><th>name</th><th>created (UTC)</th>"
                "<th>status</th><th>max |e| [rad|m]</th><th>hash</th></tr></thead>"
                f"<tbody>{rows}</tbody></table>")


@dataclass
class Problem:
    """A finding of :meth:`Workspace.check`: what (missing, changed, unindexed,
    leftover, outside, invalid), the item and details (hashes)."""

    problem: str
    kind: str
    name: str
    detail: str = ""

    def to_dict(self) -> dict[str, str]:
        """A JSON-ready mapping."""
        return {"problem": self.problem, "kind": self.kind, "name": self.name,
                "detail": self.detail}


class Workspace:
    """An opened workspace (see the module docstring).

    Args:
        root: the workspace folder (made by :meth:`init`); None: :func:`default_root`.
        rebuild_index: if the index cannot be read, move it aside
            (``index.sqlite.unreadable-TIME``) and rebuild it from the files.

    Raises:
        InputError: not a workspace folder (the message says how to make one), or an
            unreadable index (without ``rebuild_index``).

    Example:
        >>> import tempfile
        >>> ws = Workspace.init(tempfile.mkdtemp() + "/ws")
        >>> [i.name for i in ws.list()]
        []
    """

    def __init__(self, root: str | Path | None = None, *, rebuild_index: bool = False) -> None:
        self.root = default_root(root)
        if not (self.root / MARKER).is_file():
            raise InputError(str(self.root), "", "not a manipcad workspace (no "
                             f"{MARKER}); make one with 'manipcad ws init {self.root}'")
        for kind in KINDS:
            folder = self.root / kind
            if folder.is_symlink() and not inside(folder, self.root):
                raise InputError(str(folder), "", "links outside the workspace; refused")
        try:
            self.index = Index(self.root / INDEX)
        except InputError:
            if not rebuild_index:
                raise
            # files are the truth: set the unreadable index aside and rebuild it from them
            stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S")
            for suffix in ("", "-wal", "-shm"):
                old = self.root / f"{INDEX}{suffix}"
                if old.exists():
                    os.replace(old, self.root / f"{INDEX}{suffix}.unreadable-{stamp}")
            self.index = Index(self.root / INDEX)
            self.reindex()

    # ------------------------------------------------------------------ making
    @classmethod
    def init(cls, root: str | Path | None = None) -> Workspace:
        """Make a workspace folder (or complete an existing one) and open it.

        Args:
            root: the folder; None: :func:`default_root`.

        Returns:
            The opened :class:`Workspace`.

        Raises:
            InputError: ``root`` is a file, or a non-empty folder that is not a workspace.
        """
        root = default_root(root)
        if root.exists() and not root.is_dir():
            raise InputError(str(root), "", "exists and is not a folder")
        if root.is_dir() and not (root / MARKER).is_file() and any(root.iterdir()):
            raise InputError(str(root), "", "folder exists, is not empty and is not a "
                             "workspace; choose an empty or new folder")
        try:
            for kind in KINDS:
                (root / kind).mkdir(parents=True, exist_ok=True)
            (root / META).mkdir(exist_ok=True)
        except OSError as exc:
            raise InputError(str(root), "", f"cannot make the workspace: "
                             f"{exc.strerror or exc}") from None
        if not (root / MARKER).is_file():
            atomic_write_text(root / MARKER, f"# a manipcad workspace (docs/workspace.md)\n"
                              f"format: {FORMAT}\ncreated: '{_now()}'\n"
                              f"manipcad_version: '{__version__}'\n")
        return cls(root)

    def close(self) -> None:
        """Close the index connection."""
        self.index.close()

    def __enter__(self) -> Workspace:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Workspace({str(self.root)!r})"

    def _repr_html_(self) -> str:
        return f"<p>manipcad workspace <code>{self.root}</code></p>" + \
            self.list()._repr_html_()

    # ------------------------------------------------------------------ paths
    def _item_path(self, kind: str, rel: str) -> Path:
        """The absolute path of an item, refused if it leaves its kind's folder."""
        p = self.root / rel
        folder = self.root / kind
        if not inside(p, folder) or not inside(folder, self.root):
            raise InputError(str(p), "", "points outside the workspace; refused")
        return p

    def path(self, item: Item | str) -> Path:
        """The file or folder of an item (an :class:`Item` or a name/``kind/name``)."""
        it = item if isinstance(item, Item) else self.get(item)
        return self._item_path(it.kind, it.path)

    def resolve(self, kind: str, name: str) -> Path:
        """The file or folder of the item ``name`` of ``kind``.

        This is the call for commands that read inputs: ``load_robot(ws.resolve("robot",
        "ur5"))``.

        Raises:
            InputError: no such item (listing the names of that kind).
        """
        return self.path(self.get(f"{kind_of(kind)}/{name}"))

    def find(self, kind: str, text: str | Path) -> Path | None:
        """A command argument as a workspace item of ``kind``, or None if it is not one.

        ``text`` is an item name (or ``kind/name``); an existing file or a
        catalog name is not looked up here (None).
        """
        text = str(text)
        if Path(text).exists():
            return None
        name = text.split("/", 1)[1] if text.startswith(f"{kind_of(kind)}/") else text
        rows = self.index.query("SELECT * FROM items WHERE kind = ? AND name = ?",
                                (kind_of(kind), name))
        return self._item_path(rows[0]["kind"], rows[0]["path"]) if rows else None

    # ------------------------------------------------------------------ reading
    def _item(self, row, metrics_rows=None) -> Item:
        metrics = {}
        if metrics_rows is None:
            metrics_rows = self.index.query(
                "SELECT joint, metric, value FROM metrics WHERE item_id = ?", (row["id"],))
        for m in metrics_rows:
            key = m["metric"] if m["joint"] == "*" else f"{m['joint']}.{m['metric']}"
            metrics[key] = m["value"]
        return Item(kind=row["kind"], name=row["name"], path=row["path"], hash=row["hash"],
                    created=row["created"], manipcad_version=row["manipcad_version"],
                    source=row["source"], provenance=json.loads(row["provenance"] or "{}"),
                    status=row["status"], metrics=metrics)

    def list(self, kind: str | None = None, where: str | None = None) -> ItemList:
        """The indexed items, by kind and name.

        Args:
            kind: only this kind (singular or plural), or None for all.
            where: a metric filter, e.g. ``"max_error<1e-3 and status=ok"``
                (:mod:`manipcad.workspace.where`); it selects results.

        Returns:
            An :class:`ItemList` (a list Jupyter shows as a table).

        Raises:
            InputError: unknown kind, or a filter that does not parse.
        """
        sql, params = "SELECT * FROM items", []
        conds = []
        if kind:
            conds.append("kind = ?")
            params.append(kind_of(kind))
        if where:
            clauses = parse_where(where)
            self._check_where_names(clauses)
            cond, wparams = where_sql(clauses)
            conds.append(cond)
            params += wparams
        if conds:
            sql += " WHERE " + " AND ".join(conds)
        sql += " ORDER BY kind, name"
        rows = self.index.query(sql, params)
        by_item: dict[int, list] = {r["id"]: [] for r in rows}
        if any(r["kind"] == "results" for r in rows):  # one query for all the metrics
            for m in self.index.query("SELECT item_id, joint, metric, value FROM metrics"):
                if m["item_id"] in by_item:
                    by_item[m["item_id"]].append(m)
        return ItemList(self._item(r, by_item[r["id"]]) for r in rows)

    def _check_where_names(self, clauses) -> None:
        """Refuse a filter naming a joint no stored result has, or a status none can have
        (a misspelt name matched nothing and listed no result, as if none qualified)."""
        joints = {r["joint"] for r in self.index.query("SELECT DISTINCT joint FROM metrics")}
        joints.discard("*")
        statuses = {"ok", "diverged"} | {r["status"] for r in self.index.query(
            "SELECT DISTINCT status FROM items WHERE status IS NOT NULL")}
        for c in clauses:
            if c.joint != "*" and c.joint not in joints:
                raise InputError("--where", "", f"{c.field}[{c.joint}]: no stored result has a "
                                 f"joint {c.joint!r}; the results' joints: "
                                 f"{', '.join(sorted(joints)) or '(no results)'}")
            if c.field == "status" and c.value not in statuses:
                raise InputError("--where", "", f"status {c.value!r}: a result's status is one "
                                 f"of {', '.join(sorted(statuses))}")

    def library(self, kind: str | None = None, where: str | None = None) -> ItemList:
        """The workspace's items and, for robots, motors and gears, the built-in
        catalog's beside them (``source`` "catalog (read-only)"); a filter selects
        results only, so it leaves out the catalog."""
        items = self.list(kind, where=where)
        if where is None and (kind is None or kind_of(kind) in ("robots", "motors", "gears")):
            items = ItemList(sorted([*items, *catalog_items(kind)],
                                    key=lambda i: (i.kind, i.name, i.source)))
        return items

    def get(self, ref: str) -> Item:
        """One item by ``kind/name`` or by a name unique across kinds.

        Raises:
            InputError: no such item, or a name used by several kinds.
        """
        ref = str(ref)
        if "/" in ref and ref.split("/", 1)[0].lower() in (*KINDS, "robot", "motor", "gear",
                                                           "trajectory", "regulator",
                                                           "result", "study"):
            kind, name = ref.split("/", 1)
            rows = self.index.query("SELECT * FROM items WHERE kind = ? AND name = ?",
                                    (kind_of(kind), name))
        else:
            rows = self.index.query("SELECT * FROM items WHERE name = ?", (ref,))
        if not rows:
            raise InputError(ref, "", f"no such item in the workspace {self.root}; "
                             "'manipcad ws list' shows them")
        if len(rows) > 1:
            raise InputError(ref, "", "several items have this name: " + ", ".join(
                f"{r['kind']}/{r['name']}" for r in rows) + "; say which")
        return self._item(rows[0])

    def dependents(self, item: Item) -> list[Item]:
        """The items (results) that record ``item`` among their inputs."""
        rows = self.index.query(
            "SELECT DISTINCT items.* FROM deps JOIN items ON items.id = deps.item_id "
            "WHERE deps.kind = ? AND deps.name = ? ORDER BY items.name", (item.kind, item.name))
        return [self._item(r) for r in rows]

    # ------------------------------------------------------------------ writing
    def add(self, source: str | Path, *, kind: str | None = None, name: str | None = None,
            force: bool = False, robot=None) -> Item | list[Item]:
        """Add a file or folder to the workspace (a copy), validated and indexed.

        Args:
            source: a robot, motor, gear, trajectory or regulator file, a result
                or study folder, or a bundle folder made by :meth:`export`
                (then every item in it is added and a list is returned).
            kind: the kind; None: recognized from the content
                (:func:`manipcad.workspace.kinds.detect_kind`).
            name: the item's name; None: from the file name.
            force: replace an item of the same kind and name.
            robot: a robot (anything ``load_robot`` takes) to check a regulator or
                Cartesian trajectory file against.

        Returns:
            The new :class:`Item` (a list for a bundle).

        Raises:
            InputError, ModelError: the loader's error (file, field, reason), a
                name taken (without ``force``) or unsafe.
        """
        src = Path(source)
        if not src.exists():
            raise InputError(str(src), "", "no such file or folder")
        if src.is_symlink() and src.is_dir():
            src = src.resolve()
        _no_links_out(src)
        found = detect_kind(src) if kind is None else kind_of(kind)
        if found == "bundle":
            return self._add_bundle(src, force=force)
        if found == "studies" and kind is None:
            _no_bundles_inside(src)
        kind = found
        if (kind in FILE_KINDS) != src.is_file():
            form = "files" if kind in FILE_KINDS else "folders"
            raise InputError(str(src), "", f"{kind} are {form}")
        name = check_name(name if name is not None else name_from_file(src))
        if kind in FILE_KINDS and src.suffix.lower() not in _SUFFIXES:
            raise InputError(str(src), "", f"a {kind[:-1]} file ends in "
                             f"{', '.join(_SUFFIXES)}")
        if robot is None and kind == "regulators":

            named = regulator_robot_name(src)  # a workspace robot of that name checks it
            robot = str(self.find("robots", named)) if named and self.find("robots", named) \
                else None
        if robot is not None and not hasattr(robot, "joint_types"):
            robot = _robot_quiet(self.find("robots", robot) or robot)
        facts = validate_item(kind, src, robot=robot)
        self.check_free(kind, name, force)
        folder = self.root / kind
        self._clean_leftovers(kind)
        stored_as = ""
        if kind in FILE_KINDS:
            copy_from = src
            if kind == "robots" and _references_files(src):
                # a URDF + drives file or one naming motor/gear files by path: store it
                # self-contained, in the tree form save_robot writes (loads back identical)
                copy_from = Path(tempfile.mkdtemp(prefix="manipcad-ws-")) / f"{name}.yaml"
                save_robot(_robot_quiet(src), copy_from)
                stored_as = " (stored in the tree form: its file referenced other files)"
            try:
                tmp = self._copy_file(copy_from, folder, name)
            finally:
                if copy_from != src:
                    shutil.rmtree(copy_from.parent, ignore_errors=True)
            target = folder / f"{name}{copy_from.suffix.lower()}"
        else:

            tmp = temp_dir(folder / name)
            shutil.rmtree(tmp)
            shutil.copytree(src, tmp, symlinks=False,
                            ignore=shutil.ignore_patterns(".*"))
            target = folder / name
        meta = {"created": _now(), "manipcad_version": __version__,
                "source": str(src.resolve()) + stored_as}
        if kind == "results":
            meta["provenance"] = self._result_provenance(tmp)
        return self._commit(kind, name, tmp, target, meta, facts, force)

    def _clean_leftovers(self, kind: str) -> list[str]:
        """Remove what killed writers left in ``kind``'s folder (the hidden
        ``.NAME.partial-PID-*`` files and folders, nested ones included, of processes that
        no longer run; :func:`manipcad.folders.clean_stale`). Every write does it
        first, so a SIGKILL's leftovers last only until the next write."""

        folder = self.root / kind
        return clean_stale(folder) if folder.is_dir() else []

    def check_free(self, kind: str, name: str, force: bool = False) -> None:
        """Refuse a name already taken by an item of ``kind`` (indexed, or a file or folder
        there), unless ``force``: the check :meth:`add` and :meth:`store_result` make
        before they write, for a caller that must know before long work.

        Raises:
            InputError: ``kind/name``: :data:`NAME_TAKEN`.
        """
        if force:
            return
        rows = self.index.query("SELECT 1 FROM items WHERE kind = ? AND name = ?", (kind, name))
        if rows or self._existing(kind, name):
            raise InputError(f"{kind}/{name}", "", NAME_TAKEN)

    def _existing(self, kind: str, name: str) -> Path | None:
        folder = self.root / kind
        if kind not in FILE_KINDS:
            p = folder / name
            return p if p.exists() or p.is_symlink() else None
        for suffix in _SUFFIXES:
            p = folder / f"{name}{suffix}"
            if p.exists() or p.is_symlink():
                return p
        return None

    def _copy_file(self, src: Path, folder: Path, name: str) -> Path:
        fd, tmp = tempfile.mkstemp(prefix=f".{name}.partial-{os.getpid()}-", dir=folder)
        try:
            with os.fdopen(fd, "wb") as out, open(src, "rb") as inp:
                shutil.copyfileobj(inp, out)
                out.flush()
                os.fsync(out.fileno())
            os.chmod(tmp, 0o644)
        except BaseException:
            os.unlink(tmp)
            raise
        return Path(tmp)

    def _commit(self, kind: str, name: str, tmp: Path, target: Path, meta: dict[str, Any],
                facts: dict[str, Any], force: bool) -> Item:
        """Install ``tmp`` as ``target`` and index it, in one write transaction."""

        try:
            with self.index.write() as db:
                rows = db.execute("SELECT id, path FROM items WHERE kind = ? AND name = ?",
                                  (kind, name)).fetchall()
                existing = self._existing(kind, name)
                if (rows or existing) and not force:
                    raise InputError(f"{kind}/{name}", "", NAME_TAKEN)
                if tmp.is_dir():
                    install_folder(tmp, target, force=force)
                else:
                    if existing is not None and existing != target:
                        existing.unlink()
                    if force:
                        os.replace(tmp, target)
                    else:
                        os.link(tmp, target)  # fails if another writer made it meanwhile
                        os.unlink(tmp)
                self._write_meta(kind, name, meta)
                if rows:
                    db.execute("DELETE FROM items WHERE id = ?", (rows[0]["id"],))
                item = self._index_row(db, kind, name, target, meta, facts)
        finally:
            if tmp.exists() and not tmp.is_dir():
                tmp.unlink()
            elif tmp.is_dir():
                shutil.rmtree(tmp, ignore_errors=True)
        return item

    def _write_meta(self, kind: str, name: str, meta: Mapping[str, Any]) -> None:
        folder = self.root / META / kind
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_text(folder / f"{name}.json", json.dumps(json_safe(meta), indent=2) + "\n")

    def _read_meta(self, kind: str, name: str) -> dict[str, Any]:
        p = self.root / META / kind / f"{name}.json"
        try:
            data = json.loads(p.read_text(encoding="utf-8"))
            return data if isinstance(data, dict) else {}
        except (OSError, ValueError):
            return {}

    def _index_row(self, db, kind: str, name: str, target: Path, meta: Mapping[str, Any],
                   facts: Mapping[str, Any]) -> Item:
        rel = str(target.relative_to(self.root))
        digest = content_hash(target)
        prov = meta.get("provenance") or {}
        status = facts.get("status")
        cur = db.execute(
            "INSERT INTO items(kind, name, path, hash, created, manipcad_version, source, "
            "provenance, status) VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (kind, name, rel, digest, str(meta.get("created") or _now()),
             str(meta.get("manipcad_version") or "unknown"), str(meta.get("source") or ""),
             json.dumps(json_safe(prov)), status))
        item_id = cur.lastrowid
        for role, dep in (prov.get("inputs") or {}).items():
            for d in dep if isinstance(dep, list) else [dep]:
                db.execute("INSERT INTO deps(item_id, role, kind, name, hash) "
                           "VALUES(?, ?, ?, ?, ?)",
                           (item_id, role, d.get("kind"), d.get("name"), d.get("hash", "")))
        if kind == "results" and "doc" in facts:
            for (joint, metric), value in result_metrics(facts["doc"], facts["result"]).items():
                db.execute("INSERT INTO metrics(item_id, joint, metric, value) "
                           "VALUES(?, ?, ?, ?)", (item_id, joint, metric, value))
        row = db.execute("SELECT * FROM items WHERE id = ?", (item_id,)).fetchone()
        return self._item(row)

    def _result_provenance(self, folder: Path) -> dict[str, Any]:
        """role -> {kind, name, hash} of a result folder's stored inputs, and its settings hash.

        An input whose bytes equal a workspace item's (same kind, same hash) is
        recorded with that item's name.
        """

        roles = {"robot": "robots", "trajectory": "trajectories", "regulator": "regulators"}
        inputs: dict[str, Any] = {}
        folder_in = folder / "inputs"
        for f in sorted(folder_in.iterdir()) if folder_in.is_dir() else ():
            role = f.stem.rsplit("-", 1)[0] if f.stem.rsplit("-", 1)[-1].isdigit() else f.stem
            kind = roles.get(role)
            digest = file_hash(f)
            name = None
            if kind is not None:
                rows = self.index.query("SELECT name FROM items WHERE kind = ? AND hash = ? "
                                        "ORDER BY name LIMIT 1", (kind, digest))
                name = rows[0]["name"] if rows else None
            entry = {"kind": kind, "name": name, "hash": digest, "file": f"inputs/{f.name}"}
            if role in inputs:
                prev = inputs[role]
                inputs[role] = (prev if isinstance(prev, list) else [prev]) + [entry]
            else:
                inputs[role] = entry
        doc_path = folder / "metrics.json"
        settings = {}
        if doc_path.is_file():
            try:
                doc = json.loads(doc_path.read_text(encoding="utf-8"))
                settings = {"settings": doc.get("settings"), "run": doc.get("run")}
            except ValueError:
                pass

        sett = hashlib.sha256(json.dumps(json_safe(settings), sort_keys=True).encode())
        return {"inputs": inputs, "settings_hash": sett.hexdigest()}

    def store_result(self, result, *, name: str | None = None, robot=None, trajectory=None,
                     regulators: Sequence[Any] = (), run: Mapping[str, Any] | None = None,
                     joint_types: Sequence[str] | None = None, force: bool = False,
                     status: str = "ok", message: str = "", plot: bool = True) -> Item:
        """Store a simulation result in ``results/NAME`` and index it (the call for
        ``simulate --ws``).

        Args:
            result: a :class:`manipcad.sim.SimulationResult`.
            name: the result's name; None: ``result-YYYYMMDD-HHMMSS-XXXX`` (UTC).
            robot: a :class:`~manipcad.model.Robot` (saved in its tree form, which
                loads back identical), a workspace robot name, or a file.
            trajectory: a workspace trajectory name, a file or a trajectory object.
            regulators: workspace regulator names or files.
            run: the run's settings (``t_end`` s, ``dt`` s, ``every``, ``drives``,
                ``payload`` kg), recorded for ``rerun``.
            joint_types: per joint, for units (default: the robot's).
            force: replace a result of the same name.
            status, message: as :func:`manipcad.store.save_result`.
            plot: also write errors.png.

        Returns:
            The indexed :class:`Item`; its provenance names the workspace items used.

        Raises:
            InputError: name taken (without ``force``) or unsafe, an input not found.
        """

        if name is None:
            name = datetime.now(UTC).strftime("result-%Y%m%d-%H%M%S-") + secrets.token_hex(2)
        name = check_name(name, "--out")
        self.check_free("results", name, force)
        self._clean_leftovers("results")
        inputs: dict[str, Any] = {}
        if robot is not None:
            if hasattr(robot, "joint_types"):
                inputs["robot"] = robot        # saved in its tree form (store.save_result)
                if joint_types is None:
                    joint_types = robot.joint_types
            else:
                inputs["robot"] = self.find("robots", robot) or Path(robot)
                if joint_types is None:
                    joint_types = _joint_types(inputs["robot"])
        if trajectory is not None:
            inputs["trajectory"] = (self.find("trajectories", trajectory) or Path(trajectory)
                                    if isinstance(trajectory, str | Path) else trajectory)
        if regulators:
            inputs["regulator"] = [self.find("regulators", r) or Path(r) for r in regulators]
        run_doc = dict(run or {})
        folder = self.root / "results"

        staging = temp_dir(folder / name)
        shutil.rmtree(staging)
        save_result(result, staging, inputs=inputs, joint_types=joint_types,
                    status=status, message=message, run=run_doc, plot=plot, csv=False)
        try:
            facts = validate_item("results", staging)
            prov = self._result_provenance(staging)
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise
        meta = {"created": _now(), "manipcad_version": __version__,
                "source": "store_result", "provenance": prov}
        return self._commit("results", name, staging, folder / name, meta, facts, force)

    def _add_bundle(self, bundle: Path, *, force: bool) -> list[Item]:
        try:
            manifest = json.loads((bundle / BUNDLE_MANIFEST).read_text(encoding="utf-8"))
            entries = manifest["items"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise InputError(str(bundle / BUNDLE_MANIFEST), "", f"not a bundle manifest: "
                             f"{exc}") from None
        added = []
        # inputs first, results last: provenance then finds the names
        if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
            raise InputError(str(bundle / BUNDLE_MANIFEST), "items", "not a bundle manifest: "
                             "expected a list of items")
        order = sorted(entries, key=lambda e: KINDS.index(kind_of(e.get("kind", "?"),
                                                                  str(bundle))))
        paths = []
        for e in order:  # every item checked before any is added
            rel = Path(str(e.get("path", "")))
            if rel.is_absolute() or ".." in rel.parts:
                raise InputError(str(bundle / BUNDLE_MANIFEST), "path", f"{rel}: refused "
                                 "(outside the bundle)")
            p = bundle / rel
            if not inside(p, bundle):
                raise InputError(str(p), "", "points outside the bundle; refused")
            _check_bundle_hash(bundle, p, e, entries.index(e))
            paths.append(p)
        for e, p in zip(order, paths, strict=True):
            existing = self.index.query("SELECT hash FROM items WHERE kind = ? AND name = ?",
                                        (kind_of(e["kind"]), str(e.get("name"))))
            if existing and existing[0]["hash"] == content_hash(p) and not force:
                continue  # already here, identical
            added.append(self.add(p, kind=e["kind"], name=e.get("name"), force=force))
        return added

    # ------------------------------------------------------------------ removing
    def rm(self, ref: str, *, cascade: bool = False) -> list[Item]:
        """Remove an item (file, metadata and index row).

        Args:
            ref: ``kind/name`` or a name unique across kinds.
            cascade: also remove the results that depend on it.

        Returns:
            The items removed.

        Raises:
            InputError: no such item, or results depend on it (listed) without ``cascade``.
        """
        item = self.get(ref)
        deps = self.dependents(item)
        if deps and not cascade:
            raise InputError(item.ref, "", "stored results depend on it: " + ", ".join(
                d.name for d in deps) + "; remove them first or use --cascade")
        removed = []
        for it in [*deps, item]:
            with self.index.write() as db:
                db.execute("DELETE FROM items WHERE kind = ? AND name = ?", (it.kind, it.name))
                p = self._item_path(it.kind, it.path)
                if p.is_symlink():  # a result in the versioned layout: the link and its target
                    target = p.resolve()
                    p.unlink()
                    shutil.rmtree(target, ignore_errors=True)
                elif p.is_dir():
                    trash = p.parent / f".{p.name}.old-{os.getpid()}-{secrets.token_hex(4)}"
                    os.rename(p, trash)
                    shutil.rmtree(trash, ignore_errors=True)
                elif p.exists():
                    p.unlink()
                (self.root / META / it.kind / f"{it.name}.json").unlink(missing_ok=True)
            removed.append(it)
        return removed

    # ------------------------------------------------------------------ checking
    def _scan(self) -> Iterator[tuple[str, str, Path]]:
        """(kind, name, path) of every item file/folder on disk (hidden names skipped)."""
        for kind in KINDS:
            folder = self.root / kind
            if not folder.is_dir():
                continue
            for p in sorted(folder.iterdir()):
                if p.name.startswith("."):
                    continue
                if kind in FILE_KINDS:
                    if p.suffix.lower() not in _SUFFIXES:
                        continue
                    yield kind, p.stem if p.suffix else p.name, p
                else:
                    yield kind, p.name, p

    def check(self) -> list[Problem]:
        """Compare the index with the files.

        Returns:
            One :class:`Problem` per finding: "missing" (indexed, no file),
            "changed" (hash differs: the indexed and the current hash), "unindexed"
            (a file the index lacks), "outside" (a link leaving the workspace),
            "leftover" (a dead writer's temporary file or folder). Empty when clean.
        """

        problems: list[Problem] = []
        seen = set()
        for row in self.index.query("SELECT * FROM items ORDER BY kind, name"):
            kind, name = row["kind"], row["name"]
            seen.add((kind, name))
            p = self.root / row["path"]
            if not inside(p, self.root / kind):
                problems.append(Problem("outside", kind, name, f"{p} -> {p.resolve()}"))
                continue
            if not p.exists():
                problems.append(Problem("missing", kind, name, f"{row['path']} is gone"))
                continue
            now = content_hash(p)
            if now != row["hash"]:
                problems.append(Problem("changed", kind, name,
                                        f"indexed {row['hash'][:16]}, now {now[:16]}"))
        for kind, name, p in self._scan():
            if (kind, name) not in seen:
                what = "outside" if not inside(p, self.root / kind) else "unindexed"
                problems.append(Problem(what, kind, name, str(p.relative_to(self.root))))
        for kind in KINDS:
            for p, tag, alive in leftovers(self.root / kind):
                if not alive and not (tag == "v" and (self.root / kind).is_dir()
                                      and any(q.is_symlink() and q.resolve() == p.resolve()
                                              for q in (self.root / kind).iterdir())):
                    problems.append(Problem("leftover", kind, p.name, "of a dead writer; "
                                            "the next write or 'ws reindex' removes it"))
        return problems

    def reindex(self) -> dict[str, int]:
        """Rebuild the index from the files (one transaction; leftovers of dead
        writers removed first).

        Returns:
            {"items": count indexed, "skipped": count of files that do not load}
            and the skipped items' errors under "errors".
        """

        for kind in KINDS:
            if (self.root / kind).is_dir():
                clean_stale(self.root / kind)
        found = []
        errors = {}
        for kind, name, p in self._scan():
            if not inside(p, self.root / kind):
                errors[f"{kind}/{name}"] = "points outside the workspace"
                continue
            try:
                facts = validate_item(kind, p)
            except InputError as exc:
                errors[f"{kind}/{name}"] = str(exc)
                continue
            except ValueError as exc:
                errors[f"{kind}/{name}"] = str(exc)
                continue
            meta = self._read_meta(kind, name)
            if not meta:
                meta = {"created": datetime.fromtimestamp(p.stat().st_mtime, UTC)
                        .isoformat(timespec="seconds"), "manipcad_version": "unknown",
                        "source": "reindex"}
            found.append((kind, name, p, meta, facts))
        with self.index.write() as db:
            db.execute("DELETE FROM items")
            for kind, name, p, meta, facts in found:
                self._index_row(db, kind, name, p, meta, facts)
        return {"items": len(found), "skipped": len(errors), "errors": errors}

    # ------------------------------------------------------------------ sharing
    def export(self, ref: str, to: str | Path, *, csv: bool = True) -> Path:
        """Write a self-contained bundle of an item and the workspace items it depends on.

        The bundle ``TO/NAME/`` holds ``manipcad-bundle.json`` (the items, their
        hashes and provenance), the items in their kind folders and, for
        results, ``timeseries.csv`` (with units in the header). Another workspace
        takes it with ``ws add TO/NAME``.

        Returns:
            The bundle folder.

        Raises:
            InputError: no such item, or the bundle folder exists.
        """

        item = self.get(ref)
        out = Path(to) / item.name
        if out.exists():
            raise InputError(str(out), "", "exists; choose another --to folder")
        items = [item]
        for dep in _flat(item.provenance.get("inputs", {})):
            if dep.get("kind") and dep.get("name"):
                try:
                    items.append(self.get(f"{dep['kind']}/{dep['name']}"))
                except InputError:
                    pass
        tmp = temp_dir(out)
        try:
            entries = []
            for it in items:
                src = self.path(it)
                dst = tmp / it.kind / src.name
                dst.parent.mkdir(exist_ok=True)
                if src.is_dir():
                    shutil.copytree(src.resolve(), dst, ignore=shutil.ignore_patterns(".*"))
                    if it.kind == "results" and csv:
                        res, doc = load_result(src)
                        write_csv(res, dst / "timeseries.csv", joint_types=doc.get("joint_types"))
                else:
                    shutil.copyfile(src, dst)
                # the hash of what is exported (with the CSV added), checked on import
                entries.append({"kind": it.kind, "name": it.name,
                                "path": f"{it.kind}/{src.name}", "hash": content_hash(dst),
                                "created": it.created, "manipcad_version": it.manipcad_version,
                                "provenance": it.provenance})
            (tmp / BUNDLE_MANIFEST).write_text(json.dumps(json_safe(
                {"format": FORMAT, "exported": _now(), "manipcad_version": __version__,
                 "root": item.ref, "items": entries}), indent=2) + "\n", encoding="utf-8")
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        install_folder(tmp, out)
        return out


def _no_bundles_inside(folder: Path) -> None:
    """Refuse to file a folder as a study when it holds bundles made by ``ws export``
    (``ws export r1 --to share`` writes ``share/r1/``): the user meant to take the
    bundles, which ``ws add`` does given each bundle folder itself. ``--kind study``
    files the folder as a study all the same.

    Raises:
        InputError: naming the bundle folders found and the command that takes them.
    """
    found = []
    for dirpath, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        if BUNDLE_MANIFEST in files:
            found.append(Path(dirpath))
            dirs[:] = []                       # a bundle's own folders are its items
    if found:
        shown = ", ".join(str(p) for p in found[:3]) + (" ..." if len(found) > 3 else "")
        take = "; ".join(f"manipcad ws add {shlex.quote(str(p))}" for p in found[:3])
        raise InputError(str(folder), "", f"holds {len(found)} workspace bundle(s) made by "
                         f"'ws export' ({shown}), not a study; take a bundle with: {take} "
                         "(or file the folder as a study with --kind study)")


def _check_bundle_hash(bundle: Path, p: Path, entry: Mapping[str, Any], k: int) -> None:
    """Refuse a bundle item whose content is not what its manifest's SHA-256 says (a file
    changed, added or removed after the export). A result exported by an earlier
    manipcad recorded its hash without the ``timeseries.csv`` the export adds."""
    want = entry.get("hash")
    where = f"items[{k}].hash"
    if not isinstance(want, str) or not re.fullmatch(r"[0-9a-f]{64}", want):
        raise InputError(str(bundle / BUNDLE_MANIFEST), where, f"expected the item's SHA-256 "
                         f"(64 hex digits), got {want!r}")
    if not (p.exists() or p.is_symlink()):
        raise InputError(str(p), "", "listed in the bundle manifest but missing")
    got = content_hash(p)
    if got == want:
        return
    if p.is_dir() and content_hash(p, skip={"timeseries.csv"}) == want:
        return
    raise InputError(str(p), "", f"changed since the bundle was exported: its SHA-256 is "
                     f"{got[:16]}..., the manifest ({where}) says {want[:16]}...; refused "
                     "(nothing imported)")


def _robot_quiet(robot_file: Path):
    """A robot file's robot (its data warnings are the loader's business, shown at add)."""


    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return load_robot(robot_file)


def _joint_types(robot_file: Path) -> tuple[str, ...]:
    """The joint types of a robot file."""
    return _robot_quiet(robot_file).joint_types


def _references_files(robot_file: Path) -> bool:
    """Whether a robot YAML file names other files (``urdf:``, motor or gear paths:
    :func:`manipcad.model.load.referenced_files`)."""

    return robot_file.suffix.lower() in (".yaml", ".yml") and bool(
        referenced_files(robot_file))


def _no_links_out(src: Path) -> None:
    """Refuse a folder holding links that point outside it (or a file link)."""
    if src.is_file():
        return
    for dirpath, dirs, files in os.walk(src):
        for n in dirs + files:
            p = Path(dirpath) / n
            if p.is_symlink() and not inside(p, src):
                raise InputError(str(p), "", "a link pointing outside the folder; refused")


def _flat(inputs: Mapping[str, Any]) -> list[dict[str, Any]]:
    out = []
    for v in inputs.values():
        out.extend(v if isinstance(v, list) else [v])
    return [d for d in out if isinstance(d, dict)]


def catalog_items(kind: str | None = None) -> ItemList:
    """The built-in catalog's robots, motors and gears as read-only items.

    Args:
        kind: robots, motors or gears (singular too); None for all three.

    Returns:
        Items with ``source`` "catalog (read-only)", ``path`` "catalog/KIND/FILE"
        and the file's SHA-256; ``created`` is empty.

    Example:
        >>> [i.name for i in catalog_items("gear")][:2]
        ['ballscrew_d16_p10_l800', 'belt_at5_z20_omega']
    """

    kinds = ("robots", "motors", "gears") if kind is None else (kind_of(kind),)
    out = ItemList()
    for k in kinds:
        folder = (CATALOG / k if k == "robots" else PARTS / k
                  if k in ("motors", "gears") else None)
        if folder is None or not folder.is_dir():
            continue
        for entry in sorted(folder.iterdir(), key=lambda e: e.name):
            if not entry.name.endswith((".yaml", ".urdf")):
                continue

            digest = hashlib.sha256(entry.read_bytes()).hexdigest()
            out.append(Item(kind=k, name=entry.name.rsplit(".", 1)[0],
                            path=f"catalog/{k}/{entry.name}", hash=digest, created="",
                            manipcad_version=__version__, source="catalog (read-only)"))
    return out


def resolve_input(kind: str, arg: str | Path, ws: Workspace | str | Path | None = None) -> str:
    """What a command's input argument means: an existing file as it is, else a
    workspace item's file (when a workspace is given or found by default), else
    the argument unchanged (a catalog name for the loaders).

    Example:
        >>> resolve_input("robot", "puma560", ws=None)
        'puma560'
    """
    text = str(arg)
    if Path(text).exists():
        return text
    if ws is None:
        root = default_root(None)
        if not (root / MARKER).is_file():
            return text
        ws = root
    w = ws if isinstance(ws, Workspace) else Workspace(ws)
    found = w.find(kind, text)
    return str(found) if found is not None else text
