"""The import graph of src/manipcad has no circle.

Every module is a node; an arrow A -> B for every import of B in A, wherever it
stands (at the top, or inside a function: a deferred import still ties the two
modules), except under ``if TYPE_CHECKING:``. ``from P import X`` is an arrow to
the module ``P.X`` when X is one, else to ``P``. In a module that imports by name
(``importlib.import_module``, as the method registry loads its method modules), a
string that is the dotted name of a module of the package counts as an arrow too.
A circle is a strongly connected set of two modules or more.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import manipcad

ROOT = Path(manipcad.__file__).parent


def _modules() -> dict[str, Path]:
    mods = {}
    for py in ROOT.rglob("*.py"):
        parts = list(py.relative_to(ROOT.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        mods[".".join(parts)] = py
    return mods


def _targets(name: str, path: Path, node: ast.AST, mods: dict[str, Path]) -> list[str]:
    if isinstance(node, ast.Import):
        wanted = [a.name for a in node.names]
    else:
        base = node.module or ""
        if node.level:
            here = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
            here = here[:len(here) - (node.level - 1)]
            base = ".".join(here + ([base] if base else []))
        wanted = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base
                  for a in node.names]
    out = []
    for t in wanted:
        while t not in mods and "." in t:
            t = t.rsplit(".", 1)[0]
        if t in mods:
            out.append(t)
    return out


def import_graph() -> dict[str, set[str]]:
    """Module -> the modules of the package it imports (see the module docstring)."""
    mods = _modules()
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for name, path in mods.items():
        text = path.read_text(encoding="utf-8")
        tree = ast.parse(text)
        by_name = "import_module(" in text
        typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
                       and "TYPE_CHECKING" in ast.unparse(block.test)
                       for n in ast.walk(block)}
        for node in ast.walk(tree):
            if id(node) in typing_only:
                continue
            if isinstance(node, ast.Import | ast.ImportFrom):
                graph[name].update(_targets(name, path, node, mods))
            elif (by_name and isinstance(node, ast.Constant) and isinstance(node.value, str)
                  and "." in node.value and node.value in mods):
                graph[name].add(node.value)
        graph[name].discard(name)
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected sets of two modules or more (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found = []
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on.add(start)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    found.append(sorted(comp))
    return found


def test_the_checker_finds_a_circle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert circles(graph) == [["a", "b", "c"]]
    assert circles({"a": {"b"}, "b": set()}) == []


def test_the_graph_reads_deferred_and_by_name_imports():
    graph = import_graph()
    # a deferred import (inside a function) and a module the registry loads by name
    assert "manipcad.control.pid" in graph["manipcad.control.registry"]
    assert "manipcad.model.robot" in graph["manipcad.model.tree_file"]
    assert "manipcad.version" in graph["manipcad"]


def test_no_import_circle_in_the_package():
    found = circles(import_graph())
    assert not found, "import circles:\n" + "\n".join(" <-> ".join(c) for c in found)


# ------------------------------------------------------------- imports inside functions

#: the mark of a function-level import's reason, on its line or the line above its group
REASON = re.compile(r"#\s*deferred:\s*\S")


def unexplained_deferred_imports(text: str) -> list[int]:
    """The lines of the imports made inside a function without a stated reason.

    An import inside a function says why it is not at the top of the module: a comment
    ``# deferred: <reason>`` (an optional dependency, a measured start-up cost, ...) on
    its first line, or above it in the run of imports it belongs to (or just above the run).
    """
    tree = ast.parse(text)
    lines = text.splitlines()
    bad = []
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for block in ast.walk(fn):
            for field in ("body", "orelse", "finalbody", "handlers"):
                body = getattr(block, field, None)
                if not isinstance(body, list):
                    continue
                run_start = None
                for st in body:
                    if not isinstance(st, ast.Import | ast.ImportFrom):
                        run_start = None
                        continue
                    if run_start is None:
                        run_start = st.lineno
                    # its own line, the lines of its run above it, the line above the run
                    marks = lines[max(run_start - 2, 0):st.lineno]
                    if not any(REASON.search(m) for m in marks):
                        bad.append(st.lineno)
    return sorted(set(bad))


def test_the_reason_checker_can_fail():
    text = ("def f():\n"
            "    import json\n"
            "    # deferred: start-up cost\n"
            "    import csv\n"
            "    import zlib\n"
            "    x = 1\n"
            "    import gzip  # deferred: optional dependency\n"
            "    import bz2\n")
    assert unexplained_deferred_imports(text) == [2]
    assert unexplained_deferred_imports("import json\n\ndef f():\n    return json\n") == []


def test_every_import_inside_a_function_states_why():
    bad = {}
    for name, path in _modules().items():
        lines = unexplained_deferred_imports(path.read_text(encoding="utf-8"))
        if lines:
            bad[name] = lines
    assert not bad, ("imports inside functions without a '# deferred: <reason>' comment "
                     "(move them to the top, or say why not):\n"
                     + "\n".join(f"{m}: lines {v}" for m, v in sorted(bad.items())))
