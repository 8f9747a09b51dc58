"""The design loop in files: every method synthesized, saved, reloaded, simulated, exported.

Checked here: the registry drives the simulator (no method named in sim/); a regulator
read back from its file runs bit for bit as the one in memory, for every method, on the
PUMA 560 and the Fig. 2 arm; bad regulator files give one error naming file, field and
reason; the centralized computed torque spans joints and beats the decentralized one on
a coupled arm; the python-control export closes the same loop as manipcad to 1e-9; the
complexity is counted from the code; no import circle between subpackages.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import control as ct
import numpy as np
import pytest
import yaml

import manipcad
from manipcad.control import (
    METHODS,
    load_regulators,
    realization_complexity,
    save_regulators,
    synthesize,
    to_control,
)
from manipcad.control.files import regulators_document
from manipcad.errors import InputError, ManipcadError
from manipcad.trajectories import cosine, quintic

SRC = Path(manipcad.__file__).parent
DT = 1e-4


@pytest.fixture(scope="module")
def arm():
    return manipcad.load_robot("cylindrical")


@pytest.fixture(scope="module")
def puma():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return manipcad.load_robot("puma560")


def _flat(regs):
    return regs if isinstance(regs, list) else [regs]


@pytest.mark.parametrize("method", list(METHODS))
def test_round_trip_is_bit_for_bit_on_the_fig2_arm(arm, method, tmp_path):
    regs = _flat(synthesize(arm, "all", method, period=1e-3))
    traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=0.3)
    res = manipcad.simulate(arm, t_end=0.3, dt=DT, trajectory=traj, regulators=regs)
    path = save_regulators(regs, tmp_path / "reg.yaml")
    back = load_regulators(path, arm, dt=DT)
    assert [r.method for r in back] == [method] * len(regs)
    for a, b in zip(regs, back, strict=True):
        assert np.array_equal(a.params, b.params)
        assert a.joints == b.joints and a.period == b.period
        assert set(b.needs) == set(a.needs)
    res2 = manipcad.simulate(arm, t_end=0.3, dt=DT, trajectory=traj, regulators=back)
    for k in ("q", "qd", "u", "current", "tau"):
        assert np.array_equal(getattr(res, k), getattr(res2, k)), k
    assert np.isfinite(res.q).all()


@pytest.mark.slow
def test_every_method_from_files_on_the_puma(puma, tmp_path):
    """The PUMA 560, all six joints, every method: saved, reloaded, simulated identically."""
    traj = quintic(np.zeros(6), [0.4, -0.3, 0.3, 0.2, 0.2, 0.2], duration=0.2)
    for method in METHODS:
        regs = _flat(synthesize(puma, "all", method, period=1e-3))
        path = save_regulators(regs, tmp_path / f"{method}.yaml")
        back = load_regulators(path, puma, dt=5e-4)
        a = manipcad.simulate(puma, t_end=0.2, dt=5e-4, trajectory=traj, regulators=regs)
        b = manipcad.simulate(puma, t_end=0.2, dt=5e-4, trajectory=traj, regulators=back)
        assert np.array_equal(a.q, b.q), method


def test_mixed_methods_in_one_file(arm, tmp_path):
    regs = [synthesize(arm, "turn", "ace_de"), synthesize(arm, "lift", "pid"),
            synthesize(arm, "reach", "lqr")]
    path = save_regulators(regs, tmp_path / "mix.yaml")
    back = load_regulators(path, arm)
    assert [r.method for r in back] == ["ace_de", "pid", "lqr"]
    doc = yaml.safe_load(path.read_text())
    assert doc["robot"]["name"] == arm.name and len(doc["robot"]["hash"]) == 16
    assert doc["manipcad_version"] == manipcad.__version__
    assert "kp_V_per_rad" in doc["regulators"][0]["gains"]
    assert doc["regulators"][0]["drive_assumed"]["R_ohm"] == arm.drives[0].R


def test_lqr_gs_table_is_in_the_file(arm, tmp_path):
    reg = synthesize(arm, "turn", "lqr_gs", h_range=(-5.0, 5.0), grid=(6, 3))
    path = save_regulators([reg], tmp_path / "gs.yaml")
    g = yaml.safe_load(path.read_text())["regulators"][0]["table"]
    assert len(g["H_ii_grid_kgm2"]) == 6 and len(g["h_grid_Nms_per_rad"]) == 3
    assert np.array(g["D_e_V_per_rad"]).shape == (6, 3)
    back = load_regulators(path, arm)[0]
    assert np.array_equal(back.params, reg.params)


def test_a_file_for_another_robot_is_refused(arm, tmp_path):
    path = save_regulators([synthesize(arm, "turn", "ace_de")], tmp_path / "r.yaml")
    heavier = arm.with_payload(2.0)
    with pytest.raises(InputError, match="robot.hash.*allow-other-robot"):
        load_regulators(path, heavier)
    assert load_regulators(path, heavier, allow_other_robot=True)[0].method == "ace_de"


def _doc(arm, method="lqr_gs", **kw):
    regs = _flat(synthesize(arm, "turn", method, **kw))
    return regulators_document(regs, robot=arm)


BAD = [
    (lambda d: d["regulators"][0].update(method="nonesuch"), "regulators[0].method",
     "unknown method"),
    (lambda d: d["regulators"][0]["table"].pop("H_ii_grid_kgm2"),
     "regulators[0].table.H_ii_grid_kgm2", "missing"),
    (lambda d: d["regulators"][0]["table"]["H_ii_grid_kgm2"].reverse(),
     "regulators[0].table.H_ii_grid_kgm2", "increasing"),
    (lambda d: d["regulators"][0]["table"]["D_e_V_per_rad"].pop(), "D_e_V_per_rad", "rows"),
    (lambda d: d["regulators"][0]["gains"].update(u_limit_V=float("nan")),
     "regulators[0].gains.u_limit_V", "finite"),
    (lambda d: d["regulators"][0]["drive_assumed"].update(R_ohm=float("inf")),
     "regulators[0].drive_assumed.R_ohm", "finite"),
    (lambda d: d["regulators"][0].update(period_s=-1e-3), "regulators[0].period_s", "> 0"),
    (lambda d: d["regulators"][0].update(period_s=1.5e-4), "regulators[0].period_s",
     "not a multiple"),
    (lambda d: d["regulators"][0].update(joints=["turn", "turn"]), "regulators[0].joints",
     "one joint"),
    (lambda d: d["regulators"].append(dict(d["regulators"][0])), "regulators[1].joints",
     "already has a regulator"),
    (lambda d: d["regulators"][0].update(joints=[-1]), "regulators[0].joints[0]", "no joint"),
    (lambda d: d["regulators"][0]["table"].update(
        H_ii_grid_kgm2=[x * 0.5 for x in d["regulators"][0]["table"]["H_ii_grid_kgm2"]],
        H_ii_step_kgm2=d["regulators"][0]["table"]["H_ii_step_kgm2"] * 0.5),
     "regulators[0].table.H_ii_grid_kgm2", "re-synthesize"),
    (lambda d: d["regulators"][0]["gains"].update(extra=1.0), "regulators[0].gains.extra",
     "unknown field"),
]


@pytest.mark.parametrize("mutate, field, reason", BAD)
def test_bad_regulator_files(arm, tmp_path, mutate, field, reason):
    doc = _doc(arm)
    mutate(doc)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError) as exc:
        load_regulators(path, arm, dt=1e-4)
    assert str(path) in str(exc.value)
    assert field in exc.value.field, exc.value
    assert reason in exc.value.reason, exc.value


def test_synthesize_cli_round_trip(arm, tmp_path):
    from typer.testing import CliRunner

    from manipcad.cli import app

    out = tmp_path / "reg.yaml"
    r = CliRunner().invoke(app, ["synthesize", "cylindrical", "--method", "ace_tf",
                                 "--joint", "turn", "--joint", "reach",
                                 "--realization", "controllable", "--out", str(out)])
    assert r.exit_code == 0, r.output
    back = load_regulators(out, arm)
    assert [b.joint_names for b in back] == [("turn",), ("reach",)]
    assert all(b.options["realization"] == "controllable" for b in back)
    # an existing file is kept unless --force
    r = CliRunner().invoke(app, ["synthesize", "cylindrical", "--method", "pid", "--all",
                                 "--out", str(out)])
    assert r.exit_code == 2 and "exists" in r.output
    r = CliRunner().invoke(app, ["synthesize", "cylindrical", "--method", "nonesuch",
                                 "--all", "--out", str(tmp_path / "x.yaml")])
    assert r.exit_code == 2 and "unknown method" in r.output
    r = CliRunner().invoke(app, ["synthesize", "--list"])
    assert r.exit_code == 0 and all(m in r.output for m in ("ace_de", "lqr_gs", "asvs"))


def test_computed_torque_full_spans_joints_and_uses_the_coupling(puma):
    """On the PUMA (strong inertial coupling) the full-model law tracks better than the
    decentralized one with the same outer-loop gains on each of the three large joints,
    once the joints have broken away from their static friction. The breakaway (the
    stick-slip plant holds a joint until its drive overcomes M_f; both laws compensate
    friction on the measured speed, 0 while stuck) makes the same peak for both,
    1.7e-3 / 1.9e-4 / 2.4e-3 rad at t = 0.075 s, and is not what the coupling changes.
    Measured after 0.2 s: max |e| 2.5e-4 / 1.6e-4 / 5.3e-4 rad against 3.3e-4 / 2.7e-4 /
    1.9e-3."""
    traj = quintic(np.zeros(6), [0.8, -0.6, 0.7, 0.5, 0.5, 0.5], duration=1.0)
    full = synthesize(puma, "all", "computed_torque_full", period=1e-3)
    assert full.joints == tuple(range(6)) and "H" in full.needs
    dec = synthesize(puma, "all", "computed_torque", period=1e-3)
    runs = [manipcad.simulate(puma, t_end=1.0, dt=5e-4, trajectory=traj, regulators=r)
            for r in (full, dec)]
    e_full, e_dec = (np.abs(r.error[r.t > 0.2]).max(axis=0) for r in runs)
    assert np.all(e_full[:3] < 0.8 * e_dec[:3]), (e_full, e_dec)


def test_complexity_is_counted_from_the_code(arm):
    c_de = realization_complexity(synthesize(arm, "turn", "ace_de"))
    c_none = realization_complexity(synthesize(arm, "turn", "none"))
    assert c_none["ops_per_period"] == 2 and c_none["signals"] == ["q_ref", "q"]
    assert c_de["ops_per_period"] > 10 * c_none["ops_per_period"]
    # a gain table counts whole: more grid points, more numbers stored
    small = realization_complexity(synthesize(arm, "turn", "lqr_gs", grid=(4, 1)))
    big = realization_complexity(synthesize(arm, "turn", "lqr_gs", grid=(12, 1)))
    assert big["gains_stored"] - small["gains_stored"] == 3 * 8


def test_simulator_names_no_method():
    for path in (SRC / "sim").glob("*.py"):
        text = path.read_text()
        for m in METHODS:
            assert f'"{m}"' not in text and f"'{m}'" not in text, (path, m)


def test_no_import_cycles_between_subpackages():
    graph: dict[str, set[str]] = {}
    for path in SRC.rglob("*.py"):
        rel = path.relative_to(SRC).parts
        pkg = rel[0] if len(rel) > 1 else path.stem
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                mods = [node.module]
            elif isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            else:
                continue
            for mod in mods:
                parts = mod.split(".")
                if parts[0] == "manipcad" and len(parts) > 1 and parts[1] != pkg:
                    graph.setdefault(pkg, set()).add(parts[1])
    # depth-first search for a cycle
    state: dict[str, int] = {}

    def visit(u, stack):
        state[u] = 1
        for v in graph.get(u, ()):
            if state.get(v) == 1:
                raise AssertionError(f"import cycle: {' -> '.join(stack + [u, v])}")
            if state.get(v) is None:
                visit(v, stack + [u])
        state[u] = 2

    for u in list(graph):
        if state.get(u) is None:
            visit(u, [])


def _one_joint(drive, inertia=0.02):
    """A single revolute joint about the vertical axis: a drive at a fixed load."""
    return manipcad.Robot.from_arrays(
        "one", ["revolute"], [-1], [np.eye(3)], [np.zeros(3)], [1.0], [np.zeros(3)],
        [np.diag([inertia, inertia, inertia])], drives=[drive], gravity=np.zeros(3))


@pytest.mark.parametrize("method", [m for m in METHODS if m != "computed_torque_full"])
def test_python_control_export_closes_the_same_loop(arm, method):
    """The exported regulator, closed in python-control around the drive (exact ZOH
    discretization at the regulator period, fixed load), gives manipcad's own simulation
    of that loop (RK4 at dt = period/20) to 1e-9 rad. The drive is made linear for the
    comparison: no dry friction, no amplifier limit and a lossless gear (the plant's gear
    losses switch between 1/η and η with the power flow)."""
    d = arm.drives[0].replace(M_f=(0.0, 0.0), u_max=math.inf, efficiency=1.0)
    robot = _one_joint(d)
    T = 1e-3
    reg = synthesize(robot, 0, method, period=T, load_range=(0.02, 0.02))
    traj = quintic([0.0], [0.3], duration=0.2)
    t_end = 0.25
    res = manipcad.simulate(robot, t_end=t_end, dt=T / 20, trajectory=traj, regulators=reg,
                            every=20)
    # the plant: x = (q, q̇, i), input U; (H + J r²)·q̈ = r·k_m·i − k_v·r²·q̇
    r, Jq = d.ratio, 0.02 + d.J * d.ratio ** 2
    A = [[0, 1, 0], [0, -d.k_v * r * r / Jq, r * d.k_m / Jq], [0, -d.k_w * r / d.L, -d.R / d.L]]
    B = [[0], [0], [d.k_u / d.L]]
    plant = ct.c2d(ct.ss(A, B, np.eye(3), 0), T, method="zoh")
    sysc = to_control(reg)
    N = int(round(t_end / T)) + 1
    t = np.arange(N) * T
    qr, qdr, qddr = (a[:, 0] for a in traj.sample(t))
    x = np.zeros(3)
    xc = np.zeros(sysc.nstates)
    qs = np.empty(N)
    names = sysc.input_labels
    Hs = 0.02
    for k in range(N):
        qs[k] = x[0]
        sig = {"q": x[0], "q_dot": x[1], "i": x[2], "q_ref": qr[k], "q_dot_ref": qdr[k],
               "q_ddot_ref": qddr[k], "H_ii": Hs, "c_i": 0.0, "Q_i": 0.0, "e": qr[k] - x[0],
               "e_dot": qdr[k] - x[1], "theta_m": r * x[0], "omega_m": r * x[1]}
        u = np.array([sig[nm] for nm in names])
        U = float(np.ravel(sysc.output(t[k], xc, u))[0])
        if sysc.nstates:
            xc = np.ravel(sysc.dynamics(t[k], xc, u))
        x = np.ravel(plant.A @ x + plant.B[:, 0] * U)
    np.testing.assert_allclose(res.q[:, 0], qs, atol=1e-9, rtol=0)


def test_fixed_lqr_exports_as_a_static_gain(arm):
    """The fixed-gain ``lqr`` is linear in its signals: a state-space system with no state
    whose gains are the design's (U = D_e·(q* − q) + D_v·(q̇* − q̇) − D_i·i + feed-forward);
    with the feed-forward at the current load (H_ii a signal) or a scheduled table
    (``lqr_gs``) the law is not linear: a nonlinear I/O system."""
    from manipcad.control.lqr import LQ_ADAPT

    reg = synthesize(arm, "turn", "lqr", period=1e-3)
    sysc = to_control(reg)
    assert isinstance(sysc, ct.StateSpace) and sysc.nstates == 0 and sysc.dt == 1e-3
    D = dict(zip(sysc.input_labels, np.ravel(sysc.D), strict=True))
    De, Dv, Di = reg.design["gains"][:3]
    assert D["q_ref"] == pytest.approx(De) and D["q"] == pytest.approx(-De)
    assert D["q_dot"] == pytest.approx(-Dv) and D["i"] == pytest.approx(-Di)
    # the feed-forward of J_q·q̈* through the current i* (the law's text writes it out)
    d, H = arm.drives[arm.joint_index("turn")], reg.design["H_nominal"]
    kf = (Di + d.R / d.k_u) / (d.k_m * d.ratio)
    assert D["q_ddot_ref"] == pytest.approx(kf * (H + d.J * d.ratio ** 2))
    p = reg.params.copy()
    p[LQ_ADAPT] = 1.0
    adapt = manipcad.Regulator(method="lqr", joints=reg.joints, period=1e-3, params=p,
                               needs=reg.needs + ("H_ii",))
    assert not isinstance(to_control(adapt), ct.StateSpace)
    gs = to_control(synthesize(arm, "turn", "lqr_gs", period=1e-3))
    assert not isinstance(gs, ct.StateSpace)


def test_sampled_loop_is_checked_at_the_period(arm):
    """The regulator as it runs, closed around its drive sampled at its period: a gain that
    is unstable at that period is refused, naming the stable period range."""
    reg = synthesize(arm, "turn", "pid", period=1e-3)
    assert reg.design["sampled_loop"]["spectral_radius"] < 1.0
    with pytest.raises(ManipcadError, match=r"sampled loop is unstable at the period 0.001 s "
                       r"\(\|λ\|max = .*periods up to .* s are stable"):
        synthesize(arm, "turn", "pid", period=1e-3, kp=-1e5, kd=-2000.0)
    with pytest.raises(ManipcadError, match=r"no period down to .* is stable .*signs"):
        synthesize(arm, "turn", "pid", period=1e-3, kp=1e3, kd=20.0)  # positive feedback


def test_lqr_is_designed_for_its_period(arm):
    """Continuous-time LQR gains sampled at 1 ms make the turn's loop unstable (|λ| 1.11
    measured); the discrete-time design at that period is stable."""
    from manipcad.control.lqr import LQ_TAB, lqr_gains
    from manipcad.control.sampled import spectral_radius

    reg = synthesize(arm, "turn", "lqr", period=1e-3)
    d = arm.drives[0]
    H = reg.design["H_nominal"]
    lo, hi = reg.design["load_range"]
    assert max(spectral_radius(reg, d, lo), spectral_radius(reg, d, hi)) < 1.0
    cont = reg.params.copy()
    cont[LQ_TAB:LQ_TAB + 3] = lqr_gains(d, H, 0.0, reg.design["weights"])
    bad = manipcad.Regulator(method="lqr", joints=(0,), period=1e-3, params=cont)
    assert max(spectral_radius(bad, d, lo), spectral_radius(bad, d, hi)) > 1.0


def test_computed_torque_full_exports_as_a_mimo_system_of_its_joints(puma):
    """The export of the spanning law: one discrete static system, 7 signals per joint
    and H(q) in, U per joint out, equal to the law in closed form (τ = H·v + c + Q +
    J·i_r²·v + k_v·i_r²·q̇, U = (R·τ/(k_m·i_r) + k_w·i_r·q̇)/k_u) with the coupling."""
    from manipcad.control import to_control
    from manipcad.control.computed_torque_full import EXPORT_SIGNALS

    reg = synthesize(puma, "all", "computed_torque_full", period=1e-3, friction=False)
    sys_ = to_control(reg)
    n = puma.n
    assert (sys_.ninputs, sys_.noutputs, sys_.nstates, sys_.dt) == (7 * n + n * n, n, 0, 1e-3)
    assert sys_.input_labels[:7] == [f"{s}[waist]" for s in EXPORT_SIGNALS]
    assert sys_.input_labels[7 * n] == "H[waist,waist]"
    rng = np.random.default_rng(3)
    sig = rng.uniform(-0.05, 0.05, (n, 7))       # small: no amplifier limit reached
    A = rng.uniform(-0.3, 0.3, (n, n))
    H = A @ A.T + np.eye(n)
    U = np.asarray(sys_.output(0.0, [], np.concatenate([sig.ravel(), H.ravel()]))).ravel()
    q_ref, qd_ref, qdd_ref, q, qd, c, g = sig.T
    kp, kd = reg.design["kp"], reg.design["kd"]
    v = qdd_ref + kd * (qd_ref - qd) + kp * (q_ref - q)
    for k, d in enumerate(puma.drives):
        tau = H[k] @ v + c[k] + g[k] + d.J * d.ratio**2 * v[k] + d.k_v * d.ratio**2 * qd[k]
        want = (d.R * tau / (d.k_m * d.ratio) + d.k_w * d.ratio * qd[k]) / d.k_u
        assert U[k] == pytest.approx(want, rel=1e-12, abs=1e-12)
    H2 = H.copy()
    H2[0, 1] = H2[1, 0] = H[0, 1] + 0.1           # the coupling reaches the output
    U2 = np.asarray(sys_.output(0.0, [], np.concatenate([sig.ravel(), H2.ravel()]))).ravel()
    assert U2[0] != pytest.approx(U[0], rel=1e-9)
