"""Benchmark: customized generated dynamics against Pinocchio and the general kernels, one run.

Usage::

    python benchmarks/bench_codegen.py [--rounds R] [--json out.json]

Robots: the UR5 (6 joints) and the Panda (7 arm joints + 2 finger joints, a
tree) URDFs of ``example-robot-data``, loaded by :func:`manipcad.load_robot`
(rigid bodies, as Pinocchio sees them), and the catalog PUMA 560 with its
drives for the right-hand side of the closed loop.

What is timed (``time.perf_counter``, wall clock, per state):

* ``pin.rnea`` single: a Python loop of calls over prebuilt per-state arrays;
* generated single: ``gen.inverse_dynamics(q, qd, qdd, False)`` in the same kind of loop;
* general single: ``manipcad.inverse_dynamics(..., drives=False, use_generated=False)``;
* generated single through the public API: ``manipcad.inverse_dynamics(..., drives=False,
  use_generated=True)`` on the robot ``generate`` attached the kernels to (its argument
  checks and dispatch on top of the generated call);
* generated batch / general batch: one call on N = 10,000 states divided by N
  (the general batch on one thread, as the generated batch runs);
* right-hand side (forward dynamics with the drive terms, PUMA 560): the
  generated kernel and the general ABA kernel in a batch of N states, per
  state; and a compiled loop calling the generated C-ABI kernel
  (``gen.cfunc``, passed as an argument) against the same loop with the
  general ``aba_state`` inlined, as the simulator's right-hand side does; and
  the closed loop's whole right-hand side as the simulator evaluates it
  (``sim/loop.py`` ``_rates``: the drives' equations, then the forward dynamics),
  generated and general, on states with random currents and amplifier inputs;
* the closed loop of ``benchmarks/bench_simulator.py`` (PUMA 560, drives with
  inductance, PD, dt = 1e-4 s, RK4, 1 s): ``simulate`` with
  ``use_generated=True`` and ``False``, wall time and real-time factor; and,
  labelled as variants (not the benchmark's job), the generated run with the PD
  sampled every 1 ms, and that with only every 10th step kept (``every``);
* generation: ``generate`` of a 7-joint arm (the xArm7 URDF) into an empty
  cache (symbolic work, cse and printing), then the first numba compile of
  its inverse dynamics kernel, then a second ``generate`` (cache hit).

Cases are interleaved: every round times each case once, in a new random
order; the table shows the minimum over rounds and (in brackets) the median.

Targets: generated single call <= 0.5x Pinocchio's, batch
<= 0.1x per state, generation of a 7-joint arm < 5 s, simulator RTF >= 100.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numba
import numpy as np
import pinocchio as pin

import manipcad
from manipcad.codegen import generate
from manipcad.dynamics.aba import ABA_WORK, aba_state
from manipcad.errors import ManipcadWarning
from manipcad.sim.borrow import address, borrowed, keep, row
from manipcad.sim.loop import Plant, _rates, scratch

sys.path.insert(0, str(Path(__file__).parent))
from bench_dynamics import ur5_urdf  # noqa: E402  (the one locator of the data set)

N_BATCH = 10_000


def erd(rel: str) -> Path:
    """A URDF of example-robot-data by its path under robots/."""
    ur5 = ur5_urdf()
    if ur5 is None:
        sys.exit("example-robot-data is not installed (pip install example-robot-data)")
    return ur5.parents[2] / rel


def load(path) -> manipcad.Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot(path)


@numba.njit(cache=True)
def loop_cfunc(f, Q, QD, T, OUT):
    """A compiled loop calling a generated C-ABI kernel per state (as a simulator would)."""
    n = Q.shape[1]
    q, qd, tau, qdd = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for k in range(Q.shape[0]):
        for j in range(n):
            q[j] = Q[k, j]
            qd[j] = QD[k, j]
            tau[j] = T[k, j]
        f(q.ctypes.data, qd.ctypes.data, tau.ctypes.data, qdd.ctypes.data)
        for j in range(n):
            OUT[k, j] = qdd[j]


@numba.njit(cache=True)
def chain_cfunc(f, q, qd, tau, N):
    """N calls of a generated C-ABI forward dynamics, each waiting for the previous one's
    accelerations (q += 1e-12·q̈ between them), as RK4's stages wait: the call's latency."""
    n = q.shape[0]
    qdd = np.empty(n)
    for _ in range(N):
        f(address(q), address(qd), address(tau), address(qdd))
        for j in range(n):
            q[j] += 1e-12 * qdd[j]


@numba.njit(cache=True)
def loop_aba(table, g, Q, QD, T, OUT):
    """The same loop with the general ABA inlined (what sim/loop.py does today)."""
    n = Q.shape[1]
    q, qd, tau, qdd = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    work, fext = np.empty((n, ABA_WORK)), np.zeros((n, 6))
    for k in range(Q.shape[0]):
        for j in range(n):
            q[j] = Q[k, j]
            qd[j] = QD[k, j]
            tau[j] = T[k, j]
        aba_state(table, g, q, qd, tau, fext, False, True, work, qdd)
        for j in range(n):
            OUT[k, j] = qdd[j]


@numba.njit(cache=True)
def loop_rates(plant, X, U, D, OUT):
    """The closed loop's whole right-hand side per state, as the simulator evaluates it:
    ``sim/loop.py`` ``_rates`` (the drives' equations, then the forward dynamics)."""
    n = plant.rtable.shape[0]
    nx = X.shape[1]
    own = (np.empty((4, nx)), scratch(n, nx))
    # as in sim/loop.py run: the arrays without owners (no reference counts per state)
    plant, bare = borrowed((plant, own))
    K4, scr = bare
    q, qd, qdd, xd, dxd, tau, sig, H, fext, awork, comp = scr
    for k in range(X.shape[0]):
        _rates(row(X, k), row(U, k), row(D, k), n, plant, q, qd, xd, dxd, tau, qdd, K4, 0,
               fext, awork)
        for j in range(nx):
            OUT[k, j] = K4[0, j]
    keep(own)


def closed_loop_plant(robot, use_generated: bool):
    """The simulator's :class:`~manipcad.sim.loop.Plant` of the benchmark's closed loop
    (rigid drives with inductance, the drive terms in the body table), as ``simulate``
    builds it."""
    from manipcad.codegen import simulation_kernels
    from manipcad.drives.params import joint_referred_terms, pack_drives, state_offsets
    from manipcad.model.robot import COL_BV, COL_FCN, COL_FCP, COL_JR
    from manipcad.sim.events import no_events
    from manipcad.sim.pickup import no_pickup

    dtable = pack_drives(robot.drives, None, order=3)
    rtable = np.array(robot.table)
    rtable[:, [COL_JR, COL_BV, COL_FCP, COL_FCN]] = joint_referred_terms(dtable)
    gen = simulation_kernels(robot, rtable, use_generated=use_generated)
    assert gen[0] == use_generated
    limits = np.tile([-np.inf, np.inf], (robot.n, 1))
    return Plant(rtable, np.array(robot.table), np.asarray(robot.gravity, float), dtable,
                 state_offsets(dtable), True, False, limits, *gen, no_pickup(),
                 no_events(robot.n, 2 * robot.n + int(state_offsets(dtable)[-1])))


def per_state(fn, *args, **kwargs):
    """A case timing one call on a batch of N_BATCH states, per state."""

    def case() -> float:
        t = time.perf_counter()
        fn(*args, **kwargs)
        return (time.perf_counter() - t) / N_BATCH

    return case


def loop(fn, args) -> float:
    t = time.perf_counter()
    for a in args:
        fn(*a)
    return (time.perf_counter() - t) / len(args)


def bench_id(label: str, path: Path, rounds: int, rng) -> dict:
    robot = load(path)
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    names = [model.names[j] for j in range(1, model.njoints)]
    order = np.array([robot.joint_names.index(nm) for nm in names])
    n = robot.n
    gen = generate(robot)   # attached: the public functions call it (use_generated=True)
    Q, QD, QDD = rng.uniform(-1.5, 1.5, (3, N_BATCH, n))
    k1 = 1000
    ours = [(Q[k].copy(), QD[k].copy(), QDD[k].copy(), False) for k in range(k1)]
    general = [(robot, *a[:3]) for a in ours]
    qp = (Q + robot.offset)[:, order]
    pins = [(model, data, qp[k].copy(), QD[k, order].copy(), QDD[k, order].copy())
            for k in range(k1)]
    # agreement with Pinocchio (rigid body)
    tau = gen.inverse_dynamics(Q[:50], QD[:50], QDD[:50], False)
    err = max(np.abs(tau[k, order] - pin.rnea(*pins[k])).max()
              / np.abs(pin.rnea(*pins[k])).max() for k in range(50))
    TAU = np.empty_like(Q)
    kb = gen.kernel("inverse_dynamics_batch")

    def general_single(r, q, qd, qdd):
        manipcad.inverse_dynamics(r, q, qd, qdd, drives=False, use_generated=False)

    def public_single(r, q, qd, qdd):
        manipcad.inverse_dynamics(r, q, qd, qdd, drives=False, use_generated=True)

    cases = {
        "pinocchio single": lambda: loop(pin.rnea, pins),
        "generated single": lambda: loop(gen.inverse_dynamics, ours),
        "general single": lambda: loop(general_single, general),
        "generated single, public API": lambda: loop(public_single, general),
        "generated batch": per_state(kb, Q, QD, QDD, False, TAU),
        "general batch": per_state(manipcad.inverse_dynamics, robot, Q, QD, QDD, drives=False,
                                   use_generated=False),
    }
    for f in cases.values():  # warm-up: compile or load
        f()
    return {"robot": label, "n": n, "agreement": float(err), "ops": gen.ops,
            "times": interleave(cases, rounds, rng)}


def bench_rhs(rounds: int, rng) -> dict:
    robot = load("puma560")
    gen = generate(robot)   # attached: the public functions call it (use_generated=True)
    n = robot.n
    Q, QD, T = rng.uniform(-1.5, 1.5, (3, N_BATCH, n))
    out = np.empty_like(Q)
    kf = gen.kernel("forward_dynamics_batch")
    cf = gen.cfunc("forward_dynamics")
    # the whole right-hand side (drives + dynamics) as the simulator evaluates it
    X = np.concatenate([Q, QD, rng.uniform(-2.0, 2.0, (N_BATCH, n))], axis=1)
    UU = rng.uniform(-10.0, 10.0, (N_BATCH, n))
    DD = np.zeros((N_BATCH, n))
    XD = np.empty_like(X)
    pg, pl = closed_loop_plant(robot, True), closed_loop_plant(robot, False)
    cases = {"generated forward (H + bias + L·D·Lᵀ), batch kernel": per_state(
                 kf, Q, QD, T, True, out),
             "general forward (aba), batch kernel": per_state(
                 manipcad.forward_dynamics, robot, Q, QD, T, use_generated=False),
             "generated forward, C-ABI call in a compiled loop": per_state(
                 loop_cfunc, cf, Q, QD, T, out),
             "general aba_state inlined in a compiled loop": per_state(
                 loop_aba, robot.table, robot.gravity, Q, QD, T, out),
             "generated forward, C-ABI call, each call waiting for the previous one":
                 per_state(chain_cfunc, cf, Q[0].copy(), QD[0], T[0], N_BATCH),
             "whole right-hand side (sim/loop.py _rates: drives + dynamics), generated":
                 per_state(loop_rates, pg, X, UU, DD, XD),
             "whole right-hand side (sim/loop.py _rates: drives + dynamics), general":
                 per_state(loop_rates, pl, X, UU, DD, XD)}
    for f in cases.values():
        f()
    return {"robot": "puma560 with drives", "n": n, "times": interleave(cases, rounds, rng)}


def bench_simulator(rounds: int, rng) -> dict:
    """Real-time factor of ``simulate`` with and without the generated kernels.

    The closed loop of benchmarks/bench_simulator.py: PUMA 560 with its drives
    (armature inductance kept), PD + back-EMF feed-forward on every joint
    sampled every step, RK4 with dt = 1e-4 s, a 1 s quintic move; as variants, the PD
    sampled every 1 ms, and the drives without their dry friction (no events).
    """
    from _puma_job import DT, Q_END, Q_START, pd_regulators

    from manipcad.sim import simulate
    from manipcad.trajectories import quintic

    robot = load("puma560")
    generate(robot)
    traj = quintic(Q_START, Q_END, 1.0)
    regs = pd_regulators(period=DT)
    regs_1ms = pd_regulators(period=10 * DT)
    # without the drives' dry friction the plant has no events (sim/events.py): the
    # steps skip the hybrid plant's event code
    smooth = robot.replace(drives=tuple(d.replace(M_f=0.0) for d in robot.drives))
    generate(smooth)
    used = {}

    def case(use, regulators=regs, every=1, arm=robot):
        def run() -> float:
            t = time.perf_counter()
            res = simulate(arm, t_end=1.0, dt=DT, trajectory=traj, regulators=regulators,
                           use_generated=use, every=every)
            if regulators is regs and every == 1 and arm is robot:
                used[use] = (res.settings["generated"], res.q[-1])
            return time.perf_counter() - t
        return run

    # the benchmark's job (the first two rows), and two variants of it, labelled: the
    # PD sampled every 1 ms instead of every step, and also only every 10th step kept
    cases = {"simulate, generated kernels": case(True),
             "simulate, general kernels": case(False),
             "(variant) generated, the PD sampled every 1 ms": case(True, regs_1ms),
             "(variant) generated, PD every 1 ms, every=10": case(True, regs_1ms, 10),
             "(variant) generated, no dry friction": case(True, arm=smooth),
             "(variant) general, no dry friction": case(False, arm=smooth)}
    for f in cases.values():
        f()
    times = interleave(cases, rounds, rng)
    dq = float(np.abs(used[True][1] - used[False][1]).max())
    return {"times": times, "generated_used": bool(used[True][0]), "max_dq_end": dq}


def bench_generation() -> dict:
    path = erd("xarm_description/urdf/xarm7.urdf")
    robot = load(path)
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        gen = generate(robot, cache_dir=tmp, attach=False)
        t_gen = time.perf_counter() - t
        z = np.zeros(robot.n)
        t = time.perf_counter()
        gen.kernel("inverse_dynamics")(z, z, z, True, np.empty(robot.n))  # compiles
        t_compile = time.perf_counter() - t
        t = time.perf_counter()
        generate(robot, cache_dir=tmp, attach=False)
        t_hit = time.perf_counter() - t
    return {"robot": f"xarm7 ({robot.n} joints)", "generate_s": t_gen,
            "symbolic_s": gen.seconds, "first_compile_id_s": t_compile, "cache_hit_s": t_hit,
            "ops": gen.ops}


def interleave(cases: dict, rounds: int, rng) -> dict:
    samples: dict = {k: [] for k in cases}
    keys = list(cases)
    for _ in range(rounds):
        rng.shuffle(keys)
        for k in keys:
            samples[k].append(cases[k]())
    return {k: {"min": min(v), "median": statistics.median(v)} for k, v in samples.items()}


def us(x: float) -> str:
    return f"{x * 1e6:.3f}"


def report(res: dict) -> str:
    out = ["| robot | case | µs per state, min (median) | ratio to Pinocchio single |",
           "|---|---|---|---|"]
    for r in res["id"]:
        ref = r["times"]["pinocchio single"]
        for k, v in r["times"].items():
            out.append(f"| {r['robot']} | {k} | {us(v['min'])} ({us(v['median'])}) | "
                       f"{v['min'] / ref['min']:.2f} ({v['median'] / ref['median']:.2f}) |")
    out.append("")
    rhs = res["rhs"]
    out += ["| right-hand side, " + rhs["robot"] + " | µs per state, min (median) |", "|---|---|"]
    for k, v in rhs["times"].items():
        out.append(f"| {k} | {us(v['min'])} ({us(v['median'])}) |")
    sim = res["simulator"]
    out += ["", "| closed loop, PUMA 560 with drives, 1 s, dt 1e-4, RK4 | wall s, min (median) "
            "| real-time factor (min wall) |", "|---|---|---|"]
    for k, v in sim["times"].items():
        out.append(f"| {k} | {v['min']:.3f} ({v['median']:.3f}) | {1.0 / v['min']:.1f} |")
    out.append(f"| (generated kernels used: {sim['generated_used']}; end states differ by "
               f"{sim['max_dq_end']:.1e} rad) | | |")
    g = res["generation"]
    out += ["", f"generation, {g['robot']}: generate {g['generate_s']:.2f} s "
            f"(symbolic + printing {g['symbolic_s']:.2f} s), first numba compile of the "
            f"inverse dynamics {g['first_compile_id_s']:.2f} s, cached generate "
            f"{g['cache_hit_s'] * 1e3:.1f} ms"]
    out.append("")
    for r in res["id"]:
        t = r["times"]
        s = t["generated single"]["min"] / t["pinocchio single"]["min"]
        p = t["generated single, public API"]["min"] / t["pinocchio single"]["min"]
        b = t["generated batch"]["min"] / t["pinocchio single"]["min"]
        out.append(f"- {r['robot']}: single through the public API {p:.2f}x Pinocchio (target "
                   f"<= 0.5: {'met' if p <= 0.5 else 'NOT met'}; the generated call alone "
                   f"{s:.2f}x), batch {b:.3f}x (target <= 0.1: "
                   f"{'met' if b <= 0.1 else 'NOT met'}); agreement with pin.rnea "
                   f"{r['agreement']:.1e}")
    out.append(f"- generation < 5 s: {'met' if g['generate_s'] < 5 else 'NOT met'}")
    return "\n".join(out)


PAPER = {  # the paper's general formulas (section 4), mul and add
    "inverse_dynamics": (lambda n: 95 * n - 101, lambda n: 84 * n - 97),
    "forward_dynamics": (lambda n: 249 * n - 272, lambda n: 231 * n - 294),
    "forward_crba": (lambda n: n**3 / 6 + 9 / 2 * n**2 + 544 / 3 * n - 155,
                     lambda n: n**3 / 6 + 7 / 2 * n**2 + 499 / 3 * n - 159),
}


def counts_table() -> str:
    """Markdown: generated counts per robot beside the paper's formulas and our general kernels."""
    robots = [("PUMA 560 (catalog, drives)", "puma560"), ("Stanford arm (catalog, drives)",
                                                         "stanford"),
              ("Fig. 2 arm (catalog 'cylindrical', drives)", "cylindrical"),
              ("SCARA (catalog, drives)", "scara"),
              ("UR5 (example-robot-data, rigid)", erd("ur_description/urdf/ur5_robot.urdf")),
              ("Panda (example-robot-data, rigid, 7 + 2 fingers)",
               erd("panda_description/urdf/panda.urdf"))]
    out = ["| robot | n | function | generated mul / add / sin-cos (sqrt) | general kernel "
           "mul / add | paper mul / add |", "|---|---|---|---|---|---|"]
    for label, src in robots:
        robot = load(src)
        gen = generate(robot)   # attached: the public functions call it (use_generated=True)
        n = robot.n
        for func, c in gen.ops.items():
            general = {"inverse_dynamics": "rnea", "mass_matrix": "crba",
                       "forward_dynamics": "aba"}.get(func)
            g = manipcad.operation_counts(general, n) if general else None
            paper = {"inverse_dynamics": "inverse_dynamics",
                     "forward_dynamics": "forward_dynamics"}.get(func)
            pm = (f"{PAPER[paper][0](n):.0f} / {PAPER[paper][1](n):.0f}" if paper else "")
            if func == "forward_dynamics":
                pm += (f" (O(n)); {PAPER['forward_crba'][0](n):.0f} / "
                       f"{PAPER['forward_crba'][1](n):.0f} (H + Cholesky)")
            sq = f" ({c['sqrt']})" if c["sqrt"] else ""
            out.append(f"| {label} | {n} | {func} | {c['mul']} / {c['add']} / {c['trig']}{sq} "
                       f"| {g['mul']} / {g['add'] if g else ''} |" if g else
                       f"| {label} | {n} | {func} | {c['mul']} / {c['add']} / {c['trig']}{sq} "
                       f"| | {pm} |")
            if g:
                out[-1] += f" {pm} |"
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--counts", action="store_true",
                    help="print only the operation-count table (Markdown) and exit")
    args = ap.parse_args()
    if args.counts:
        print(counts_table())
        return
    numba.set_num_threads(1)
    rng = np.random.default_rng(0)
    res = {
        "id": [bench_id("ur5", erd("ur_description/urdf/ur5_robot.urdf"), args.rounds, rng),
               bench_id("panda", erd("panda_description/urdf/panda.urdf"), args.rounds, rng)],
        "rhs": bench_rhs(args.rounds, rng),
        "simulator": bench_simulator(max(3, args.rounds // 2), rng),
        "generation": bench_generation(),
        "pinocchio": pin.__version__, "numba": numba.__version__,
    }
    print(report(res))
    if args.json:
        args.json.write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
