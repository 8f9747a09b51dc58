"""The workspace's SQLite index: derived from the files, rebuildable, safe for concurrent writers.

Schema (``index.sqlite``; docs/workspace.md)::

    meta(key TEXT PRIMARY KEY, value TEXT)                 schema version
    items(id INTEGER PRIMARY KEY, kind, name, path, hash, created, manipcad_version,
          source, provenance (JSON), status, UNIQUE(kind, name))
    deps(item_id -> items.id ON DELETE CASCADE, role, kind, name, hash)
    metrics(item_id -> items.id ON DELETE CASCADE, joint, metric, value REAL,
            PRIMARY KEY(item_id, joint, metric))

The database runs in WAL mode (readers never block the writer); every change
is one ``BEGIN IMMEDIATE`` transaction, so two writer processes queue (up to
``timeout`` seconds) instead of losing a row.
"""

from __future__ import annotations

import contextlib
import sqlite3
from collections.abc import Iterator
from pathlib import Path

from manipcad.errors import InputError

SCHEMA_VERSION = "1"

SCHEMA = """
CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS items(
    id INTEGER PRIMARY KEY,
    kind TEXT NOT NULL,
    name TEXT NOT NULL,
    path TEXT NOT NULL,
    hash TEXT NOT NULL,
    created TEXT NOT NULL,
    manipcad_version TEXT NOT NULL,
    source TEXT NOT NULL DEFAULT '',
    provenance TEXT NOT NULL DEFAULT '{}',
    status TEXT,
    UNIQUE(kind, name));
CREATE TABLE IF NOT EXISTS deps(
    item_id INTEGER NOT NULL REFERENCES items(id) ON DELETE CASCADE,
    role TEXT NOT NULL,
    kind TEXT,
    name TEXT,
    hash TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS deps_target ON deps(kind, name);
CREATE TABLE IF NOT EXISTS metrics(
    item_id INTEGER NOT NULL REFERENCES items(id) ON DELETE CASCADE,
    joint TEXT NOT NULL,
    metric TEXT NOT NULL,
    value REAL NOT NULL,
    PRIMARY KEY(item_id, joint, metric));
"""


class Index:
    """A connection to a workspace index (one per :class:`Workspace` object).

    Args:
        path: the ``index.sqlite`` file (created if missing).
        timeout: seconds a writer waits for another writer's transaction.
    """

    def __init__(self, path: str | Path, timeout: float = 60.0) -> None:
        self.path = Path(path)
        try:
            self.db = sqlite3.connect(str(self.path), timeout=timeout, isolation_level=None)
            self.db.row_factory = sqlite3.Row
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=NORMAL")
            self.db.execute("PRAGMA foreign_keys=ON")
            with self.write():
                for stmt in SCHEMA.split(";"):
                    if stmt.strip():
                        self.db.execute(stmt)
                self.db.execute("INSERT OR IGNORE INTO meta(key, value) VALUES('schema', ?)",
                                (SCHEMA_VERSION,))
        except sqlite3.DatabaseError as exc:
            raise InputError(str(self.path), "", f"not a usable index ({exc}); "
                             "'manipcad ws reindex' rebuilds it") from None

    @contextlib.contextmanager
    def write(self) -> Iterator[sqlite3.Connection]:
        """One write transaction (BEGIN IMMEDIATE ... COMMIT; ROLLBACK on any error)."""
        self.db.execute("BEGIN IMMEDIATE")
        try:
            yield self.db
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        self.db.execute("COMMIT")

    def query(self, sql: str, params: tuple | list = ()) -> list[sqlite3.Row]:
        """Rows of a read-only query."""
        return self.db.execute(sql, params).fetchall()

    def close(self) -> None:
        """Close the connection."""
        self.db.close()
