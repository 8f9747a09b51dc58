"""Customized per-robot code (manipcad.codegen) against the general kernels, compiled C included."""

from __future__ import annotations

import ctypes
import json
import math
import shutil
import subprocess
import warnings
from pathlib import Path

import numba
import numpy as np
import pytest
from typer.testing import CliRunner

import manipcad
from manipcad.analysis import moment_components
from manipcad.cli import app
from manipcad.codegen import CFUNC_SIGNATURES, generate, robot_hash
from manipcad.codegen.emit import count_ops
from manipcad.errors import ManipcadError, ManipcadWarning

TOL = 1e-12


def rel(a, b) -> float:
    """Largest difference relative to the largest magnitude of the reference."""
    a, b = np.asarray(a), np.asarray(b)
    scale = np.abs(b).max()
    return float(np.abs(a - b).max() / scale) if scale > 0 else float(np.abs(a).max())


def load(name: str) -> manipcad.Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot(name)


def erd_robot(name: str) -> manipcad.Robot:
    from test_urdf import ERD_URDFS, erd_robots_dir

    from manipcad.model.urdf import load_urdf

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return load_urdf(erd_robots_dir() / ERD_URDFS[name])


def states(robot, N: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-2.0, 2.0, (3, N, robot.n))


def check_against_general(robot, gen, N: int = 8) -> None:
    """Every generated function equals the general kernels at random states, batch and single."""
    Q, QD, QDD = states(robot, N)
    for drives in (True, False):
        tau = manipcad.inverse_dynamics(robot, Q, QD, QDD, drives=drives, use_generated=False)
        assert rel(gen.inverse_dynamics(Q, QD, QDD, drives), tau) < TOL
        H = manipcad.mass_matrix(robot, Q, drives=drives, use_generated=False)
        assert rel(gen.mass_matrix(Q, drives), H) < TOL
        # forward dynamics: the generated accelerations reproduce the torques (backward
        # error) and differ from the general Cholesky solve by at most cond(H)·TOL
        qdd = gen.forward_dynamics(Q, QD, tau, drives)
        back = manipcad.inverse_dynamics(robot, Q, QD, qdd, drives=drives, use_generated=False)
        assert rel(back, tau) < TOL
        ref = manipcad.forward_dynamics(robot, Q, QD, tau, method="crba", drives=drives,
                                        use_generated=False)
        cond = max(np.linalg.cond(h) for h in H)
        assert rel(qdd, ref) < TOL * max(1.0, cond)
    mc = gen.moment_components(Q, QD)
    ref = moment_components(robot, Q, QD)
    for a, b in ((mc.H_ii, ref.H_ii), (mc.velocity, ref.velocity), (mc.gravity, ref.gravity)):
        assert rel(a, b) < TOL
    # the one-state fast path gives the batch's rows
    k = N // 2
    assert np.array_equal(gen.inverse_dynamics(Q[k], QD[k], QDD[k]),
                          gen.inverse_dynamics(Q, QD, QDD)[k])
    assert np.array_equal(gen.mass_matrix(Q[k]), gen.mass_matrix(Q)[k])


@pytest.mark.slow
@pytest.mark.parametrize("name", manipcad.catalog_names())
def test_catalog_robot_matches_general_kernels(name):
    robot = load(name)
    gen = generate(robot, attach=False)
    assert gen.generated
    check_against_general(robot, gen)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_example_robot_data_urdf_matches_general_kernels(name):
    """The code computes the snapped robot's dynamics (the UR5's 12-digit π made exact)."""
    from manipcad.codegen.symbolic import snapped

    robot = erd_robot(name)
    gen = generate(robot, attach=False)
    assert gen.generated
    check_against_general(snapped(robot), gen, N=5)


def test_puma_counts_within_target_and_read_from_the_code():
    gen = generate(load("puma560"), attach=False)
    ops = gen.ops["inverse_dynamics"]
    assert ops["mul"] <= 210 and ops["add"] <= 165, ops
    assert ops["trig"] <= 10
    src = gen.python_source()
    for func, c in gen.ops.items():
        assert count_ops(src, func) == c
    # the general kernel's count at n = 6 without drives is far higher (134n - 60)
    assert manipcad.operation_counts("rnea", 6)["mul"] > 3 * ops["mul"]


def test_ur5_twelve_digit_pi_constants_snapped():
    """The UR5 URDF writes π as 3.14159265359: sin and cos of it left 2e-12 and 5e-12 in
    the placements (and a payload com of -2e-13 m), 162 constants below 1e-9 in the code
    and 253 + 203 operations of inverse dynamics. Snapped (symbolic.snapped), the code is
    smaller, equals the general kernels on the snapped robot to TOL and Pinocchio on the
    robot as given to its URDF tolerance."""
    import re

    import pinocchio as pin
    from urdf_pinref import RTOL, close, pin_from_robot, pin_reference

    from manipcad.codegen.symbolic import SNAP_RTOL, snapped

    robot = load(str(Path(__file__).resolve().parents[1] / "examples/ur5/ur5.yaml"))
    gen = generate(robot, attach=False)
    ops = gen.ops["inverse_dynamics"]
    assert ops["mul"] + ops["add"] <= 390 and gen.ops["mass_matrix"]["mul"] <= 150, gen.ops
    consts = [float(x) for x in re.findall(r"\d+\.\d+e-\d+", gen.python_source())]
    assert not [x for x in consts if x < SNAP_RTOL], "near-zero constants left"
    snap = snapped(robot)
    assert snap is not robot and np.abs(snap.placement_R - robot.placement_R).max() < 1e-11
    check_against_general(snap, gen, N=4)
    model = pin_from_robot(robot)
    rng = np.random.default_rng(5)
    for _ in range(3):
        q, qd, qdd = rng.uniform(-1.5, 1.5, (3, robot.n))
        tau_ref, H_ref, _ = pin_reference(robot, model, q, qd, qdd, np.zeros(robot.n))
        close(gen.inverse_dynamics(q, qd, qdd, False), tau_ref, RTOL)
        close(gen.mass_matrix(q, False), H_ref, RTOL)
    assert pin.__version__


def test_count_ops_counts_longest_branch_and_skips_unary_minus():
    src = ("def f(a, b, t):\n    x = -a*b + a/b - math.cos(a)\n    if b > 0.0:\n"
           "        t += 1.0\n    elif b < 0.0:\n        t -= 2.0\n    return math.sqrt(x)\n")
    assert count_ops(src, "f") == {"mul": 2, "add": 3, "trig": 1, "sqrt": 1}
    with pytest.raises(ManipcadError, match="no function 'g'"):
        count_ops(src, "g")


def _compile_c(gen, tmp_path, prefix: str):
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.fail("no system C compiler (cc or gcc) to compile the generated code")
    hdr, src = gen.c_code(prefix)
    (tmp_path / f"{prefix}.h").write_text(hdr)
    (tmp_path / f"{prefix}.c").write_text(src)
    lib = tmp_path / f"lib{prefix}.so"
    subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-pedantic", "-Werror",
                    "-shared", "-fPIC", "-o", str(lib), str(tmp_path / f"{prefix}.c"), "-lm"],
                   check=True, capture_output=True, text=True)
    return ctypes.CDLL(str(lib))


@pytest.mark.parametrize("name", ["puma560", "stanford"])
def test_c_code_compiles_and_matches(name, tmp_path):
    robot = load(name)
    gen = generate(robot, attach=False)
    lib = _compile_c(gen, tmp_path, "arm")
    n = robot.n
    ptr = ctypes.POINTER(ctypes.c_double)

    def p(a):
        return a.ctypes.data_as(ptr)

    lib.arm_forward_dynamics.restype = ctypes.c_int
    Q, QD, QDD = states(robot, 5, seed=3)
    for q, qd, qdd in zip(Q, QD, QDD, strict=True):
        tau = np.empty(n)
        lib.arm_inverse_dynamics(p(q), p(qd), p(qdd), p(tau))
        ref = manipcad.inverse_dynamics(robot, q, qd, qdd, use_generated=False)
        assert rel(tau, ref) < TOL
        H = np.empty((n, n))
        lib.arm_mass_matrix(p(q), p(H))
        assert rel(H, manipcad.mass_matrix(robot, q, use_generated=False)) < TOL
        # the rigid body alone, as computed_torque_full's H (docs/codegen.md)
        lib.arm_mass_matrix_rigid(p(q), p(H))
        assert rel(H, manipcad.mass_matrix(robot, q, drives=False, use_generated=False)) < TOL
        lib.arm_inverse_dynamics_rigid(p(q), p(qd), p(qdd), p(tau))
        assert rel(tau, manipcad.inverse_dynamics(robot, q, qd, qdd, drives=False,
                                                  use_generated=False)) < TOL
        Hii, h, Qg = np.empty(n), np.empty(n), np.empty(n)
        lib.arm_moment_components(p(q), p(qd), p(Hii), p(h), p(Qg))
        mc = moment_components(robot, q, qd)
        assert rel(Hii, mc.H_ii) < TOL and rel(h, mc.velocity) < TOL
        assert rel(Qg, mc.gravity) < TOL
        a = np.empty(n)
        assert lib.arm_forward_dynamics(p(q), p(qd), p(ref), p(a)) == -1
        back = manipcad.inverse_dynamics(robot, q, qd, a, use_generated=False)
        assert rel(back, ref) < TOL
    # the C code calls nothing from libm but sin, cos and sqrt, and allocates nothing
    src = gen.c_code("arm")[1]
    calls = set(__import__("re").findall(r"\b([a-z_]+)\(", src)) - {"if", "return"}
    own = {f"arm_{f}{tail}" for f in gen.ops for tail in ("", "_body", "_rigid")} | {"arm_sincos"}
    assert calls <= {"sin", "cos", "sqrt"} | own, calls
    assert "malloc" not in src


def test_sincos_within_one_ulp_of_libm_and_alike_everywhere():
    """codegen.trig: the vectorized batch, the scalar kernel and the C twin give the same
    numbers, within 1 ulp of libm's sin and cos (libm's own beyond 1e5 rad and inf/NaN)."""
    from manipcad.codegen.trig import C_SOURCE, LIMIT, sincos, sincos_many

    rng = np.random.default_rng(3)
    X = np.concatenate([rng.uniform(-2, 2, 4000), rng.uniform(-300, 300, 4000),
                        rng.uniform(-LIMIT, LIMIT, 500), [0.0, -0.0, math.pi / 2, -math.pi,
                                                          1e-300, 2e5, -3e7, math.inf, math.nan]])
    S, C = np.empty_like(X), np.empty_like(X)
    sincos_many(X, S, C)
    with np.errstate(invalid="ignore"):
        ref_s, ref_c = np.sin(X), np.cos(X)
    fin = np.isfinite(X)
    for got, ref in ((S, ref_s), (C, ref_c)):
        ulp = np.spacing(np.abs(ref[fin]))
        big = np.abs(ref[fin]) > 1e-3  # near a zero the absolute error is what counts
        assert (np.abs(got[fin] - ref[fin])[big] <= ulp[big]).all()
        assert np.abs(got[fin] - ref[fin]).max() <= 2.3e-16
        assert np.isnan(got[~fin]).all()
    beyond = (np.abs(X) > LIMIT) & fin
    assert beyond.sum() == 2 and np.array_equal(S[beyond], ref_s[beyond])
    scalar = np.array([sincos(x) for x in X])
    assert np.array_equal(scalar[fin], np.stack([S, C], 1)[fin])
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.fail("no system C compiler (cc or gcc)")
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "t.c"
        src.write_text("#include <math.h>\n" + C_SOURCE.replace("@PREFIX@", "t") +
                       "void t_many(const double *x, double *s, double *c, int n)\n"
                       "{ int i; for (i = 0; i < n; i++) t_sincos(x[i], s + i, c + i); }\n")
        lib = Path(tmp) / "libt.so"
        subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-pedantic", "-Werror",
                        "-ffp-contract=off", "-shared", "-fPIC", "-o", str(lib), str(src), "-lm"],
                       check=True, capture_output=True, text=True)
        f = ctypes.CDLL(str(lib)).t_many
        Sc, Cc = np.empty_like(X), np.empty_like(X)
        ptr = ctypes.POINTER(ctypes.c_double)
        f(X.ctypes.data_as(ptr), Sc.ctypes.data_as(ptr), Cc.ctypes.data_as(ptr), len(X))
        assert np.array_equal(Sc[fin], S[fin]) and np.array_equal(Cc[fin], C[fin])


def test_one_state_calls_equal_the_compiled_batch_bit_for_bit():
    """The one-state calls (the C extension, or numba) and the batch kernels agree exactly."""
    robot = load("stanford")
    gen = generate(robot, attach=False)
    Q, QD, QDD = states(robot, 4, seed=9)
    tau = gen.inverse_dynamics(Q, QD, QDD)
    for k in range(4):
        assert np.array_equal(gen.inverse_dynamics(Q[k], QD[k], QDD[k]), tau[k])
        assert np.array_equal(gen.forward_dynamics(Q[k], QD[k], tau[k], False),
                              gen.forward_dynamics(Q, QD, tau, False)[k])
    # lists and other dtypes take the checked path, same numbers
    assert np.array_equal(gen.inverse_dynamics(list(Q[0]), QD[0], QDD[0]), tau[0])
    strided = np.asfortranarray(Q)[1]  # not contiguous: the checked path
    assert not strided.flags.c_contiguous
    assert np.array_equal(gen.mass_matrix(strided), gen.mass_matrix(Q)[1])


@numba.njit(cache=True)
def _loop_with_kernels(fd, mc, Q, QD, T, QDD, HII, HV, QG):
    """What a compiled simulator does: call C-ABI kernels given as arguments.

    Element by element copies (no slice assignment, whose shape-mismatch error path would
    compile numba's string formatting, about a second, into this test)."""
    n = Q.shape[1]
    q, qd, tau, out = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    a, b, c = np.empty(n), np.empty(n), np.empty(n)
    bad = -1
    for k in range(Q.shape[0]):
        for j in range(n):
            q[j], qd[j], tau[j] = Q[k, j], QD[k, j], T[k, j]
        r = fd(q.ctypes.data, qd.ctypes.data, tau.ctypes.data, out.ctypes.data)
        if r >= 0:
            bad = k
        mc(q.ctypes.data, qd.ctypes.data, a.ctypes.data, b.ctypes.data, c.ctypes.data)
        for j in range(n):
            QDD[k, j], HII[k, j], HV[k, j], QG[k, j] = out[j], a[j], b[j], c[j]
    return bad


def test_c_abi_kernels_run_inside_compiled_code():
    robot = load("puma560")
    gen = generate(robot, attach=False)
    Q, QD, QDD = states(robot, 6, seed=4)
    tau = manipcad.inverse_dynamics(robot, Q, QD, QDD, use_generated=False)
    out, hii, hv, qg = (np.empty_like(Q) for _ in range(4))
    fd, mc = gen.cfunc("forward_dynamics"), gen.cfunc("moment_components")
    assert _loop_with_kernels(fd, mc, Q, QD, tau, out, hii, hv, qg) == -1
    assert np.array_equal(out, gen.forward_dynamics(Q, QD, tau))
    ref = moment_components(robot, Q, QD)
    assert rel(hii, ref.H_ii) < TOL and rel(hv, ref.velocity) < TOL
    assert rel(qg, ref.gravity) < TOL
    # the same compiled loop serves another robot (the kernels' type is the signature)
    other = load("stanford")
    g2 = generate(other, attach=False)
    Q2, QD2, QDD2 = states(other, 3, seed=5)
    tau2 = manipcad.inverse_dynamics(other, Q2, QD2, QDD2, use_generated=False)
    o2, a2, b2, c2 = (np.empty_like(Q2) for _ in range(4))
    _loop_with_kernels(g2.cfunc("forward_dynamics"), g2.cfunc("moment_components"),
                       Q2, QD2, tau2, o2, a2, b2, c2)
    assert rel(manipcad.inverse_dynamics(other, Q2, QD2, o2, use_generated=False), tau2) < TOL
    assert len(_loop_with_kernels.signatures) == 1
    assert _loop_with_kernels.signatures[0][0] == numba.types.FunctionType(
        CFUNC_SIGNATURES["forward_dynamics"])
    with pytest.raises(ManipcadError, match="no C-ABI kernel"):
        gen.cfunc("jacobian")


def test_simulator_picks_the_generated_kernels():
    from manipcad.control import pid
    from manipcad.sim import simulate
    from manipcad.trajectories import quintic

    robot = load("puma560")
    gen = generate(robot)
    traj = quintic(np.zeros(6), np.array([0.4, -0.3, 0.2, 0.5, -0.4, 0.6]), 0.05)
    regs = [pid(j, kp=300.0, kd=10.0, u_limit=40.0, period=1e-3) for j in range(robot.n)]
    runs = {use: simulate(robot, t_end=0.05, dt=1e-4, trajectory=traj, regulators=regs,
                          use_generated=use) for use in (True, False)}
    assert runs[True].settings["generated"] and not runs[False].settings["generated"]
    assert np.abs(runs[True].q - runs[False].q).max() < 1e-9
    assert np.abs(runs[True].current - runs[False].current).max() < 1e-7
    # drives=False: the generated rigid body; a payload makes another robot (general kernels)
    passive = simulate(robot, t_end=0.02, dt=1e-4, drives=False)
    assert passive.settings["generated"]
    ref = simulate(robot, t_end=0.02, dt=1e-4, drives=False, use_generated=False)
    assert np.abs(passive.q - ref.q).max() < 1e-9
    loaded = simulate(robot, t_end=0.01, dt=1e-4, drives=False, payload=1.0)
    assert not loaded.settings["generated"]
    # with and without the drive terms one compiled forward dynamics serves both flags:
    # the flag reaches it as a plain boolean, no constant's specialization (the C-ABI
    # wrappers pass it so too; loaded from the cache they compile nothing here, so the
    # Python calls are what this process can count)
    fd = gen.kernel("forward_dynamics")
    q, qd, tau, qdd = np.full(6, 0.1), np.zeros(6), np.ones(6), np.empty(6)
    for flag in (True, False, True):
        assert fd(q, qd, tau, flag, qdd) == -1
    assert [str(sig[3]) for sig in fd.signatures] == ["bool"], fd.signatures


def test_cache_is_keyed_by_content_hash(tmp_path):
    robot = load("cylindrical")
    first = generate(robot, cache_dir=tmp_path, attach=False)
    again = generate(robot, cache_dir=tmp_path, attach=False)
    assert first.path == again.path and again.seconds == 0.0
    heavier = robot.with_payload(3.0, com=(0.0, 0.0, 0.05))
    assert robot_hash(heavier) != robot_hash(robot)
    other = generate(heavier, cache_dir=tmp_path, attach=False)
    assert other.path != first.path
    Q, QD, QDD = states(robot, 4)
    ref = manipcad.inverse_dynamics(heavier, Q, QD, QDD, use_generated=False)
    assert rel(other.inverse_dynamics(Q, QD, QDD), ref) < TOL
    assert rel(first.inverse_dynamics(Q, QD, QDD), ref) > 1e-3  # the old robot's torques
    # a folder whose recorded hash is not the robot's is regenerated, never used
    meta = first.path / "meta.json"
    data = json.loads(meta.read_text())
    data["hash"] = "0" * 64
    meta.write_text(json.dumps(data))
    fresh = generate(robot, cache_dir=tmp_path, attach=False)
    assert fresh.seconds > 0.0
    assert json.loads(meta.read_text())["hash"] == robot_hash(robot)


def test_api_uses_attached_kernels_and_can_opt_out():
    robot = load("scara")
    Q, QD, QDD = states(robot, 3)
    gen = generate(robot)  # attaches to this robot object
    from manipcad.dynamics.generated import attached

    assert np.array_equal(manipcad.inverse_dynamics(robot, Q, QD, QDD),
                          gen.inverse_dynamics(Q, QD, QDD))
    assert np.array_equal(manipcad.mass_matrix(robot, Q[0]), gen.mass_matrix(Q[0]))
    tau = gen.inverse_dynamics(Q, QD, QDD)
    assert np.array_equal(manipcad.forward_dynamics(robot, Q, QD, tau),
                          gen.forward_dynamics(Q, QD, tau))
    general = manipcad.inverse_dynamics(robot, Q, QD, QDD, use_generated=False)
    assert rel(general, tau) < TOL
    # a changed copy is a new object: the general kernels, not the stale ones
    heavier = robot.with_payload(2.0)
    assert attached(heavier) is None and attached(robot) is gen
    assert not any(k.startswith("_") for k in robot.__dict__)  # nothing hung on the robot
    # a robot with kernels attached pickles (process pools); the copy finds them again
    import pickle

    from manipcad.codegen import find

    copy = pickle.loads(pickle.dumps(robot))
    assert attached(copy) is None
    # its table is read-only like the original's: the same compiled kernels serve it
    assert not copy.table.flags.writeable and np.array_equal(copy.table, robot.table)
    assert np.array_equal(manipcad.inverse_dynamics(copy, Q, QD, QDD, use_generated=False),
                          general)
    again = find(copy)
    assert again is not None and again.hash == gen.hash


def test_too_many_joints_falls_back_with_a_message():
    robot = load("puma560")
    with pytest.warns(ManipcadWarning, match="at most 3 joints"):
        gen = generate(robot, attach=False, max_joints=3)
    assert not gen.generated and "general kernels" in gen.reason
    Q, QD, QDD = states(robot, 3)
    ref = manipcad.inverse_dynamics(robot, Q, QD, QDD, use_generated=False)
    assert np.array_equal(gen.inverse_dynamics(Q, QD, QDD), ref)
    mc = gen.moment_components(Q, QD)
    assert rel(mc.gravity, moment_components(robot, Q, QD).gravity) < TOL
    with pytest.raises(ManipcadError, match="no C code"):
        gen.c_code()


def test_bad_shapes_name_the_argument():
    gen = generate(load("cylindrical"), attach=False)
    with pytest.raises(ManipcadError, match="qd"):
        gen.inverse_dynamics(np.zeros(3), np.zeros(4), np.zeros(3))
    with pytest.raises(ManipcadError, match="q must have"):
        gen.mass_matrix(np.zeros((2, 2, 3)))


runner = CliRunner()


def test_cli_stats_json_and_c_files(tmp_path):
    res = runner.invoke(app, ["codegen", "puma560", "--stats", "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    assert data["inverse_dynamics"]["mul"] <= 210 and data["inverse_dynamics"]["add"] <= 165
    assert set(data) == {"inverse_dynamics", "mass_matrix", "moment_components",
                         "forward_dynamics"}
    assert set(data["mass_matrix"]) == {"mul", "add", "trig", "sqrt"}
    res = runner.invoke(app, ["codegen", "puma560", "--out", str(tmp_path), "--lang", "c"])
    assert res.exit_code == 0, res.output
    assert "puma_560_inverse_dynamics(const double *q" in (tmp_path / "puma_560.h").read_text()
    res = runner.invoke(app, ["codegen", "puma560", "--out", str(tmp_path), "--prefix", "p5"])
    assert res.exit_code == 0 and (tmp_path / "p5_dynamics.py").is_file()


@pytest.mark.parametrize("args, fragment", [
    (["puma560", "--out", "x", "--lang", "fortran"], "--lang"),
    (["puma560", "--out", "x", "--prefix", "9lives"], "C identifier"),
    (["no_such_robot", "--stats"], "no_such_robot"),
    (["puma560"], "--out"),
])
def test_cli_bad_input_exits_2(args, fragment):
    res = runner.invoke(app, ["codegen", *args])
    assert res.exit_code == 2 and fragment in res.output
