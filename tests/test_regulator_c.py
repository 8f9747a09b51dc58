"""C99 regulator updates translated from the numba laws (manipcad.control.c_code): compiled
with the system C compiler (-Werror, one compile for the module) and compared with the
numba law the simulator runs, on random signals and states over several periods."""

from __future__ import annotations

import ctypes
import math
import shutil
import subprocess

import numpy as np
import pytest
from typer.testing import CliRunner

import manipcad
from manipcad.cli.app import app
from manipcad.control import synthesize
from manipcad.control.c_code import regulator_name, regulators_c
from manipcad.control.registry import METHODS, method
from manipcad.control.signals import NSIG, NSTATE, S_HII, S_I
from manipcad.errors import ManipcadError

# (label, method, joint, options): every method of the registry; ace_tf in both realizations
CASES = [
    ("none", "none", "turn", {}),
    ("none_sce", "none_sce", "turn", {}),
    ("pid", "pid", "lift", {}),
    ("computed_torque", "computed_torque", "turn", {}),
    ("ace_tf_obs", "ace_tf", "turn", {"realization": "observable"}),
    ("ace_tf_ctl", "ace_tf", "turn", {"realization": "controllable"}),
    ("ace_de", "ace_de", "turn", {}),
    ("vss", "vss", "turn", {}),
    ("asvs", "asvs", "turn", {}),
    ("lqr", "lqr", "turn", {}),
    ("lqr_gs", "lqr_gs", "turn", {"h_range": (-5.0, 5.0), "grid": (6, 3)}),
    ("computed_torque_full", "computed_torque_full", "all", {}),
]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """Every case's C (and a file through the CLI) compiled into one shared library."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.fail("no system C compiler (cc or gcc) to compile the generated code")
    arm = manipcad.load_robot("cylindrical")
    d = tmp_path_factory.mktemp("regc")
    regs, sources = {}, []
    for label, m, joint, opts in CASES:
        reg = synthesize(arm, joint, m, period=1e-3, **opts)
        regs[label] = reg
        h, c = regulators_c([reg], arm, label, source=label)
        (d / f"{label}_regulators.h").write_text(h)
        (d / f"{label}_regulators.c").write_text(c)
        sources.append(str(d / f"{label}_regulators.c"))
    # a regulator file with one method per joint, through the CLI
    mixed = [synthesize(arm, "turn", "ace_de", period=1e-3),
             synthesize(arm, "lift", "asvs", period=1e-3),
             synthesize(arm, "reach", "lqr_gs", period=1e-3, grid=(4, 1))]
    manipcad.save_regulators(mixed, d / "reg.yaml", robot=arm)
    res = CliRunner().invoke(app, ["codegen", "cylindrical", "--lang", "c", "--regulators",
                                   str(d / "reg.yaml"), "--out", str(d / "cli"),
                                   "--prefix", "cyl"])
    assert res.exit_code == 0, res.output
    sources += [str(d / "cli" / "cyl_regulators.c"), str(d / "cli" / "cyl.c")]
    lib = d / "libregs.so"
    run = subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-pedantic", "-Werror",
                          "-shared", "-fPIC", "-I", str(d / "cli"), "-o", str(lib), *sources,
                          "-lm"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[:4000]
    return arm, regs, mixed, ctypes.CDLL(str(lib)), d


_P = ctypes.POINTER(ctypes.c_double)


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(_P)


def _signals(rng, n):
    sig = rng.uniform(-2.0, 2.0, (n, NSIG))
    sig[:, S_HII] = rng.uniform(0.05, 3.0, n)  # a positive inertia, kg·m²
    sig[:, S_I] = rng.uniform(-5.0, 5.0, n)
    return sig


def _close(a, b) -> bool:
    return a == b or abs(a - b) <= 1e-12 * max(abs(a), abs(b))


def _compare(arm, reg, lib, name, seed, random_state: bool, steps: int = 8):
    """Run the numba law and the C side by side; returns the number of values compared."""
    rng = np.random.default_rng(seed)
    m = method(reg.method)
    p = np.asarray(reg.params, dtype=float)
    s_py = rng.uniform(-1.0, 1.0, NSTATE) if random_state else np.zeros(NSTATE)
    s_c = s_py.copy()
    n = arm.n
    fn = getattr(lib, f"{name}_update")
    compared = 0
    for _ in range(steps):
        sig = _signals(rng, n)
        if m.spans:
            A = rng.uniform(-0.3, 0.3, (n, n))
            H = A @ A.T + np.diag(rng.uniform(0.1, 2.0, n))
            joints = np.array(reg.joints, dtype=np.int64)
            U_py = np.zeros(n)
            U_c = np.zeros(n)
            m.update(p, s_py, sig, H, joints, len(joints), reg.period, U_py)
            fn.restype = None
            fn(_ptr(np.ascontiguousarray(sig)), _ptr(H), _ptr(s_c), _ptr(U_c))
            outs = list(zip(U_py, U_c, strict=True))
        else:
            j = reg.joints[0]
            u_py = m.update(p, s_py, sig, j, reg.period)
            fn.restype = ctypes.c_double
            row = np.ascontiguousarray(sig[j])
            u_c = fn(_ptr(row), _ptr(s_c))
            outs = [(float(u_py), u_c)]
        outs += list(zip(s_py, s_c, strict=True))
        for a, b in outs:
            assert _close(a, b), (reg.method, a, b)
            assert math.isfinite(b) or not math.isfinite(a)
        compared += len(outs)
    return compared


@pytest.mark.parametrize("label", [c[0] for c in CASES])
def test_c_update_equals_the_numba_law(built, label):
    arm, regs, _, lib, _ = built
    reg = regs[label]
    name = regulator_name(reg, arm, label)
    for seed, random_state in ((1, False), (2, True), (3, True)):
        assert _compare(arm, reg, lib, name, seed, random_state) > 8


def test_every_registry_method_is_covered():
    assert {c[1] for c in CASES} == set(METHODS)


def test_cli_file_regulators_and_static_state(built):
    arm, _, mixed, lib, d = built
    h = (d / "cli" / "cyl_regulators.h").read_text()
    for name in ("cyl_turn_update", "cyl_lift_step", "cyl_reach_reset", "cyl_regulators_reset",
                 "extern const double cyl_turn_params[256]", "#define CYL_S_Q 4"):
        assert name in h
    for reg in mixed:
        _compare(arm, reg, lib, regulator_name(reg, arm, "cyl"), 7, True, steps=4)
    # the _step functions keep their own state from _reset: equal to a zero-state run
    rng = np.random.default_rng(5)
    reg = mixed[0]
    lib.cyl_regulators_reset()
    lib.cyl_turn_step.restype = ctypes.c_double
    s = np.zeros(NSTATE)
    for _ in range(4):
        sig = _signals(rng, arm.n)
        u_py = METHODS["ace_de"].update(np.asarray(reg.params), s, sig, 0, reg.period)
        assert _close(float(u_py), lib.cyl_turn_step(_ptr(np.ascontiguousarray(sig[0]))))


def test_a_run_time_exp_is_refused_with_file_and_line():
    import numba as nb

    from manipcad.codegen.pyc import Dyn, Translator

    @nb.njit
    def law(x):
        return math.exp(x)

    with pytest.raises(ManipcadError, match=r"math.exp of a run-time value.*"):
        Translator("t").function(law, [Dyn("x", "double")])


def test_cli_regulators_need_lang_c(tmp_path):
    res = CliRunner().invoke(app, ["codegen", "cylindrical", "--regulators", "r.yaml",
                                   "--out", str(tmp_path)])
    assert res.exit_code == 2
    assert "--regulators" in res.output
