"""manipcad warmup / ensure_warm: the once-only compile step and its markers.

The real steps compile every kernel (minutes on a cold cache), so these tests
swap in quick fake steps and a temporary cache folder; the real steps run in
every other test that touches a kernel.
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from manipcad.cli import app
from manipcad.cli import warmup as wu


@pytest.fixture
def fake(monkeypatch, tmp_path):
    calls: list[str] = []

    def ok(name):
        return lambda: calls.append(name)

    def broken():
        calls.append("broken")
        raise RuntimeError("no compiler")

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(wu, "STEPS", {"a": ("step a", ok("a")), "b": ("step b", ok("b")),
                                      "c": ("step c", broken)})
    return calls, tmp_path


def test_ensure_warm_runs_cold_steps_once(fake, capsys):
    calls, folder = fake
    wu.ensure_warm("a")
    assert calls == ["a"] and (folder / "warm-a").is_file()
    assert "compiling kernels (once" in capsys.readouterr().err
    wu.ensure_warm("a")                                  # warm: nothing runs, nothing printed
    assert calls == ["a"] and capsys.readouterr().err == ""
    wu.ensure_warm("a", "b")                             # only the cold one runs
    assert calls == ["a", "b"]


def test_failed_step_is_reported_and_stays_cold(fake, capsys):
    calls, folder = fake
    wu.ensure_warm("c", "a")
    err = capsys.readouterr().err
    assert "warmup step failed" in err and "no compiler" in err
    assert not (folder / "warm-c").exists() and (folder / "warm-a").is_file()
    wu.ensure_warm("c")
    assert calls.count("broken") == 2                    # tried again next time


def test_cli_warmup_exit_status(fake):
    calls, folder = fake
    res = CliRunner().invoke(app, ["warmup"])
    assert res.exit_code == 1 and "2 of 3 steps" in res.stdout
    assert (folder / "warm-a").is_file() and (folder / "warm-b").is_file()
