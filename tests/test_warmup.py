"""manipcad warmup / ensure_warm: the once-only compile steps, their markers and coverage.

The real steps compile every kernel (minutes on a cold cache), so the marker tests swap
in quick fake steps and a temporary cache folder. The coverage test runs the real steps
in a fresh process on the suite's kernel cache (warm after the suite's prewarm, which
runs the same steps) and then every integrator on another robot: nothing may compile.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from manipcad.cli import app
from manipcad.cli import warmup as wu
from manipcad.sim import warm
from manipcad.sim.integrate import INTEGRATORS


@pytest.fixture
def fake(monkeypatch, tmp_path):
    calls: list[str] = []

    def ok(name):
        return lambda: calls.append(name)

    def broken():
        calls.append("broken")
        raise RuntimeError("no compiler")

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("MANIPCAD_COMPILE_WORKERS", "1")  # the fakes exist in this process only
    steps = {"a": ("step a", ok("a")), "b": ("step b", ok("b")), "c": ("step c", broken)}
    monkeypatch.setattr(warm, "STEPS", steps)
    monkeypatch.setattr(wu, "STEPS", steps)
    monkeypatch.setattr(warm, "PHASES", (("a", "c"), ("b",)))
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
    assert calls == ["a", "broken", "b"]                 # phase by phase


def test_two_workers_share_the_steps(tmp_path):
    """Two processes on one empty folder: each step runs once, in the phases' order."""
    script = f"""
import os, sys, time
from manipcad.sim import warm
log = open({str(tmp_path / 'log')!r}, 'a')
def step(name):
    def run():
        log.write(f"{{sys.argv[1]}} {{name}} start\\n"); log.flush()
        time.sleep(0.3)
        log.write(f"{{sys.argv[1]}} {{name}} end\\n"); log.flush()
    return run
warm.STEPS = {{n: (n, step(n)) for n in "abcd"}}
warm.PHASES = (("a", "b", "c"), ("d",))
open({str(tmp_path / 'ready')!r} + sys.argv[1], 'w').close()   # both started: then share
while not all(os.path.exists({str(tmp_path / 'ready')!r} + w) for w in "01"):
    time.sleep(0.01)
assert warm.share(int(sys.argv[1]), 2) == []
"""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    procs = [subprocess.Popen([sys.executable, "-c", script, str(w)], env=env)
             for w in range(2)]
    assert [p.wait(timeout=60) for p in procs] == [0, 0]
    lines = (tmp_path / "log").read_text().split("\n")[:-1]
    starts = [ln.split()[1] for ln in lines if ln.endswith("start")]
    assert sorted(starts) == ["a", "b", "c", "d"]        # each step once
    assert {ln.split()[0] for ln in lines} == {"0", "1"}  # both workers took steps
    # d (phase 2) starts after every step of phase 1 has ended
    assert lines.index(next(ln for ln in lines if ln.endswith("d start"))) > max(
        i for i, ln in enumerate(lines) if ln.endswith("end") and ln.split()[1] != "d")


def test_every_integrator_has_a_core_step():
    """The steps cover the integrators' registry: each integrator's core is a step that
    ``manipcad warmup`` (all steps) runs, and a simulation's needs include it."""
    assert set(warm.CORES) == set(INTEGRATORS)
    for integrator, core in warm.CORES.items():
        assert core in warm.STEPS and core in warm.needs(integrator)
    assert set(sum(warm.PHASES, ())) == set(warm.STEPS)


COVERAGE = r"""
import json, sys, warnings
import numpy as np
from numba.core import event
from numba.core.registry import CPUDispatcher
import gc
from manipcad.sim import warm
for what, step in warm.STEPS.values():   # as `manipcad warmup --force`: load, or compile
    step()
def loaded():
    return {(d.py_func.__module__ + "." + d.py_func.__qualname__, str(sig))
            for d in gc.get_objects() if type(d) is CPUDispatcher for sig in d.overloads}
before = loaded()
compiled = []
class Listener(event.Listener):
    def on_start(self, ev):
        d = ev.data["dispatcher"]
        compiled.append(f"{d.py_func.__module__}.{d.py_func.__qualname__}{ev.data['args']}")
    def on_end(self, ev):
        pass
event.register("numba:compile", Listener())
import manipcad
from manipcad.control.files import load_regulators
from manipcad.trajectories import quintic
warnings.simplefilter("ignore")
arm = manipcad.load_robot("puma560")           # 6 joints, dry friction: the events run
regs = load_regulators("examples/pid_puma.yaml", arm, dt=1e-4)
q0 = np.zeros(arm.n)
for integrator in sys.argv[1:]:
    res = manipcad.simulate(arm, t_end=0.01, dt=1e-4, regulators=regs, integrator=integrator,
                            use_generated=False,  # per-robot code: `manipcad codegen`
                            trajectory=quintic(q0, q0 + 0.05, 0.01))
    assert np.isfinite(res.q).all()
new = sorted(" ".join(k) for k in loaded() - before)
print(json.dumps({"compiled": compiled, "new": new}))
"""


def test_warmup_leaves_nothing_to_compile_for_any_integrator():
    """After the warm-up steps, a fresh process runs every integrator (PUMA 560 with its
    drives, dry friction and a PID from a file) without numba compiling or loading any
    specialization the steps did not (numba's compile events, and the dispatchers'
    specializations before and after)."""
    res = subprocess.run([sys.executable, "-c", COVERAGE, *INTEGRATORS], capture_output=True,
                         text=True, timeout=900, cwd=os.path.dirname(os.path.dirname(__file__)))
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads(res.stdout.strip().splitlines()[-1])
    assert out == {"compiled": [], "new": []}
