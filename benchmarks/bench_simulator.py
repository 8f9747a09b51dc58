"""Benchmark: the closed-loop simulator's real-time factor against python-control, in one run.

Usage::

    python benchmarks/bench_simulator.py [--t-end 1.0] [--rounds 5] [--json out.json]
                                         [--profile] [--no-python-rk4]
                                         [--part python-control|integrators|ur5]

``--part integrators`` and ``--part ur5`` compare the
adaptive integrators with RK4 (PUMA + drives + PD at 1 kHz; LQR-GS and ASVS on the
cylindrical arm) and the rigid UR5 PD job with MuJoCo and Drake; see
benchmarks/_bench_integrators.py. The default part is the comparison below.

The closed loop: the 6-joint PUMA 560 of the catalog with
its DC drives' electrical dynamics (armature inductance L kept: one current
state per joint, 18 states in all), rigid gears with rotor inertia, viscous
and dry friction, and a PD regulator on every joint (the ``pid`` regulator
with k_i = 0, plus the back-EMF feed-forward k_ff·q̇_ref; gains of
examples/pid_puma.yaml), following a 1 s quintic move of all six joints.

What is timed (``time.perf_counter``, wall clock; real-time factor RTF =
simulated seconds per wall second):

* **manipcad**: ``manipcad.simulate`` — fixed-step RK4, dt = 1e-4 s, the
  regulators sampled every step (period = dt, the closest match to the
  peer's continuous PD law), every step recorded; the whole call (setup,
  reference sampling, compiled loop, metrics), after a warm-up call that
  compiles (or loads the cached compilation).
* **python-control** (the peer): ``control.input_output_response`` of a
  ``NonlinearIOSystem`` whose update function computes the same PD law and
  drive equations in NumPy and the multibody part with Pinocchio's
  ``pin.aba`` (rotor inertia as ``model.armature``); default solver
  (``solve_ivp`` RK45, default tolerances), output every 1 ms.
* **Python RK4 + pin.aba**: a hand-written fixed-step RK4 loop (dt = 1e-4 s)
  over the same update function, on a tenth of the time (scaled).

The cases are interleaved, each round times each once; the table shows the
best (and median) wall time over the rounds. The agreement of the peers with
manipcad (max |Δq| over the move) is printed so the three are seen to
integrate the same closed loop.

Targets: RTF >= 20 and >= 10x the python-control peer.

``--profile`` adds a breakdown of one simulator step: compiled micro-loops
timing the right-hand side (drives + ABA) and the ABA alone per call, and
the share of ``simulate`` spent outside the compiled loop.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import control as ct
import numba
import numpy as np
import pinocchio as pin
from _core_calls import core_calls
from _puma_job import DT, KD, KFF, KP, Q_END, Q_START, U_LIMIT, load_puma, pd_regulators

import manipcad
from manipcad.codegen import simulation_kernels
from manipcad.model.to_pinocchio import to_pinocchio
from manipcad.sim import simulate
from manipcad.trajectories import quintic

OURS = "manipcad simulate (RK4, compiled)"
PEER = "python-control input_output_response (RK45)"
PYRK4 = "Python RK4 loop + pin.aba"
SMOOTH = ", no dry friction"


# ------------------------------------------------------------------ manipcad


def run_manipcad(robot, traj, t_end: float):
    regs = pd_regulators()
    return simulate(robot, t_end=t_end, dt=DT, trajectory=traj, regulators=regs)


# --------------------------------------------------------------- the peers


class Peer:
    """The same closed loop as one NumPy/Pinocchio right-hand side f(t, x), x = (q, q̇, i)."""

    def __init__(self, robot, duration: float) -> None:
        self.n = n = robot.n
        self.model, order = to_pinocchio(robot, armature=True)
        assert list(order) == list(range(n)), "the PUMA is a chain: Pinocchio keeps our order"
        self.data = self.model.createData()
        self.offset = robot.offset.copy()
        d = robot.drives
        self.G = np.array([x.ratio for x in d])
        self.R = np.array([x.R for x in d])
        self.L = np.array([x.L for x in d])
        self.k_m = np.array([x.k_m for x in d])
        self.k_w = np.array([x.k_w for x in d])
        self.k_u = np.array([x.k_u for x in d])
        self.u_max = np.array([x.u_max for x in d])
        self.bv = np.array([x.k_v * x.ratio**2 for x in d])  # joint-side viscous friction
        self.fcp = np.array([abs(x.ratio) * x.M_f[0] for x in d])  # joint-side dry friction
        self.fcn = np.array([abs(x.ratio) * x.M_f[1] for x in d])
        self.T = duration

    def reference(self, t: float):
        """The quintic move (the same law as manipcad.trajectories.quintic)."""
        s = min(max(t / self.T, 0.0), 1.0)
        dq = Q_END - Q_START
        q = Q_START + dq * (10 * s**3 - 15 * s**4 + 6 * s**5)
        if t >= self.T:
            return q, np.zeros(self.n)
        qd = dq * (30 * s**2 - 60 * s**3 + 30 * s**4) / self.T
        return q, qd

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        n = self.n
        q, qd, i = x[:n], x[n:2 * n], x[2 * n:]
        qr, qdr = self.reference(t)
        U = np.clip(KP * (qr - q) + KD * (qdr - qd) + KFF * qdr, -U_LIMIT, U_LIMIT)
        ua = np.clip(self.k_u * U, -self.u_max, self.u_max)
        di = (ua - self.R * i - self.k_w * self.G * qd) / self.L
        fric = np.where(qd > 0, self.fcp, np.where(qd < 0, -self.fcn, 0.0))
        tau = self.G * self.k_m * i - self.bv * qd - fric
        qdd = pin.aba(self.model, self.data, q + self.offset, qd, tau)
        return np.concatenate([qd, qdd, di])

    def x0(self) -> np.ndarray:
        return np.concatenate([Q_START, np.zeros(2 * self.n)])


def run_python_control(peer: Peer, t_end: float):
    sys_ = ct.nlsys(lambda t, x, u, params: peer.rhs(t, x), None, inputs=0,
                    states=3 * peer.n, outputs=3 * peer.n, name="puma_pd")
    T = np.linspace(0.0, t_end, int(round(t_end / 1e-3)) + 1)
    return ct.input_output_response(sys_, T, X0=peer.x0())


def run_python_rk4(peer: Peer, t_end: float):
    x = peer.x0()
    K = int(round(t_end / DT))
    out = np.empty((K + 1, x.size))
    out[0] = x
    f = peer.rhs
    for k in range(K):
        t = k * DT
        k1 = f(t, x)
        k2 = f(t + DT / 2, x + DT / 2 * k1)
        k3 = f(t + DT / 2, x + DT / 2 * k2)
        k4 = f(t + DT, x + DT * k3)
        x = x + DT / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[k + 1] = x
    return out


# ------------------------------------------------------------------ profile


def profile(robot, traj, t_end: float, reps: int = 20000) -> dict:
    """Per-call cost of the simulator's compiled pieces, and simulate()'s Python share."""
    from manipcad.control import kind_of
    from manipcad.control.pid import PID_KD, PID_KP, PID_ULIM
    from manipcad.control.signals import NPARAM, NSIG, NSTATE
    from manipcad.drives.coupling import drive_rates
    from manipcad.drives.params import joint_referred_terms, pack_drives, state_offsets
    from manipcad.dynamics.aba import ABA_WORK, aba_one
    from manipcad.model.robot import COL_BV, COL_FCN, COL_FCP, COL_JR
    from manipcad.sim.events import no_events
    from manipcad.sim.loop import Plant, _rates, regulator_update
    from manipcad.sim.pickup import no_pickup

    dtable = pack_drives(robot.drives, order=3)
    off = state_offsets(dtable)
    rtable = np.array(robot.table)
    rtable[:, [COL_JR, COL_BV, COL_FCP, COL_FCN]] = joint_referred_terms(dtable)
    n = robot.n
    g = robot.gravity.copy()
    rng = np.random.default_rng(0)
    x = np.concatenate([Q_START, rng.normal(size=n) * 0.3, rng.normal(size=off[-1])])
    U = rng.normal(size=n)
    dist = np.zeros(n)

    @numba.njit(cache=False)
    def loop_rates(reps, x, U, dist, n, plant):
        # the simulator's inlined right-hand side (rigid drives written out, ABA inlined)
        nx = x.size
        K4 = np.empty((4, nx))
        q = np.empty(n)
        qd = np.empty(n)
        qdd = np.empty(n)
        tau = np.empty(n)
        xd = np.empty(nx - 2 * n)
        dxd = np.empty(nx - 2 * n)
        fext = np.zeros((n, 6))
        work = np.empty((n, ABA_WORK))
        s = 0.0
        for _ in range(reps):
            x[0] += 1e-12
            _rates(x, U, dist, n, plant, q, qd, xd, dxd, tau, qdd, K4, 0, fext, work)
            s += K4[0, n]
        return s

    @numba.njit(cache=False)
    def loop_aba(reps, x, U, n, rtable, g):
        tau = U.copy()
        qdd = np.empty(n)
        fext = np.zeros((n, 6))
        work = np.empty((n, ABA_WORK))
        s = 0.0
        q = x[:n].copy()
        qd = x[n:2 * n].copy()
        for _ in range(reps):
            q[0] += 1e-12
            aba_one(rtable, g, q, qd, tau, fext, False, True, work, qdd)
            s += qdd[0]
        return s

    @numba.njit(cache=False)
    def loop_drives(reps, x, U, n, dtable, off):
        tau = np.empty(n)
        dxd = np.empty(off[n])
        q = x[:n].copy()
        qd = x[n:2 * n].copy()
        xd = x[2 * n:].copy()
        s = 0.0
        for _ in range(reps):
            qd[0] += 1e-12
            drive_rates(dtable, off, xd, U, q, qd, tau, dxd)
            s += dxd[0]
        return s

    @numba.njit(cache=False)
    def loop_regulators(reps, n, kind, rparam):
        sig = np.zeros((n, NSIG))
        st = np.zeros(NSTATE)
        H = np.zeros((n, n))
        U = np.zeros(n)
        joints = np.zeros((n, n), dtype=np.int64)
        for j in range(n):
            joints[j, 0] = j
        s = 0.0
        for _ in range(reps):
            for j in range(n):
                sig[j, 4] += 1e-9
                regulator_update(kind, rparam[j], st, sig, H, joints[j], 1, 1e-4, U)
                s += U[j]
        return s

    rparam = np.zeros((n, NPARAM))
    rparam[:, PID_KP], rparam[:, PID_KD], rparam[:, PID_ULIM] = KP, KD, U_LIMIT
    plant = Plant(rtable, np.ascontiguousarray(robot.table), g, dtable, off, True, False,
                  np.tile([-np.inf, np.inf], (robot.n, 1)),
                  *simulation_kernels(robot, rtable, use_generated=False), no_pickup(),
                  no_events(robot.n, 2 * robot.n + int(off[-1])))

    def per_call(fn, *args):
        fn(10, *args)  # compile
        best = np.inf
        for _ in range(15):
            t0 = time.perf_counter()
            fn(reps, *args)
            best = min(best, time.perf_counter() - t0)
        return best / reps

    out = {
        "rates (drives + ABA) per call": per_call(loop_rates, x.copy(), U, dist, n, plant),
        "ABA alone per call": per_call(loop_aba, x.copy(), U, n, rtable, g),
        "drives alone per call": per_call(loop_drives, x.copy(), U, n, dtable, off),
        "6 PID updates per step": per_call(loop_regulators, n, kind_of("pid"), rparam),
    }
    # simulate(): the compiled loop against the whole call
    best_total, best_kernel = np.inf, np.inf
    with core_calls() as kernel:
        for _ in range(10):
            t0 = time.perf_counter()
            run_manipcad(robot, traj, t_end)
            total = time.perf_counter() - t0
            if total < best_total:
                best_total, best_kernel = total, kernel[-1]
    steps = int(round(t_end / DT))
    out["simulate() whole call per step"] = best_total / steps
    out["compiled loop per step"] = best_kernel / steps
    out["simulate() outside the loop (s)"] = best_total - best_kernel
    return out


# ------------------------------------------------------------------- main


def machine_info() -> dict:
    cpu = platform.processor()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "numba": numba.__version__, "pinocchio": pin.__version__,
            "control": ct.__version__, "manipcad": manipcad.__version__,
            "load_average_at_start": os.getloadavg()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--t-end", type=float, default=1.0, help="simulated time, s (default 1)")
    ap.add_argument("--rounds", type=int, default=5, help="timing rounds (default 5)")
    ap.add_argument("--json", type=Path, default=None, help="write the results to this file")
    ap.add_argument("--profile", action="store_true", help="break one step's cost down")
    ap.add_argument("--no-python-rk4", action="store_true",
                    help="skip the hand-written Python RK4 loop")
    ap.add_argument("--part", choices=("python-control", "integrators", "ur5"),
                    default="python-control", help="which comparison (default python-control)")
    args = ap.parse_args(argv)
    t_end = args.t_end
    if args.part != "python-control":
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import _bench_integrators as bi

        machine = machine_info()
        machine["command"] = " ".join(["python", *sys.argv])
        print(f"machine: {machine['cpu']}, {machine['cores']} cores, load average at start "
              f"{', '.join(f'{x:.2f}' for x in machine['load_average_at_start'])}; "
              f"{args.rounds} rounds, medians")
        print(f"command: {machine['command']}")
        if args.part == "integrators":
            result = {"puma": bi.puma_part(args.rounds, t_end),
                      "cylindrical": bi.cylindrical_part(args.rounds, t_end)}
        else:
            result = {"ur5": bi.ur5_part(args.rounds, t_end)}
        machine["load_average_at_end"] = os.getloadavg()
        print(f"\nload average at end: "
              f"{', '.join(f'{x:.2f}' for x in machine['load_average_at_end'])}")
        if args.json:
            args.json.write_text(json.dumps({"machine": machine, **result}, indent=1))
        return 0
    machine = machine_info()
    machine["command"] = " ".join(["python", *sys.argv])

    robot = load_puma()
    smooth = robot.replace(drives=tuple(d.replace(M_f=0.0) for d in robot.drives))
    traj = quintic(Q_START, Q_END, t_end)
    peer = Peer(robot, t_end)
    peer_smooth = Peer(smooth, t_end)
    t_rk4 = t_end / 10

    # warm-up: compile (or load numba's cache), import lazily loaded modules
    t0 = time.perf_counter()
    run_manipcad(robot, traj, 0.01)
    warm = time.perf_counter() - t0
    run_python_control(peer, 0.01)

    cases = {OURS: (lambda: run_manipcad(robot, traj, t_end), t_end),
             PEER: (lambda: run_python_control(peer, t_end), t_end),
             OURS + SMOOTH: (lambda: run_manipcad(smooth, traj, t_end), t_end),
             PEER + SMOOTH: (lambda: run_python_control(peer_smooth, t_end), t_end)}
    if not args.no_python_rk4:
        cases[PYRK4] = (lambda: run_python_rk4(peer, t_rk4), t_rk4)
    times: dict[str, list[float]] = {k: [] for k in cases}
    outputs = {}
    for _ in range(args.rounds):
        for name, (fn, _sim) in cases.items():
            t0 = time.perf_counter()
            outputs[name] = fn()
            times[name].append(time.perf_counter() - t0)

    # agreement: the same closed loop?
    stride = int(round(1e-3 / DT))
    agreement = {}
    for variant in ("", SMOOTH):
        ours, pc = outputs[OURS + variant], outputs[PEER + variant]
        agreement["python-control" + variant] = float(
            np.abs(ours.q[::stride] - pc.states[:robot.n].T).max())
    if not args.no_python_rk4:
        ours, rk = outputs[OURS], outputs[PYRK4]
        agreement["Python RK4"] = float(np.abs(ours.q[:len(rk)] - rk[:, :robot.n]).max())

    rows = []
    for name, (_fn, sim) in cases.items():
        best, med = min(times[name]), statistics.median(times[name])
        rows.append({"case": name, "simulated_s": sim, "wall_best_s": best,
                     "wall_median_s": med, "rtf_best": sim / best, "rtf_median": sim / med})
    by = {r["case"]: r for r in rows}
    rtf_ours = by[OURS]["rtf_best"]
    ratios = {}
    for variant in ("", SMOOTH):
        ratios["best" + variant] = by[OURS + variant]["rtf_best"] / by[PEER + variant]["rtf_best"]
        ratios["median" + variant] = (by[OURS + variant]["rtf_median"]
                                      / by[PEER + variant]["rtf_median"])
    ratio = ratios["best"]
    targets = [("RTF >= 20", rtf_ours, rtf_ours >= 20.0),
               ("RTF >= 10x python-control", ratio, ratio >= 10.0),
               ("RTF >= 10x python-control" + SMOOTH, ratios["best" + SMOOTH],
                ratios["best" + SMOOTH] >= 10.0)]

    print(f"machine: {machine['cpu']}, {machine['cores']} cores, load average at start "
          f"{', '.join(f'{x:.2f}' for x in machine['load_average_at_start'])}")
    print(f"versions: python {machine['python']}, numpy {machine['numpy']}, numba "
          f"{machine['numba']}, pinocchio {machine['pinocchio']}, control {machine['control']}")
    print(f"command: {machine['command']}")
    print(f"closed loop: PUMA 560, 6 DC drives with L (18 states), PD on every joint, "
          f"dt = {DT:g} s, {t_end:g} s quintic move; warm-up call {warm:.2f} s; "
          f"{args.rounds} rounds\n")
    print(f"{'case':58s} {'sim s':>6s} {'wall s best (median)':>22s} "
          f"{'RTF best (median)':>20s}")
    for r in rows:
        print(f"{r['case']:58s} {r['simulated_s']:6.3g} "
              f"{r['wall_best_s']:>10.4g} ({r['wall_median_s']:.4g}) "
              f"{r['rtf_best']:>10.3g} ({r['rtf_median']:.3g})")
    print()
    for variant in ("", SMOOTH):
        print(f"manipcad / python-control RTF{variant}: {ratios['best' + variant]:.3g}x (best), "
              f"{ratios['median' + variant]:.3g}x (median)")
    for k, v in agreement.items():
        print(f"agreement with {k}: max |Δq| = {v:.2e} rad")
    for what, value, ok in targets:
        print(f"target {what}: {value:.3g} -> {'met' if ok else 'NOT met'}")

    prof = None
    if args.profile:
        prof = profile(robot, traj, t_end)
        print("\nprofile (best of 15 micro-loops, 10 simulate calls):")
        for k, v in prof.items():
            print(f"  {k:40s} {v * 1e6:10.3f} µs" if not k.endswith("(s)")
                  else f"  {k:40s} {v * 1e3:10.3f} ms")
        est = 4 * prof["rates (drives + ABA) per call"] + prof["6 PID updates per step"]
        print(f"  {'4 x rates + PID per RK4 step (estimate)':40s} {est * 1e6:10.3f} µs")

    if args.json:
        args.json.write_text(json.dumps({"machine": machine, "rows": rows, "ratios": ratios,
                                         "agreement": agreement, "profile": prof,
                                         "targets": [(w, v, ok) for w, v, ok in targets]},
                                        indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
