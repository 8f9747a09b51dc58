"""The adaptive integrators against RK4 and against MuJoCo and Drake.

Imported by ``bench_simulator.py --part integrators|ur5`` (see its docstring); kept
in its own file so the python-control comparison above stays as it was.

* **PUMA 560 with drives, PD at 1 kHz** (gains of examples/pid_puma.yaml, integral
  left out): RK4 at dt 1e-5 is the truth; timed: RK4 at dt 1e-4 (the fixed-step
  path, for the before/after of the registry), ``integrator="adaptive"``,
  ``"adaptive-exact"`` and ``"adaptive-exact-bs32"`` (grid dt 1e-4, rtol 1e-6, atol
  1e-8); with and without the drives' dry friction. Plus LQR-GS and ASVS on the
  cylindrical arm (turn), PID on the lift and LQR on the reach, all at 1 kHz, along
  the Fig. 3 laws.
* **UR5 rigid PD** (example-robot-data's UR5 URDF, no drives, torque PD
  τ = Kp·(q* − q) − Kd·q̇ to a fixed pose from the upright pose, 1 s): manipcad RK4
  (dt 1e-4, PD sampled every step as the issue measured, and at 1 kHz), manipcad
  adaptive (PD at 1 kHz; Dormand–Prince 5(4) and Bogacki–Shampine 3(2), general and
  generated kernels), positions kept every 1 ms or only at the end; MuJoCo RK4 at dt
  1e-4 with the PD in Python; MuJoCo Euler at dt 1e-4 with its own position actuators
  (kp, kv); Drake's Simulator with its default error-controlled integrator (RK3,
  default accuracy) and a continuous PidController, at a tighter accuracy, and recording
  only the end state: with the diagram built in the timed call (URDF parsed) and built
  once before (only the rewind and ``AdvanceTo`` timed). Accuracy: max |Δq| against each
  law's own truth (manipcad: RK4 at dt 1e-5 with the same sampling; the continuous PD:
  Drake at accuracy 1e-10, cross-checked with MuJoCo RK4 at dt 1e-5).
* **Like for like against Drake** (:func:`ur5_like_for_like`): the same law sampled the
  same way in both (the PD at 1 kHz: Drake's PidController behind a ZeroOrderHold of
  1 ms, agreeing with our RK4 at dt 1e-5 to 1e-12 rad), and the continuous PD (ours
  sampled at 100 kHz, its nearest twin), each at several tolerances, end state only,
  Drake's diagram built once; each of our rows (its kernels, generated or general, in
  its name) paired with the fastest Drake row of its law at least as accurate.
"""

from __future__ import annotations

import re
import statistics
import time
import warnings
from pathlib import Path

import numpy as np
from _puma_job import Q_END, Q_START, load_puma, pd_regulators

import manipcad
from manipcad.control import pid
from manipcad.errors import ManipcadWarning
from manipcad.sim import simulate
from manipcad.trajectories import cosine, quintic

ROOT = Path(__file__).resolve().parents[1]
URDF = ROOT / "examples" / "ur5" / "ur5_robot.urdf"
UR5_Q0 = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])
UR5_Q1 = np.array([0.5, -1.2, 0.6, -1.2, 0.4, 0.3])
UR5_KP = np.array([400.0, 400.0, 300.0, 50.0, 50.0, 20.0])      # N·m/rad
UR5_KD = np.array([40.0, 40.0, 30.0, 5.0, 5.0, 2.0])            # N·m·s/rad


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def _table(title, rows, t_end):
    cw = max(52, *(len(r["case"]) for r in rows))
    print(f"\n{title}")
    print(f"{'case':{cw}s} {'RTF median (min-max)':>24s} {'x RK4 1e-4':>10s} {'max |Δq|':>10s} "
          f"{'steps':>7s}")
    for r in rows:
        ws = r["wall"]
        rtf = [t_end / w for w in ws]
        print(f"{r['case']:{cw}s} {statistics.median(rtf):9.1f} ({min(rtf):.1f}-{max(rtf):.1f})"
              f"{'':4s} {r.get('ratio', float('nan')):10.2f} {r['dq']:10.2e} "
              f"{r.get('steps', ''):>7}")


def _compare(title, run, cases, rounds, t_end):
    """Time ``run(**kw)`` for each case in rounds against RK4 at dt 1e-5 (the truth);
    print the table and return its figures."""
    for kw in cases.values():  # warm-up (compile or load the cache)
        run(**kw)
    truth, w_truth = _timed(lambda: run(dt=1e-5, every=100))
    rows = {c: {"case": c, "wall": [], "ratios": []} for c in cases}
    for _ in range(rounds):
        base_w = None
        for c, kw in cases.items():
            res, w = _timed(lambda kw=kw: run(**kw))
            rows[c]["wall"].append(w)
            base_w = w if base_w is None else base_w
            rows[c]["ratios"].append(base_w / w)
            rows[c]["dq"] = float(np.abs(res.q - truth.q).max())
            rows[c]["steps"] = res.settings.get("steps", int(round(t_end / 1e-4)))
    for r in rows.values():
        r["ratio"] = statistics.median(r["ratios"])
    rows["truth"] = {"case": "RK4 dt 1e-5 (truth, one run)", "wall": [w_truth],
                     "dq": 0.0, "ratio": float("nan")}
    _table(title, list(rows.values()), t_end)
    return {c: {"rtf_median": statistics.median(t_end / w for w in r["wall"]),
                "ratio_to_rk4_median": r["ratio"], "max_dq": r["dq"],
                "steps": r.get("steps")} for c, r in rows.items()}


# ------------------------------------------------------------------ PUMA + drives


def puma_part(rounds: int, t_end: float) -> dict:

    out = {}
    base = load_puma()
    variants = {"with dry friction": base,
                "no dry friction": base.replace(drives=tuple(d.replace(M_f=0.0)
                                                             for d in base.drives))}
    traj = quintic(Q_START, Q_END, t_end)

    def regs():
        return pd_regulators(period=1e-3)

    general = dict(dt=1e-4, every=10, use_generated=False)
    cases = {"RK4 dt 1e-4": general,
             "adaptive (rtol 1e-6, atol 1e-8)": dict(general, integrator="adaptive",
                                                     rtol=1e-6, atol=1e-8),
             "adaptive-exact (rtol 1e-6, atol 1e-8)": dict(general,
                                                           integrator="adaptive-exact",
                                                           rtol=1e-6, atol=1e-8),
             # the robot's customized kernels (manipcad codegen)
             "RK4 dt 1e-4, generated kernels": dict(general, use_generated=True),
             "adaptive-exact, generated kernels": dict(general, use_generated=True,
                                                       integrator="adaptive-exact",
                                                       rtol=1e-6, atol=1e-8),
             "adaptive-exact-bs32, generated kernels": dict(
                 general, use_generated=True, integrator="adaptive-exact-bs32", rtol=1e-6,
                 atol=1e-8)}
    from manipcad.codegen import generate

    for vname, robot in variants.items():
        generate(robot)
        def run(robot=robot, **kw):
            return simulate(robot, t_end=t_end, trajectory=traj, regulators=regs(), **kw)

        out[vname] = _compare(f"PUMA 560, 6 drives with L, PD at 1 kHz, {t_end:g} s quintic, "
                              f"{vname}", run, cases, rounds, t_end)
    return out


def cylindrical_part(rounds: int, t_end: float) -> dict:
    """LQR-GS and ASVS on the turn (the Fig. 3 laws), RK4 vs adaptive."""
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = manipcad.load_robot("cylindrical")
    traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=t_end)
    for method in ("lqr_gs", "asvs"):
        for vname, robot in (("with dry friction", arm),
                             ("no dry friction", arm.replace(drives=tuple(
                                 d.replace(M_f=0.0) for d in arm.drives)))):
            regs = [manipcad.synthesize(robot, "turn", method, period=1e-3),
                    manipcad.synthesize(robot, "lift", "pid", period=1e-3),
                    manipcad.synthesize(robot, "reach", "lqr", period=1e-3)]

            def run(robot=robot, regs=regs, **kw):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", ManipcadWarning)
                    return simulate(robot, t_end=t_end, trajectory=traj, regulators=regs,
                                    **kw)

            cases = {"RK4 dt 1e-4": dict(dt=1e-4, every=10),
                     "adaptive": dict(dt=1e-4, every=10, integrator="adaptive"),
                     "adaptive-exact": dict(dt=1e-4, every=10,
                                            integrator="adaptive-exact"),
                     "adaptive-exact-bs32": dict(dt=1e-4, every=10,
                                                 integrator="adaptive-exact-bs32")}
            out[f"{method}, {vname}"] = _compare(
                f"cylindrical arm, {method} on turn + PID lift + LQR reach at 1 kHz, "
                f"{t_end:g} s Fig. 3 laws, {vname}", run, cases, rounds, t_end)
    return out


# ------------------------------------------------------------------ UR5 peers


def _urdf_text() -> str:
    """The UR5 URDF without meshes (visual/collision), for MuJoCo and Drake."""
    text = URDF.read_text()
    text = re.sub(r"<visual>.*?</visual>", "", text, flags=re.S)
    return re.sub(r"<collision>.*?</collision>", "", text, flags=re.S)


def ur5_manipcad(robot, t_end, dt, period, integrator="rk4", record=True, **kw):
    """Our UR5 job; positions every 1 ms (``record``), or only at t_end (rows of nan
    before, as :func:`ur5_drake`: ``every`` the whole run, so the result keeps
    t = 0 and t_end)."""
    regs = [pid(j, kp=UR5_KP[j], kd=UR5_KD[j], period=period) for j in range(6)]

    class Hold:
        def sample(self, t):
            z = np.zeros((len(t), 6))
            return np.tile(UR5_Q1, (len(t), 1)), z, z.copy()

    K = int(round(t_end / dt))
    every = max(1, int(round(1e-3 / dt))) if record else K
    kw.setdefault("use_generated", False)
    res = simulate(robot, t_end=t_end, dt=dt, trajectory=Hold(), q0=UR5_Q0,
                   regulators=regs, drives=False, every=every,
                   integrator=integrator, joint_limits="ignore", **kw)
    q = res.q
    if not record:
        q = np.full((int(round(t_end / 1e-3)) + 1, 6), np.nan)
        q[0], q[-1] = res.q[0], res.q[-1]
    return q, res.settings.get("steps", K), integrator


def ur5_mujoco(t_end, dt, own_actuators=False):
    import mujoco

    text = _urdf_text().replace(
        "<robot name=\"ur5\">",
        "<robot name=\"ur5\"><mujoco><compiler discardvisual=\"true\" fusestatic=\"false\" "
        "balanceinertia=\"false\"/></mujoco>", 1)
    if own_actuators:
        spec = mujoco.MjSpec.from_string(text)
        for j, name in enumerate(["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                  "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]):
            act = spec.add_actuator()
            act.name = f"pd_{name}"
            act.target = name
            act.trntype = mujoco.mjtTrn.mjTRN_JOINT
            act.set_to_position(kp=UR5_KP[j], kv=UR5_KD[j])
        model = spec.compile()
        model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    else:
        model = mujoco.MjModel.from_xml_string(text)
        model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model.opt.timestep = dt
    model.opt.gravity[:] = (0.0, 0.0, -9.81)
    data = mujoco.MjData(model)
    data.qpos[:] = UR5_Q0
    K = int(round(t_end / dt))
    every = max(1, int(round(1e-3 / dt)))
    out = np.empty((K // every + 1, 6))
    if own_actuators:
        data.ctrl[:] = UR5_Q1
    for k in range(K + 1):
        if k % every == 0:
            out[k // every] = data.qpos
        if k == K:
            break
        if not own_actuators:
            data.qfrc_applied[:] = UR5_KP * (UR5_Q1 - data.qpos) - UR5_KD * data.qvel
        mujoco.mj_step(model, data)
    return out


def ur5_drake(t_end, accuracy=None, record=True, built=None, period=None):
    """Drake's Simulator, default integrator; positions every 1 ms (``record``: the
    run stops at each, as our adaptive one stops at each sample) or only at t_end
    (rows of nan before). The diagram (URDF parsed, plant finalized, PID connected) and
    the Simulator are built in the call, or ``built`` (:func:`ur5_drake_built`) is
    rewound to t = 0 and the start state and run again. ``period`` (s): the PD sampled
    and held as ours (a ZeroOrderHold on the state, started at the start state); None:
    Drake's continuous PD."""
    sim, plant, integ, zoh = built if built is not None else ur5_drake_built(accuracy, period)
    ctx = sim.get_mutable_context()
    pctx = plant.GetMyMutableContextFromRoot(ctx)
    if built is not None:
        ctx.SetTime(0.0)
        plant.SetVelocities(pctx, np.zeros(6))
        integ.ResetStatistics()
    plant.SetPositions(pctx, UR5_Q0)
    if zoh is not None:
        zoh.SetVectorState(zoh.GetMyMutableContextFromRoot(ctx),
                           np.concatenate([UR5_Q0, np.zeros(6)]))
    sim.Initialize()
    n = int(round(t_end / 1e-3))
    out = np.full((n + 1, 6), np.nan)
    out[0] = plant.GetPositions(pctx)
    if record:
        for k in range(1, n + 1):
            sim.AdvanceTo(k * 1e-3)
            out[k] = plant.GetPositions(pctx)
    else:
        sim.AdvanceTo(t_end)
        out[n] = plant.GetPositions(pctx)
    return out, integ.get_num_steps_taken(), type(integ).__name__


def ur5_drake_built(accuracy=None, period=None):
    """The UR5 PD job's Drake diagram and Simulator: (simulator, plant, integrator,
    zero-order hold or None). ``period``: the PD sees the state through a ZeroOrderHold
    of that period (the law sampled as ours samples it); None: continuously."""
    from pydrake.all import (
        ConstantVectorSource,
        DiagramBuilder,
        MultibodyPlant,
        Parser,
        PidController,
        Simulator,
        ZeroOrderHold,
    )

    b = DiagramBuilder()
    plant = b.AddSystem(MultibodyPlant(0.0))
    Parser(plant).AddModelsFromString(_urdf_text(), "urdf")
    plant.Finalize()
    pidc = b.AddSystem(PidController(UR5_KP, np.zeros(6), UR5_KD))
    ref = b.AddSystem(ConstantVectorSource(np.concatenate([UR5_Q1, np.zeros(6)])))
    zoh = None
    if period is None:
        b.Connect(plant.get_state_output_port(), pidc.get_input_port_estimated_state())
    else:
        zoh = b.AddSystem(ZeroOrderHold(period, 12))
        b.Connect(plant.get_state_output_port(), zoh.get_input_port())
        b.Connect(zoh.get_output_port(), pidc.get_input_port_estimated_state())
    b.Connect(ref.get_output_port(), pidc.get_input_port_desired_state())
    b.Connect(pidc.get_output_port_control(), plant.get_applied_generalized_force_input_port())
    diagram = b.Build()
    sim = Simulator(diagram)
    integ = sim.get_mutable_integrator()
    if accuracy is not None:
        integ.set_target_accuracy(accuracy)
    return sim, plant, integ, zoh


def ur5_like_for_like(robot, rounds: int, t_end: float) -> dict:
    """Against Drake like for like: the same PD law sampled the same way, only the end
    state kept by both, Drake's diagram built once, each at several tolerances; every
    row's error is against its law's own truth (Drake at accuracy 1e-10, cross-checked
    with our RK4 at dt 1e-5). The ratios pair each of our rows with the fastest Drake
    row at least as accurate. Which kernels each of our rows uses is in its name."""
    end = int(round(t_end / 1e-3))
    laws = {"PD sampled at 1 kHz": 1e-3, "continuous PD": None}
    truth = {law: ur5_drake(t_end, 1e-10, record=False, period=p)[0][end]
             for law, p in laws.items()}
    ours_rk4 = ur5_manipcad(robot, t_end, 1e-5, 1e-3)[0][end]
    print(f"\nlike for like: the 1 kHz law's truth, Drake (accuracy 1e-10, ZeroOrderHold) "
          f"vs manipcad RK4 dt 1e-5: {np.abs(truth['PD sampled at 1 kHz'] - ours_rk4).max():.1e}"
          " rad")
    cases = {}  # name: (law, kind, fn)
    for law, period in laws.items():
        for acc in (None, 1e-4, 1e-6, 1e-8):
            built = ur5_drake_built(acc, period)
            cases[f"Drake default integrator, accuracy {acc or 'default'}, {law}"] = (
                law, "drake", lambda b=built, p=period: ur5_drake(t_end, record=False,
                                                                 built=b, period=p))
    # ours: the sampled law at its own sample times; the continuous law has no twin in
    # manipcad (regulators are digital): its closest is the PD sampled every 1e-5 s
    for integ in ("adaptive-bs32", "adaptive"):
        for gen in (True, False):
            for rtol in (1e-4, 1e-6, 1e-8):
                kern = "generated" if gen else "general"
                cases[f"manipcad {integ}, rtol {rtol:g}, {kern} kernels, PD sampled at 1 kHz"] = (
                    "PD sampled at 1 kHz", "ours",
                    lambda i=integ, g=gen, r=rtol: ur5_manipcad(
                        robot, t_end, 1e-4, 1e-3, i, record=False, use_generated=g, rtol=r,
                        atol=r * 1e-2))
    for rtol in (1e-6, 1e-8):
        cases[f"manipcad adaptive-bs32, rtol {rtol:g}, generated kernels, PD sampled at "
              "100 kHz (continuous PD)"] = (
            "continuous PD", "ours",
            lambda r=rtol: ur5_manipcad(robot, t_end, 1e-5, 1e-5, "adaptive-bs32",
                                        record=False, use_generated=True, rtol=r,
                                        atol=r * 1e-2))
    for _law, _k, fn in cases.values():  # warm-up
        fn()
    wall = {c: [] for c in cases}
    err = {}
    for _ in range(rounds):
        for c, (law, _k, fn) in cases.items():
            out, w = _timed(fn)
            wall[c].append(w)
            err[c] = float(np.abs(out[0][end] - truth[law]).max())
    med = {c: statistics.median(w) for c, w in wall.items()}
    cw = max(len(c) for c in cases)
    print(f"\nUR5 like for like, only the end state kept, {t_end:g} s, medians of "
          f"{rounds} rounds:")
    print(f"{'case':{cw}s} {'RTF':>8s} {'max |Δq|, rad':>14s}")
    for c in cases:
        print(f"{c:{cw}s} {t_end / med[c]:8.1f} {err[c]:14.2e}")
    pairs = {}
    print("\nat equal accuracy (each of our rows against the fastest Drake row of the same "
          "law at least as accurate):")
    for c, (law, kind, _fn) in cases.items():
        if kind != "ours":
            continue
        peers = [d for d, (lw, k, _f) in cases.items() if k == "drake" and lw == law
                 and err[d] <= err[c]]
        if not peers:
            # none as accurate: against the most accurate Drake row of the law
            d = min((d for d, (lw, k, _f) in cases.items() if k == "drake" and lw == law),
                    key=err.get)
            pairs[c] = {"peer": d, "ratio": med[d] / med[c], "error": err[c],
                        "peer_error": err[d], "peer_less_accurate": True}
            print(f"  {c}: no Drake row reaches {err[c]:.1e} rad; {med[d] / med[c]:.2f}x the "
                  f"most accurate, {d} ({err[d]:.1e} rad)")
            continue
        d = min(peers, key=med.get)
        pairs[c] = {"peer": d, "ratio": med[d] / med[c], "error": err[c],
                    "peer_error": err[d]}
        print(f"  {c}: {med[d] / med[c]:.2f}x {d} ({err[c]:.1e} / {err[d]:.1e} rad)")
    return {"rows": {c: {"rtf_median": t_end / med[c], "max_dq_rad": err[c]} for c in cases},
            "equal_accuracy": pairs}


OURS_END_BS32_GENERAL = "manipcad adaptive-bs32, PD at 1 kHz, only the end state"
OURS_END = "manipcad adaptive, PD at 1 kHz, generated, only the end state"
OURS_END_BS32 = "manipcad adaptive-bs32, PD at 1 kHz, generated, only the end state"
DRAKE_END = "Drake default integrator, continuous PD, only the end state"
DRAKE_END_BUILT = "Drake default integrator, continuous PD, only the end state, diagram built once"


def ur5_part(rounds: int, t_end: float) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        robot = manipcad.load_robot(str(URDF))
    try:
        import pydrake  # noqa: F401
        have_drake = True
    except ImportError:
        have_drake = False
        print("Drake (pip install drake) is not installed: MuJoCo only")
    from manipcad.codegen import generate

    generate(robot)      # the customized kernels, used only where a case asks for them
    # truths
    truth_ours_1k = ur5_manipcad(robot, t_end, 1e-5, 1e-3)[0]
    truth_cont = (ur5_drake(t_end, 1e-10)[0] if have_drake
                  else ur5_mujoco(t_end, 1e-5))
    check = ur5_mujoco(t_end, 1e-5)
    print(f"\nUR5 truths: continuous PD, Drake at accuracy 1e-10 vs MuJoCo RK4 at dt 1e-5: "
          f"max |Δq| = {np.abs(truth_cont - check).max():.2e} rad")
    truth_ours_cont = ur5_manipcad(robot, t_end, 1e-5, 1e-5)[0]
    print(f"manipcad PD sampled every 1e-5 s vs the continuous-PD truth: "
          f"{np.abs(truth_ours_cont - truth_cont).max():.2e} rad")
    cases = {
        "manipcad RK4 dt 1e-4, PD every step": (
            lambda: ur5_manipcad(robot, t_end, 1e-4, 1e-4), truth_cont),
        "manipcad RK4 dt 1e-4, PD at 1 kHz": (
            lambda: ur5_manipcad(robot, t_end, 1e-4, 1e-3), truth_ours_1k),
        "manipcad adaptive, PD at 1 kHz (rtol 1e-6)": (
            lambda: ur5_manipcad(robot, t_end, 1e-4, 1e-3, "adaptive"), truth_ours_1k),
        "manipcad adaptive, PD at 1 kHz (rtol 1e-4, atol 1e-6)": (
            lambda: ur5_manipcad(robot, t_end, 1e-4, 1e-3, "adaptive", rtol=1e-4,
                                 atol=1e-6), truth_ours_1k),
        "manipcad adaptive, PD at 1 kHz, generated kernels": (
            lambda: ur5_manipcad(robot, t_end, 1e-4, 1e-3, "adaptive", use_generated=True),
            truth_ours_1k),
        "manipcad adaptive-bs32, PD at 1 kHz, generated kernels": (
            lambda: ur5_manipcad(robot, t_end, 1e-4, 1e-3, "adaptive-bs32",
                                 use_generated=True), truth_ours_1k),
        OURS_END_BS32_GENERAL: (
            lambda: ur5_manipcad(robot, t_end, 1e-4, 1e-3, "adaptive-bs32", record=False),
            truth_ours_1k),
        OURS_END: (
            lambda: ur5_manipcad(robot, t_end, 1e-4, 1e-3, "adaptive", record=False,
                                 use_generated=True), truth_ours_1k),
        OURS_END_BS32: (
            lambda: ur5_manipcad(robot, t_end, 1e-4, 1e-3, "adaptive-bs32", record=False,
                                 use_generated=True), truth_ours_1k),
        "MuJoCo RK4 dt 1e-4, PD in Python": (lambda: ur5_mujoco(t_end, 1e-4), truth_cont),
        "MuJoCo Euler dt 1e-4, own actuators": (
            lambda: ur5_mujoco(t_end, 1e-4, own_actuators=True), truth_cont),
    }
    steps = {}
    if have_drake:
        cases["Drake default integrator (accuracy default), continuous PD"] = (
            lambda: ur5_drake(t_end), truth_cont)
        cases[DRAKE_END] = (lambda: ur5_drake(t_end, record=False), truth_cont)
        built = ur5_drake_built()
        cases[DRAKE_END_BUILT] = (lambda: ur5_drake(t_end, record=False, built=built),
                                  truth_cont)
        cases["Drake default integrator, accuracy 1e-6, continuous PD"] = (
            lambda: ur5_drake(t_end, 1e-6), truth_cont)
    for fn, _ in cases.values():  # warm-up
        fn()
    rows = {c: {"case": c, "wall": [], "ratios": []} for c in cases}
    for _ in range(rounds):
        base_w = None
        for c, (fn, truth) in cases.items():
            q, w = _timed(fn)
            if isinstance(q, tuple):
                q, steps[c], _name = q
            rows[c]["wall"].append(w)
            base_w = w if base_w is None else base_w
            rows[c]["ratios"].append(base_w / w)
            rows[c]["dq"] = float(np.nanmax(np.abs(q - truth)))
            rows[c]["steps"] = steps.get(c, "")
    for r in rows.values():
        r["ratio"] = statistics.median(r["ratios"])
    _table(f"UR5 rigid, torque PD to a fixed pose, {t_end:g} s (ratio column: x the first "
           "row)", list(rows.values()), t_end)
    against = ur5_like_for_like(robot, rounds, t_end) if have_drake else {}
    return {**{c: {"rtf_median": statistics.median(t_end / w for w in r["wall"]),
                   "ratio_to_first_median": r["ratio"], "max_dq_rad": r["dq"],
                   "steps": r.get("steps")} for c, r in rows.items()},
            "against_drake_like_for_like": against}
