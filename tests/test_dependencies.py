"""The dependency bounds of pyproject.toml are the ones the suite runs with.

Every dependency (and every test dependency) has a floor and a ceiling; the
packages this suite runs on lie within them; and the newest versions the bounds
allow, as pip resolves them for a fresh environment from the package index, are
the release lines installed here: so ``pip install -e ".[test]"`` on a new machine
gets what this suite passes with, and the README's commands (``manipcad demo``,
``python -m pytest``) run on it.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.version import Version

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def _requirements() -> list[Requirement]:
    project = tomllib.loads(PYPROJECT.read_text())["project"]
    return [Requirement(r) for r in
            project["dependencies"] + project["optional-dependencies"]["test"]]


def _line(v: str) -> tuple[int, ...]:
    """The release line: major.minor."""
    return Version(v).release[:2]


def test_every_dependency_has_a_floor_and_a_ceiling():
    for req in _requirements():
        ops = {s.operator for s in req.specifier}
        assert ">=" in ops and "<" in ops, f"{req}: wants a floor (>=) and a ceiling (<)"


def test_the_installed_packages_lie_within_the_bounds():
    for req in _requirements():
        try:
            have = version(req.name)
        except PackageNotFoundError:
            pytest.fail(f"{req.name} is not installed: pip install -e '.[test]'")
        assert req.specifier.contains(have, prereleases=True), f"{req.name} {have} not in {req}"


@pytest.mark.slow
def test_the_newest_allowed_versions_are_the_ones_tested_here(tmp_path):
    """pip's resolution for a fresh environment (``--ignore-installed``; ``--no-deps``
    keeps it to our own requirements, about 25 s): each resolves to the release line
    installed here."""
    reqs = _requirements()
    report = tmp_path / "report.json"
    run = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--dry-run", "--ignore-installed",
         "--no-deps", "--quiet", "--disable-pip-version-check", "--report", str(report),
         *map(str, reqs)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    resolved = {item["metadata"]["name"].lower().replace("_", "-"): item["metadata"]["version"]
                for item in json.loads(report.read_text())["install"]}
    for req in reqs:
        new = resolved[req.name.lower().replace("_", "-")]
        assert req.specifier.contains(new, prereleases=True)
        assert _line(new) == _line(version(req.name)), (
            f"{req.name}: the newest allowed is {new}, the suite ran with "
            f"{version(req.name)}: run it with {new}, then move the bounds")
