"""Benchmark: manipcad's inverse and forward dynamics against Pinocchio, in one run.

Usage::

    python benchmarks/bench_dynamics.py [--quick] [--json out.json] [--rounds R]

Two robots: the UR5 arm (6 revolute joints, the URDF of the ``example-robot-data``
package, loaded by :func:`manipcad.load_robot`) and a 100-joint chain of
revolute joints with random placements and full inertias (built with
:meth:`manipcad.Robot.from_arrays` and exported with
:func:`manipcad.model.to_pinocchio.to_pinocchio`).

What is timed (``time.perf_counter``, wall clock):

* ours, batch: one call on N = 10,000 states (arrays (N, n)), divided by N;
* ours, single: a Python loop of one-state calls (arrays (n,)), per call;
* Pinocchio, single: a Python loop of ``pin.rnea`` / ``pin.aba`` calls, per call
  (Pinocchio has no batch call: its per-call time is what a Python user pays
  per state).

Both loops go over the same prebuilt list of per-state arrays. The cases are
interleaved: every round times each case once, in a new random order, after a
20 ms pause (numba's OpenMP threads spin for a while after a parallel batch),
so that the noise of a shared machine hits them alike; the table shows the
minimum over the rounds and, in brackets, the median. The batch call runs
with numba's default number of threads (the machine's cores) and, as a
separate row, with one thread.

Targets: batched inverse dynamics <= 0.5x Pinocchio's
per-call time, a single call <= 3x, ABA on 100 joints <= 1.5x.
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

import numba
import numpy as np
import pinocchio as pin

import manipcad
from manipcad.model.to_pinocchio import to_pinocchio

N_BATCH = 10_000


# --------------------------------------------------------------------- robots


def ur5_urdf() -> Path | None:
    """The UR5 URDF of the installed example-robot-data, or None."""
    from importlib.metadata import PackageNotFoundError, distribution

    candidates = []
    try:  # v6 ships data only, under the cmeel prefix
        candidates.append(Path(distribution("example-robot-data").locate_file(
            "cmeel.prefix/share/example-robot-data/robots")))
    except PackageNotFoundError:
        pass
    try:  # older releases have a Python module with the path
        from example_robot_data.path import EXAMPLE_ROBOT_DATA_MODEL_DIR  # type: ignore

        candidates.append(Path(EXAMPLE_ROBOT_DATA_MODEL_DIR))
    except ImportError:
        pass
    for d in candidates:
        p = d / "ur_description" / "urdf" / "ur5_robot.urdf"
        if p.is_file():
            return p
    return None


def random_chain(n: int, seed: int = 0) -> manipcad.Robot:
    """An n-joint chain of revolute joints, random placements and full inertias."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, 3, 3))
    inertia = A @ A.transpose(0, 2, 1) * 0.05 + 0.001 * np.eye(3)
    return manipcad.Robot.from_arrays(
        f"chain{n}", ["revolute"] * n, np.arange(n) - 1,
        Rotation.random(n, random_state=seed).as_matrix(), rng.normal(size=(n, 3)) * 0.3,
        rng.uniform(0.5, 3.0, n), rng.normal(size=(n, 3)) * 0.1, inertia)


def robots():
    """(label, our robot, pinocchio model, joint order) for the two benchmark robots."""
    out = []
    path = ur5_urdf()
    if path is not None:
        robot = manipcad.load_robot(path)
        model = pin.buildModelFromUrdf(str(path))
        order = np.arange(robot.n)
        names = [model.names[j] for j in range(1, model.njoints)]
        if names != list(robot.joint_names):  # same joints, maybe in another order
            order = np.array([robot.joint_names.index(nm) for nm in names])
        out.append(("ur5 (URDF, 6 joints)", robot, model, order))
    else:  # no example-robot-data: a random 6-joint chain of the same size
        robot = random_chain(6, seed=1)
        model, order = to_pinocchio(robot)
        out.append(("chain6 (random, no URDF found)", robot, model, order))
    robot = random_chain(100)
    model, order = to_pinocchio(robot)
    out.append(("chain100 (random)", robot, model, order))
    return out


# ------------------------------------------------------------------- timing


def time_loop(fn, states) -> float:
    """Seconds per call of fn(*state) over a list of states."""
    t = time.perf_counter()
    for s in states:
        fn(*s)
    return (time.perf_counter() - t) / len(states)


def time_batch(fn, args, n_states: int) -> float:
    """Seconds per state of one batch call fn(*args)."""
    t = time.perf_counter()
    fn(*args)
    return (time.perf_counter() - t) / n_states


def check_agreement(robot, model, order, Q, QD, QDD) -> float:
    """Largest relative difference of ours and Pinocchio's inverse and forward dynamics."""
    data = model.createData()
    err = 0.0
    for k in range(3):
        q, qd, qdd = Q[k], QD[k], QDD[k]
        qp = (q + robot.offset)[order]
        tau = manipcad.inverse_dynamics(robot, q, qd, qdd)
        ref = pin.rnea(model, data, qp, qd[order], qdd[order])
        err = max(err, np.abs(tau[order] - ref).max() / max(np.abs(ref).max(), 1.0))
        a = manipcad.forward_dynamics(robot, q, qd, tau)
        err = max(err, np.abs(a - qdd).max() / max(np.abs(qdd).max(), 1.0))
    return float(err)


def bench_robot(label, robot, model, order, *, rounds: int, n_single: int, rng):
    n = robot.n
    Q = rng.uniform(-np.pi, np.pi, (N_BATCH, n))
    QD = rng.uniform(-2.0, 2.0, (N_BATCH, n))
    QDD = rng.uniform(-5.0, 5.0, (N_BATCH, n))
    TAU = manipcad.inverse_dynamics(robot, Q, QD, QDD)
    err = check_agreement(robot, model, order, Q, QD, QDD)
    data = model.createData()
    # per-state arrays, 1-D contiguous, built once for both libraries
    ours_id = [(robot, Q[k].copy(), QD[k].copy(), QDD[k].copy()) for k in range(n_single)]
    ours_fd = [(robot, Q[k].copy(), QD[k].copy(), TAU[k].copy()) for k in range(n_single)]
    qp = (Q + robot.offset)[:, order]
    pin_id = [(model, data, qp[k].copy(), QD[k, order].copy(), QDD[k, order].copy())
              for k in range(n_single)]
    pin_fd = [(model, data, qp[k].copy(), QD[k, order].copy(), TAU[k, order].copy())
              for k in range(n_single)]

    def fd_crba(r, q, qd, tau):
        return manipcad.forward_dynamics(r, q, qd, tau, method="crba")

    nthreads = numba.config.NUMBA_NUM_THREADS

    def batch(fn, *args):
        numba.set_num_threads(nthreads)
        return time_batch(fn, (robot, *args), N_BATCH)

    def batch1(fn, *args):
        numba.set_num_threads(1)
        try:
            return time_batch(fn, (robot, *args), N_BATCH)
        finally:
            numba.set_num_threads(nthreads)

    ID, FD = manipcad.inverse_dynamics, manipcad.forward_dynamics
    cases = {
        ("id", "ours batch"): lambda: batch(ID, Q, QD, QDD),
        ("id", "ours batch 1 thread"): lambda: batch1(ID, Q, QD, QDD),
        ("id", "ours single"): lambda: time_loop(ID, ours_id),
        ("id", "pinocchio"): lambda: time_loop(pin.rnea, pin_id),
        ("aba", "ours batch"): lambda: batch(FD, Q, QD, TAU),
        ("aba", "ours batch 1 thread"): lambda: batch1(FD, Q, QD, TAU),
        ("aba", "ours single"): lambda: time_loop(FD, ours_fd),
        ("aba", "pinocchio"): lambda: time_loop(pin.aba, pin_fd),
        ("crba", "ours batch"): lambda: batch(fd_crba, Q, QD, TAU),
        ("crba", "ours single"): lambda: time_loop(fd_crba, ours_fd),
    }
    for fn in cases.values():  # warm up: compile / load caches, touch the memory
        fn()
    samples = {key: [] for key in cases}
    order = list(cases)
    for _ in range(rounds):
        rng.shuffle(order)  # no case always runs right after another
        for key in order:
            time.sleep(0.02)  # let numba's idle threads stop spinning after a parallel batch
            samples[key].append(cases[key]())
    return {"robot": label, "n": n, "agreement": err,
            "times": {f"{a}/{b}": {"min": min(v), "median": statistics.median(v),
                                   "samples": v}
                      for (a, b), v in samples.items()}}


# ------------------------------------------------------------------- report

TARGETS = [
    # (robot index or None for all, algorithm, our case, limit, what)
    (None, "id", "ours batch", 0.5, "batched inverse dynamics <= 0.5x"),
    (None, "id", "ours batch 1 thread", 0.5, "batched inverse dynamics, 1 thread <= 0.5x"),
    (None, "id", "ours single", 3.0, "single-call inverse dynamics <= 3x"),
    (1, "aba", "ours single", 1.5, "ABA, 100 joints, single call <= 1.5x"),
    (1, "aba", "ours batch", 1.5, "ABA, 100 joints, batch/state <= 1.5x"),
    (1, "aba", "ours batch 1 thread", 1.5, "ABA, 100 joints, batch/state, 1 thread <= 1.5x"),
]


def us(x: float) -> str:
    return f"{x * 1e6:.3f}"


ALGORITHMS = {"id": "inverse (rnea)", "aba": "forward (aba)", "crba": "forward (crba+chol)"}
CASES = {"ours batch": "batch/state", "ours batch 1 thread": "batch/state, 1 thread",
         "ours single": "single call"}


def short(label: str) -> str:
    return label.split(" ")[0]


def rows(results):
    """Table rows: robot, algorithm, case, ours, Pinocchio, ratio; each 'min (median)'."""
    out = []
    for res in results:
        t = res["times"]
        for alg, ref_alg in (("id", "id"), ("aba", "aba"), ("crba", "aba")):
            ref = t[f"{ref_alg}/pinocchio"]
            for case, name in CASES.items():
                key = f"{alg}/{case}"
                if key not in t:
                    continue
                m = t[key]
                out.append((short(res["robot"]), ALGORITHMS[alg], name,
                            f"{us(m['min'])} ({us(m['median'])})",
                            f"{us(ref['min'])} ({us(ref['median'])})",
                            f"{m['min'] / ref['min']:.2f} ({m['median'] / ref['median']:.2f})"))
    return out


def target_rows(results):
    out = []
    for idx, alg, case, limit, what in TARGETS:
        for i, res in enumerate(results):
            if idx is not None and i != idx:
                continue
            t = res["times"]
            r_min = t[f"{alg}/{case}"]["min"] / t[f"{alg}/pinocchio"]["min"]
            r_med = t[f"{alg}/{case}"]["median"] / t[f"{alg}/pinocchio"]["median"]
            out.append((short(res["robot"]), what, f"{r_min:.2f} ({r_med:.2f})",
                        "met" if max(r_min, r_med) <= limit else
                        ("met on min only" if r_min <= limit else "NOT met")))
    return out


def print_tables(results, machine):
    head = ("robot", "algorithm", "case", "ours µs", "Pinocchio µs/call", "ratio")
    thead = ("robot", "target", "ratio", "status")
    tables = (("time per state, min (median) over rounds", head, rows(results)),
              ("targets, ratio min (median)", thead, target_rows(results)))
    print(", ".join(f"{k}: {v}" for k, v in machine.items()))
    try:
        from rich.console import Console
        from rich.table import Table
    except ImportError:  # plain text
        for title, h, rs in tables:
            print(title)
            widths = [max(len(str(x)) for x in col) for col in zip(h, *rs, strict=True)]
            for r in (h, *rs):
                print("  ".join(str(x).ljust(w) for x, w in zip(r, widths, strict=True)))
            print()
        return
    console = Console(width=max(Console().width, 120))
    for title, h, rs in tables:
        table = Table(title=title)
        for c in h:
            table.add_column(c, no_wrap=True)
        for r in rs:
            table.add_row(*r)
        console.print(table)


def markdown(results) -> str:
    """The two tables in Markdown (for docs/performance.md)."""
    out = []
    for h, rs in ((("robot", "algorithm", "case", "ours µs", "Pinocchio µs/call", "ratio"),
                   rows(results)),
                  (("robot", "target", "ratio", "status"), target_rows(results))):
        out.append("| " + " | ".join(h) + " |")
        out.append("|" + "---|" * len(h))
        out.extend("| " + " | ".join(r) + " |" for r in rs)
        out.append("")
    return "\n".join(out)


def machine_info() -> dict:
    cpu = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        cpu = platform.processor()
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "numba": numba.__version__, "pinocchio": pin.__version__,
            "manipcad": manipcad.__version__, "numba_threads": numba.config.NUMBA_NUM_THREADS,
            "numba_threading_layer": _threading_layer()}


def _threading_layer() -> str:
    try:
        return numba.threading_layer()
    except ValueError:  # no parallel region has run yet
        return "not started"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer rounds and single calls")
    ap.add_argument("--rounds", type=int, default=None, help="timing rounds (default 15, quick 3)")
    ap.add_argument("--json", type=Path, default=None, help="write the results to this file")
    ap.add_argument("--markdown", action="store_true", help="also print the tables in Markdown")
    args = ap.parse_args(argv)
    rounds = args.rounds or (3 if args.quick else 15)
    rng = np.random.default_rng(0)
    results = []
    for label, robot, model, order in robots():
        n_single = (500 if args.quick else 2000) if robot.n <= 10 else (100 if args.quick else 400)
        results.append(bench_robot(label, robot, model, order, rounds=rounds,
                                   n_single=n_single, rng=rng))
    machine = machine_info()
    machine["command"] = " ".join(["python", *sys.argv])
    machine["rounds"] = rounds
    print_tables(results, machine)
    for res in results:
        print(f"{res['robot']}: agreement with Pinocchio {res['agreement']:.1e} (relative)")
    if args.markdown:
        print(markdown(results))
    if args.json:
        args.json.write_text(json.dumps({"machine": machine, "results": results,
                                         "targets": target_rows(results)}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
