"""Every docstring example runs: none is skipped whole (pytest would report it as a skipped
test, and a skip on a path that should run hides a broken example)."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import manipcad

# every module of the package but ``__main__`` (which runs the CLI when imported)
MODULES = sorted(m.name for m in pkgutil.walk_packages(manipcad.__path__, "manipcad.")
                 if not m.name.endswith("__main__"))


def skipped_whole() -> list[str]:
    """The docstrings whose every example carries ``doctest: +SKIP``."""
    finder = doctest.DocTestFinder(exclude_empty=True)
    bad = []
    for name in MODULES:
        for test in finder.find(importlib.import_module(name)):
            if test.examples and all(ex.options.get(doctest.SKIP) for ex in test.examples):
                bad.append(test.name)
    return bad


def test_no_docstring_example_is_skipped_whole():
    assert len(MODULES) > 50
    assert skipped_whole() == []


def test_the_check_sees_a_docstring_skipped_whole(monkeypatch):
    import types

    mod = types.ModuleType("manipcad._skipped_example")
    exec('def f():\n    """Example:\n        >>> 1  # doctest: +SKIP\n        1\n    """\n',
         mod.__dict__)
    import sys

    monkeypatch.setitem(sys.modules, mod.__name__, mod)
    monkeypatch.setattr(__import__(__name__), "MODULES", [mod.__name__])
    assert skipped_whole() == ["manipcad._skipped_example.f"]
