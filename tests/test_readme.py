"""The README's two commands: the ones CI runs, and the first one works.

The README opens with the two commands a new user types: install and run the demo,
install the test extra and run the suite. CI (``.ci/run``) runs the second one verbatim
on a fresh clone in a fresh environment, where pip takes the newest versions the bounds
of pyproject.toml allow (tests/test_dependencies.py holds those to the release lines
this suite passes with); here the first one, ``manipcad demo``, runs through the
installed console script as a user runs it.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _readme_commands() -> list[str]:
    block = re.search(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert block, "README.md has no bash block"
    return [ln.strip() for ln in block.group(1).splitlines() if ln.strip()]


def test_the_readme_opens_with_the_two_commands_ci_runs():
    install_demo, install_test = _readme_commands()
    assert install_demo == "pip install -e . && manipcad demo"
    assert install_test == 'pip install -e ".[test]" && python -m pytest -n auto'
    ci = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert install_test in ci, ".ci/run must run the README's test command verbatim"


@pytest.mark.slow
def test_manipcad_demo_runs_as_the_readme_says(tmp_path):
    """``manipcad demo`` (the console script pip installed beside this Python) prints the
    torque constituents and writes the Fig. 3 study's figure, JSON and report under
    ./manipcad-demo/fig3/ of the directory it is run in."""
    exe = shutil.which("manipcad", path=str(Path(sys.executable).parent)) or shutil.which(
        "manipcad")
    assert exe, "the manipcad console script is not installed: pip install -e ."
    env = {**os.environ, "COLUMNS": "120"}
    run = subprocess.run([exe, "demo"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=600, env=env)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    fig3 = tmp_path / "manipcad-demo" / "fig3"
    for name in ("fig3.png", "fig3.json", "report.html"):
        assert (fig3 / name).stat().st_size > 0, name
    assert "Fig. 3" in run.stdout and "ace_de" in run.stdout
    assert "Traceback" not in run.stderr
