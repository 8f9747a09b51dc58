"""The regulators' models of the gear's losses, and regulator files made before them.

The simulated plant passes the load through a gear of efficiency η with the factor
f = 1/η (motoring or holding) or η (braking) (``manipcad.dynamics.gear.gear_factor``).
Checked here: every law whose structure has a load model (ace_de, ace_tf, asvs, lqr_gs,
computed_torque, computed_torque_full) stores the drive's η and applies f to that model,
against closed forms written out here; η = 1 gives the law without losses; a file made
before a law stored η loads with η = 1, says so in the law and warns; a bad η is refused
naming the field; on the Fig. 2 arm's own gears the loss model lowers the tracking error.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

import manipcad
from manipcad.control import METHODS, load_regulators, save_regulators, synthesize
from manipcad.control.files import regulators_document
from manipcad.control.signals import NSIG, NSTATE, SIGNALS
from manipcad.errors import InputError, ManipcadWarning

LOSSY = ["ace_de", "ace_tf", "asvs", "lqr_gs", "computed_torque", "computed_torque_full"]


@pytest.fixture(scope="module")
def arm():
    return manipcad.load_robot("cylindrical")


@pytest.fixture(scope="module")
def regs(arm):
    """Each lossy method on the turn (η = 0.75), period 1 ms (ace_tf: its controllable
    realization, the one that models the losses)."""
    out = {}
    for m in LOSSY:
        if METHODS[m].spans:
            out[m] = synthesize(arm, ["turn", "reach"], m, period=1e-3)
        elif m == "ace_tf":
            out[m] = synthesize(arm, "turn", m, period=1e-3, realization="controllable")
        else:
            out[m] = synthesize(arm, "turn", m, period=1e-3)
    return out


def _eta_index(m):
    meth = METHODS[m]
    return meth.fields.get("gear_efficiency", meth.joint_fields.get("gear_efficiency"))


@pytest.mark.parametrize("method", LOSSY)
def test_each_law_stores_the_drives_efficiency(arm, regs, method, tmp_path):
    reg = regs[method]
    assert reg.params[_eta_index(method)] == arm.drives[0].efficiency == 0.75
    assert "η = 0.75" in reg.law
    path = save_regulators([reg], tmp_path / "r.yaml")
    g = yaml.safe_load(path.read_text())["regulators"][0]
    eta = (g["drives_assumed"]["turn"] if METHODS[method].spans else g["gains"])
    assert eta["gear_efficiency"] == 0.75
    assert np.array_equal(load_regulators(path, arm)[0].params, reg.params)


@pytest.mark.parametrize("method", LOSSY)
def test_a_file_without_the_efficiency_loads_with_eta_one_and_says_so(arm, regs, method,
                                                                      tmp_path):
    """A file made before the law modelled the gear's losses: not refused; η = 1 (the law
    it was made with), said in a warning and in the law's text, with how to change it."""
    doc = regulators_document([regs[method]], robot=arm)
    g = doc["regulators"][0]
    blocks = g["drives_assumed"].values() if METHODS[method].spans else [g["gains"]]
    for b in blocks:
        del b["gear_efficiency"]
    path = tmp_path / "old.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    with pytest.warns(ManipcadWarning, match="gear_efficiency missing: η = 1 assumed") as rec:
        back = load_regulators(path, arm)[0]
    assert str(path) in str(rec[0].message) and "re-synthesize" in str(rec[0].message)
    i = _eta_index(method)
    n = len(back.joints) if METHODS[method].spans else 1
    assert np.all(back.params[i:i + n] == 1.0)
    assert "η = 1 assumed" in back.law
    # everything else as saved
    other = np.ones(len(back.params), bool)
    other[i:i + n] = False
    assert np.array_equal(back.params[other], regs[method].params[other])


@pytest.mark.parametrize("eta", [0.0, 1.5, -0.2])
def test_a_bad_efficiency_in_a_file_is_refused(arm, regs, eta, tmp_path):
    doc = regulators_document([regs["computed_torque"]], robot=arm)
    doc["regulators"][0]["gains"]["gear_efficiency"] = eta
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    with pytest.raises(InputError) as exc:
        load_regulators(path, arm)
    assert exc.value.field == "regulators[0].gains.gear_efficiency"
    assert "(0, 1]" in exc.value.reason


def test_the_observable_ace_models_no_losses_but_its_nominal_drive_does(arm, regs):
    """ACE (1)'s quasi-stationary (observable) realization stores η = 1 and says why; both
    realizations take T_1 for J_n = J + H*_max/η."""
    obs = synthesize(arm, "turn", "ace_tf", period=1e-3)
    assert obs.params[_eta_index("ace_tf")] == 1.0
    assert "follows no step of T_m" in obs.law
    d = arm.drives[0]
    Jn = d.J + obs.design["load_range"][1] / (0.75 * d.ratio ** 2)
    assert obs.design["T_1"] == pytest.approx(d.R * Jn / (d.k_m * d.k_w), rel=1e-12)
    assert regs["ace_tf"].design["T_1"] == obs.design["T_1"]


# ---------------------------------------------------------------- the laws, closed forms


def _sig(**values):
    sig = np.zeros((1, NSIG))
    for k, v in values.items():
        sig[0, SIGNALS[k][0]] = v
    return sig


def _f(eta, load, speed):
    """The plant's gear factor written out: 1/η motoring or holding, η braking."""
    return 1.0 / eta if load * speed >= 0 else eta


@pytest.mark.parametrize("qd", [0.3, -0.3])
def test_computed_torque_passes_its_load_through_the_gear(arm, regs, qd):
    reg = regs["computed_torque"]
    d = arm.drives[0]
    s = dict(q_ref=0.1, q=0.09, q_dot_ref=0.25, q_dot=qd, q_ddot_ref=2.0, H_ii=0.6,
             c_i=0.4, Q_i=-0.1)
    U = METHODS["computed_torque"].update(reg.params, np.zeros(NSTATE), _sig(**s), 0, 1e-3)
    kp, kd = reg.design["kp"], reg.design["kd"]
    v = s["q_ddot_ref"] + kd * (s["q_dot_ref"] - qd) + kp * (s["q_ref"] - s["q"])
    P = s["H_ii"] * v + s["c_i"] + s["Q_i"]
    r = d.ratio
    mf = d.M_f[0] if r * qd * r > 0 else -d.M_f[1]
    tau = _f(0.75, P, qd) * P + d.J * r * r * v + d.k_v * r * r * qd + abs(r) * mf
    i = tau / (d.k_m * r)
    assert U == pytest.approx((d.R * i + d.k_w * r * qd) / d.k_u, rel=1e-12)
    # braking in one case, motoring in the other: the factor matters
    assert _f(0.75, P, 0.3) != _f(0.75, P, -0.3)


def test_asvs_and_ace_tf_feel_the_load_through_the_gear(arm, regs):
    """Their load H* (and ace_tf's h*) is f·H_ii/i_r²: the law with η at a load H equals
    the law with η = 1 at the load f·H (f from H·q̈* (+ c_i + Q_i) against q̇)."""
    for method, extra in (("asvs", dict(c_i=0.0, Q_i=0.0)), ("ace_tf", {})):
        reg = regs[method]
        i = _eta_index(method)
        lossless = reg.params.copy()
        lossless[i] = 1.0
        law = METHODS[method].update
        for qd, qdd in ((0.4, 3.0), (0.4, -3.0)):
            H = 0.6
            f = _f(0.75, H * qdd, qd)
            s = dict(q_ref=0.1, q=0.0995, q_dot_ref=0.41, q_dot=qd, q_ddot_ref=qdd, **extra)
            # ace_tf differences H_ii: a constant H (Ḣ = 0) from a fresh state
            U = law(reg.params, np.zeros(NSTATE), _sig(H_ii=H, **s), 0, 1e-3)
            U1 = law(lossless, np.zeros(NSTATE), _sig(H_ii=f * H, **s), 0, 1e-3)
            assert U == pytest.approx(U1, rel=1e-12), (method, qdd)
            assert U != law(lossless, np.zeros(NSTATE), _sig(H_ii=H, **s), 0, 1e-3)


def test_lqr_gs_looks_up_its_gains_and_feeds_forward_through_the_gear(arm, regs):
    reg = regs["lqr_gs"]
    d = arm.drives[0]
    from manipcad.control.lqr import LQ_ETA, gain, lqr_update

    p = reg.params
    H, qd, qdd, c, Q = 0.6, 0.4, -3.0, 0.5, 0.0
    s = dict(q_ref=0.1, q=0.0999, q_dot_ref=0.41, q_dot=qd, q_ddot_ref=qdd, i=1.5, H_ii=H,
             c_i=c, Q_i=Q)
    U = lqr_update(p, np.zeros(NSTATE), _sig(**s), 0, 1e-3)
    P = H * qdd + c + Q
    f = _f(0.75, P, qd)
    assert f == 0.75   # braking
    De, Dv, Di = (gain(p, k, f * H, 0.0) for k in range(3))
    r = d.ratio
    i_star = (f * P + d.J * r * r * qdd + d.k_v * r * r * s["q_dot_ref"]) / (d.k_m * r)
    ff = Di * i_star + (d.R * i_star + d.k_w * r * s["q_dot_ref"]) / d.k_u
    want = De * (s["q_ref"] - s["q"]) + Dv * (s["q_dot_ref"] - qd) - Di * s["i"] + ff
    assert U == pytest.approx(want, rel=1e-12)
    assert p[LQ_ETA] == 0.75
    # the table spans the loads the motor feels through the gear, η·H_min .. H_max/η
    lo, hi = reg.design["load_range"]
    table = reg.design["table"]
    assert table.H[0] == pytest.approx(0.75 * lo) and table.H[-1] == pytest.approx(hi / 0.75)


def test_computed_torque_full_applies_each_joints_gear(arm, regs):
    reg = regs["computed_torque_full"]
    from manipcad.control.computed_torque_full import CTF_ETA0

    assert list(reg.params[CTF_ETA0:CTF_ETA0 + 2]) == [0.75, 0.95]
    lossless = reg.params.copy()
    lossless[CTF_ETA0:CTF_ETA0 + 2] = 1.0
    law = METHODS["computed_torque_full"].update
    sig = np.zeros((3, NSIG))
    sig[0, SIGNALS["q_dot"][0]], sig[2, SIGNALS["q_dot"][0]] = 0.3, -0.2
    sig[0, SIGNALS["q_ddot_ref"][0]], sig[2, SIGNALS["q_ddot_ref"][0]] = 2.0, 1.0
    H = np.array([[0.6, 0.0, 0.1], [0.0, 9.0, 0.0], [0.1, 0.0, 4.0]])
    joints = np.array([0, 2], dtype=np.int64)
    U, U1 = np.zeros(3), np.zeros(3)
    law(reg.params, np.zeros(NSTATE), sig, H, joints, 2, 1e-3, U)
    law(lossless, np.zeros(NSTATE), sig, H, joints, 2, 1e-3, U1)
    # each joint's load H·v + c + Q through its own gear: the voltage's load part scales by f
    qdc, qddc = SIGNALS["q_dot"][0], SIGNALS["q_ddot_ref"][0]
    v = {k: sig[k, qddc] - reg.design["kd"] * sig[k, qdc] for k in (0, 2)}   # e = ė* = 0
    for j, d, eta in ((0, arm.drives[0], 0.75), (2, arm.drives[2], 0.95)):
        P = H[j, 0] * v[0] + H[j, 2] * v[2]
        f = _f(eta, P, sig[j, qdc])
        dU = d.R * (f - 1.0) * P / (d.k_m * d.ratio * d.k_u)
        assert U[j] - U1[j] == pytest.approx(dU, rel=1e-9, abs=1e-12), j
        assert abs(dU) > 1e-3


# ---------------------------------------------------------------- closed loop


def test_loss_model_lowers_the_fig3_error_on_the_arms_gears(arm):
    """Fig. 3 laws (2), 0.4 s, the turn (η = 0.75) by computed torque and by lqr_gs, lift
    and reach by pid: with the gear's losses modelled the turn's error is several times
    smaller than with the same law assuming η = 1."""
    dt = 1e-4
    laws = manipcad.load_trajectory(Path(__file__).resolve().parents[1] / "examples"
                                    / "fig3_laws.yaml", robot=arm)
    others = [synthesize(arm, j, "pid", period=dt) for j in ("lift", "reach")]
    for method in ("computed_torque", "lqr_gs"):
        reg = synthesize(arm, "turn", method, period=dt)
        p = reg.params.copy()
        p[_eta_index(method)] = 1.0
        errs = []
        for r in (reg, dataclasses.replace(reg, params=p)):
            res = manipcad.simulate(arm, t_end=0.4, dt=dt, trajectory=laws,
                                    regulators=[r, *others])
            errs.append(float(np.abs(res.error[:, 0]).max()))
        assert errs[0] < errs[1] / 3, (method, errs)


def test_simulate_runs_an_old_file_and_says_what_it_assumed(arm, regs, tmp_path):
    """From the command line: a file without gear_efficiency runs (exit 0) and the
    warning tells the user what was assumed and how to change it."""
    from typer.testing import CliRunner

    from manipcad.cli import app

    doc = regulators_document([regs["ace_de"]], robot=arm)
    del doc["regulators"][0]["gains"]["gear_efficiency"]
    path = tmp_path / "old.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    laws = Path(__file__).resolve().parents[1] / "examples" / "fig3_laws.yaml"
    r = CliRunner().invoke(app, ["simulate", "cylindrical", "-t", str(laws),
                                 "-r", str(path), "--t-end", "0.01", "--dt", "1e-3",
                                 "--out", str(tmp_path / "run")], env={"COLUMNS": "200"})
    assert r.exit_code == 0, r.output
    out = " ".join(r.output.split())
    assert "gear_efficiency missing: η = 1 assumed" in out and "re-synthesize" in out
