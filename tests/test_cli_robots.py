"""``manipcad robots list|show``: tables, JSON, and exit status 2 without a traceback."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from manipcad.cli import app

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[1]


def run(*args: str):
    return runner.invoke(app, ["robots", *args], env={"COLUMNS": "200"})


def good_doc() -> dict:
    return {"name": "cli arm", "joints": [
        {"name": "j1", "type": "revolute", "dh": {"alpha": "pi/2"},
         "link": {"mass": 1.0, "com": [0.1, 0, 0]},
         "drive": {"motor": "maxon_re40_148877", "gear": "harmonic_csf17_100"}},
        {"name": "j2", "type": "prismatic", "dh": {"a": 0.3}, "limits": [0, 0.4],
         "link": {"mass": 0.5}},
    ]}


def test_list_shows_robots_motors_gears():
    res = run("list")
    assert res.exit_code == 0, res.output
    for name in ("puma560", "cylindrical", "scara", "stanford", "maxon_re40_148877",
                 "maxon_re25_118743", "harmonic_csf20_100", "maxon_gp42c_43"):
        assert name in res.output


def test_show_catalog_robot_table():
    res = run("show", "puma560")
    assert res.exit_code == 0, res.output
    for word in ("PUMA 560", "waist", "flange", "total mass 23.45 kg", "-62.611",
                 "drives on 6 of 6 joints", "triangle inequality"):
        assert word in res.output, res.output


def test_show_file_table(tmp_path):
    path = tmp_path / "arm.yaml"
    path.write_text(yaml.safe_dump(good_doc()))
    res = run("show", str(path))
    assert res.exit_code == 0, res.output
    assert "cli arm" in res.output and "maxon_re40_148877 + harmonic_csf17_100" in res.output
    assert "0..0.4 m" in res.output and "total mass 1.5 kg" in res.output


def test_show_json():
    res = run("show", "cylindrical", "--json")
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    assert data["n"] == 3 and data["total_mass"] == pytest.approx(35.4)
    j = data["joints"]
    assert [x["type"] for x in j] == ["revolute", "prismatic", "prismatic"]
    assert j[0]["parent"] == "base" and j[1]["parent"] == "turn"
    assert j[0]["drive"]["ratio"] == -100 and j[0]["drive"]["motor"] == "maxon_re40_148877"
    assert j[0]["limits"][1] == pytest.approx(170 * 3.141592653589793 / 180)
    assert data["warnings"] == []


def test_show_json_puma_has_warnings_and_nulls():
    data = json.loads(run("show", "stanford", "--json").output)
    assert any("joints[4].link.inertia" in w for w in data["warnings"])
    assert data["joints"][0]["drive"]["R"] is None  # unknown (nan) becomes null


@pytest.mark.parametrize("text, words", [
    ("name: x\njoints: [\n", ["YAML syntax error", "line"]),
    (yaml.safe_dump({"name": "x", "joints": [{"name": "a", "type": "revolute",
                                              "link": {"mass": -2}}]}),
     ["joints[0].link.mass", "mass must be >= 0"]),
    (yaml.safe_dump({"name": "x", "joints": [{"name": "a", "type": "screw",
                                              "link": {"mass": 2}}]}),
     ["joints[0].type", "unknown value 'screw'"]),
    (yaml.safe_dump({"name": "x", "joints": [{"name": "a", "type": "revolute",
                                              "link": {"mass": 1, "inertia": {"ixx": -1}}}]}),
     ["joints[0].link.inertia", "not positive semi-definite"]),
])
def test_show_bad_file_exits_2_without_traceback(tmp_path, text, words):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    res = run("show", str(path))
    assert res.exit_code == 2
    out = res.output + (res.stderr or "")
    assert "Traceback" not in out
    assert str(path) in out.replace("\n", "")
    for w in words:
        assert w in out, out


def test_show_unknown_name_exits_2():
    res = run("show", "no_such_robot")
    assert res.exit_code == 2
    assert "not a file and not a catalog robot" in (res.output + (res.stderr or ""))


def test_subprocess_bad_file_one_line_on_stderr(tmp_path):
    """The real command: status 2, one error line on stderr, nothing on stdout."""
    path = tmp_path / "bad.yaml"
    path.write_text("name: x\njoints:\n  - name: a\n    type: revolute\n    link: {mass: -1}\n")
    proc = subprocess.run([sys.executable, "-m", "manipcad", "robots", "show", str(path)],
                          capture_output=True, text=True, timeout=300, cwd=ROOT,
                          env={"COLUMNS": "400", "PATH": "/usr/bin:/bin"})
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout
    assert proc.stdout == ""
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr
    assert "joints[0].link.mass" in lines[0] and "bad.yaml" in lines[0]
