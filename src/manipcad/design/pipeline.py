"""The automated design in one call: drives → decoupling → rules → synthesis → sweep → decision.

:func:`run_design` chains the steps of this package, each a small function with a clear
input and output (docs/design.md):

1. **drives** (:mod:`.drives`): the robot file's, else selected from the catalogue;
2. **decouple** (:mod:`.decouple`): the coupling per joint, counterweights where gravity
   dominates and they pay, what they change; applied with ``counterbalance="auto"``;
3. **candidates** (:mod:`.candidates`): the rules' methods, least complexity first, each
   synthesized at the control period over the load range the payloads span;
4. **sweep** (:mod:`.sweep`): every candidate simulated (coupled dynamics, drives,
   sampled regulators) at both ends and the middle of the payload range and at the
   uncertainty samples (:mod:`.cases`), on the executor, cached by input hash;
   every run judged per joint by the run checks (:mod:`.judge`);
5. **decide** (:mod:`.decide`): per joint the least complex method that passes every
   check in every case; the combination is then verified as a whole over the same
   cases. If a joint has no such method: a tighter synthesis (where the method has a
   knob) or the next drive up (where a rating check fails and the catalogue selection
   is available), at most ``max_iterations`` rounds; then the closest design, the case
   it fails and why;
6. **outputs** (:mod:`.outputs`, :mod:`manipcad.report.design`): robot.yaml,
   regulators.yaml, design.json, report.html, the C code and every run stored.
"""

from __future__ import annotations

import math
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from manipcad.analysis.counterbalance import apply_counterweights
from manipcad.control import synthesize
from manipcad.control.design import back_emf_feedforward
from manipcad.control.files import regulators_document
from manipcad.control.pid import PID_FF
from manipcad.design import cases as C
from manipcad.design.candidates import (
    TIGHTENABLE,
    candidates,
    load_ranges,
    synthesize_method,
)
from manipcad.design.decide import choose, closest, evaluate
from manipcad.design.decouple import decouple
from manipcad.design.drives import next_drive_up, parts, resolve_drives
from manipcad.design.outputs import write_outputs
from manipcad.design.sweep import run_sweep
from manipcad.errors import InputError, ManipcadError
from manipcad.expert import Requirements
from manipcad.fileio import writable_folder
from manipcad.model.load import load_robot
from manipcad.parallel import Pool
from manipcad.parallel.executor import check_workers, default_workers
from manipcad.store.results import every_for
from manipcad.study.claims import warm_worker
from manipcad.trajectories import load_trajectory

#: the label of the runs of a combination of methods (numbered: mix1, mix2, ...)
DESIGN = "mix"


class DesignNotMet(ManipcadError):
    """No design meets the requirements; ``.doc`` is the closest design's design.json."""

    def __init__(self, message: str, doc: dict) -> None:
        super().__init__(message)
        self.doc = doc


class _Trace(list):
    def add(self, step: str, text: str, **data: Any) -> None:
        self.append({"step": step, "text": text, **data})


def _check_settings(period, dt, samples, max_methods, max_iterations, counterbalance):
    if not (isinstance(dt, int | float) and math.isfinite(dt) and 0 < dt <= 1e-3):
        raise InputError("--dt", "", f"must be in (0, 1e-3] s, got {dt!r}")
    if not (isinstance(period, int | float) and math.isfinite(period) and period >= dt):
        raise InputError("--period", "", f"must be a control period >= dt = {dt:g} s, got "
                         f"{period!r}")
    k = period / dt
    if abs(k - round(k)) > 1e-6 * k:
        raise InputError("--period", "", f"must be a multiple of dt = {dt:g} s, got {period:g}")
    for name, v, lo in (("--samples", samples, 1), ("--max-methods", max_methods, 1),
                        ("--max-iterations", max_iterations, 1)):
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= 1000:
            raise InputError(name, "", f"must be a whole number in [{lo}, 1000], got {v!r}")
    if counterbalance not in ("auto", "none"):
        raise InputError("--counterbalance", "", f"must be auto or none, got {counterbalance!r}")


def _load(requirements, robot, trajectories):

    req = Requirements.coerce(requirements)
    if req.accuracy is None:
        raise InputError(str(requirements) if isinstance(requirements, str | Path)
                         else "requirements", "accuracy",
                         "missing: the design verifies the tracking error against it")
    arm = load_robot(robot)
    if not trajectories:
        raise InputError("-t", "", "give at least one trajectory")
    trajs = [load_trajectory(t, robot=arm) if isinstance(t, str | Path) else t
             for t in trajectories]
    for k, tr in enumerate(trajs):
        if not float(getattr(tr, "duration", 0.0)) > 0:
            raise InputError(str(trajectories[k]), "duration", "must be > 0 s")
    return req, arm, trajs


def run_design(requirements, robot, trajectories, *, out: str | Path,
               payload_range: tuple[float, float] = (0.0, 0.0), uncertainty: float = 0.0,
               samples: int = 5, seed: int = 0, makers=None, counterbalance: str = "none",
               period: float = 1e-3, dt: float = 1e-4, max_methods: int = 4,
               max_iterations: int = 3, strict: bool = False, workers: int | None = None,
               scheduler: str | None = None, progress=False, store_runs: bool | str = True,
               compare_selection: bool = True, sources: dict | None = None) -> dict:
    """Design the control of a manipulator and verify it over payloads and uncertainty.

    Args:
        requirements: a requirements file, mapping or :class:`~manipcad.expert.Requirements`
            (``accuracy`` is needed: the largest tracking error, rad or m).
        robot: a robot file, catalog name or Robot (drives on every joint, or the
            catalogue selection available).
        trajectories: trajectory files or objects (>= 1).
        out: the design folder (created; reruns reuse its cache of runs).
        payload_range: (low, high) gripped mass at the tool point, kg, added to the robot's.
        uncertainty: the relative uncertainty x of the link and drive parameters, in [0, 1).
        samples: uncertainty samples (:mod:`manipcad.design.cases`; 1 with x = 0).
        seed: random stream of the random samples.
        makers: catalogue makers the selection may use (None: all).
        counterbalance: "auto" applies the counterweights that pay; "none" reports them.
        period: the regulators' control period, s (a multiple of ``dt``).
        dt: integration step of the simulations (RK4), s.
        max_methods: how many of the rules' methods are verified.
        max_iterations: rounds of the decision (tighter synthesis, next drive up).
        strict: an unknown check counts as failed.
        workers, scheduler: the executor (:func:`manipcad.parallel.run_tasks`).
        progress: a progress bar (True) or a callable given (stage text, fraction).
        store_runs: which runs to store as result folders under ``out/runs``: "final"
            (or True: the final design's), "all" (every run of the sweep, candidates
            included; their time series also go into the cache), "none" (or False).
        compare_selection: for each counterweight proposed, report the drive the catalogue
            selection picks without and with it (two selections: seconds on a 7-joint arm).
        sources: {"robot": path, "trajectories": [paths], "requirements": path} for the
            reproduction commands and the report.

    Returns:
        The design.json document (``status`` "met").

    Raises:
        InputError: bad input (named).
        DesignNotMet: no design meets the requirements within the rounds; the closest
            design's files are written and ``.doc`` holds its design.json.
    """

    t0 = time.perf_counter()
    store = {True: "final", False: "none"}.get(store_runs, store_runs)
    if store not in ("final", "all", "none"):
        raise InputError("--store-runs", "", f"must be final, all or none, got {store_runs!r}")
    keep_all = store == "all"
    _check_settings(period, dt, samples, max_methods, max_iterations, counterbalance)
    check_workers(workers, scheduler, "design")
    out = writable_folder(out)
    req, arm, trajs = _load(requirements, robot, trajectories)
    lo, hi = payload_range
    payloads = C.payload_points(lo, hi)
    if not (isinstance(uncertainty, int | float) and 0 <= uncertainty < 1):
        raise InputError("--uncertainty", "", f"must be a fraction in [0, 1), got "
                         f"{uncertainty!r}")
    sample_ids = list(range(samples)) if uncertainty > 0 else [0]
    accuracy = float(req.accuracy)
    trace = _Trace()
    stage = _stages(progress)

    # 1. drives
    stage("drives", 0.0)
    arm, drive_info = resolve_drives(arm, trajs, payloads, makers=makers)
    for name, src in drive_info["source"].items():
        d = arm.drive(name)
        trace.add("drives", f"{name}: {d.name or 'motor'} + {d.gear or 'no gear (direct)'} "
                  f"(i_r = {d.ratio:g}) from the {src}")
    # 2. decoupling
    stage("decoupling", 0.05)
    mid = C.nominal_payload(lo, hi)
    dec = decouple(C.with_payload(arm, mid), trajs, mode=counterbalance,
                   select=compare_selection)
    for cw in dec.counterweights:
        sel = dec.selected.get(cw.joint, {})
        pick = ("; the catalogue selection picks " + " without it, ".join(
            x.get("error") or f"{x['drive']} ({x['mass']:.3g} kg)"
            for x in (sel["before"], sel["after"])) + " with it") if sel else ""
        trace.add("decouple", f"{cw.joint}: gravity dominates; counterweight {cw.mass:.3g} kg "
                  f"at {cw.arm:g} m takes its peak gravity torque from "
                  f"{cw.gravity_peak_before:.3g} to {cw.gravity_peak_after:.3g} N·m{pick} "
                  + ("(applied)" if dec.applied else
                     "(proposed, not applied: --counterbalance auto applies it)"))
    for name, why in dec.rejected.items():
        trace.add("decouple", f"{name}: gravity dominates, no counterweight proposed: {why}")
    if dec.applied:

        arm = apply_counterweights(arm, dec.counterweights)
    nominal = C.with_payload(arm, mid)
    # 3. candidates
    stage("rules", 0.1)
    recs, methods = candidates(req, nominal, trajs[0], joint=req.joint, max_methods=max_methods)
    for rid in recs.fired:
        trace.add("rules", f"rule fired: {recs.rule_texts.get(rid, rid)}", rule=rid)
    for m, why in recs.excluded.items():
        trace.add("rules", f"{m} excluded: {why}", method=m)
    dropped = [r.method for r in recs if r.method not in methods]
    trace.add("rules", f"candidates, in the rules' order: {', '.join(methods)}"
              + (f" (not verified: {', '.join(dropped)}; --max-methods {max_methods})"
                 if dropped else ""))
    if not methods:
        raise ManipcadError("the rules leave no method the synthesis package has")
    driven = [j for j in range(arm.n) if arm.drives[j] is not None]
    designed = [arm.joint_index(req.joint)] if req.joint is not None else driven
    support = [j for j in driven if j not in designed]
    names = arm.joint_names

    state = {"arm": arm, "levels": dict.fromkeys(methods, 0), "excluded": set(), "mixes": {},
             "tried": {}}
    runs_all: list[dict] = []
    results: dict[str, Any] = {}
    cache_dir = out / "cache"
    outcome: dict[str, Any] = {}
    with ExitStack() as stack:
        stage("cluster", 0.12)
        pool = _pool(stack, workers, scheduler)
        for it in range(max_iterations):
            arm = state["arm"]
            nominal = C.with_payload(arm, mid)
            plants = _plants(arm, payloads, sample_ids, uncertainty, seed)
            # the load range the regulators are designed over: H_ii grows with every link
            # mass and inertia, so the nominal arm and the all-up and all-down samples
            # at each payload bound every sample's (and it does not depend on --samples:
            # more samples reuse the runs already made)
            bounds = [0, 3, 4] if uncertainty > 0 else [0]
            lr = load_ranges([p["plant"] for p in _plants(arm, payloads, bounds,
                                                           uncertainty, seed)], designed)
            stage(f"round {it + 1}: synthesis", 0.15 + 0.7 * it / max_iterations)
            support_regs = _support(nominal, support, period)
            synth = {m: synthesize_method(nominal, m, designed, period=period,
                                          accuracy=accuracy, level=state["levels"][m],
                                          reference=trajs[0], load_range=lr)
                     for m in methods}
            for m, s in synth.items():
                for j, why in s.errors.items():
                    trace.add("synthesize", f"{m} on {names[j]} refused: {why}", method=m,
                              joint=names[j], iteration=it)
            labels = {m: _label(m, synth[m].level) for m in methods if synth[m].regulators}
            docs = {labels[m]: _document(nominal, [*synth[m].regulators.values(),
                                                   *_fill(synth[m], designed, nominal, period),
                                                   *support_regs])
                    for m in labels}
            stage(f"round {it + 1}: sweep", 0.2 + 0.7 * it / max_iterations)
            recs_it = _sweep(docs, plants, trajs, payloads, dt, period, accuracy, designed,
                             pool, workers, scheduler, cache_dir, progress, results,
                             keep=keep_all)
            _merge(runs_all, recs_it)
            evals = {names[j]: {m: evaluate([r for r in recs_it if r["label"] == labels[m]],
                                            names[j], strict=strict)
                                for m in labels if j in synth[m].regulators}
                     for j in designed}
            costs = {names[j]: {m: synth[m].cost[j] for m in labels
                                if j in synth[m].regulators} for j in designed}
            for jn, per in evals.items():
                for m, e in per.items():
                    if not e.passed:
                        trace.add("verify", f"{m} on {jn} rejected: {e.reason()}", method=m,
                                  joint=jn, iteration=it)
            choice = choose(evals, costs, state["excluded"])
            outcome = {"evals": evals, "costs": costs, "synth": synth, "labels": labels,
                       "mixes": state["mixes"],
                       "docs": docs, "choice": choice, "support": support_regs,
                       "nominal": nominal, "plants": plants}
            if all(choice[names[j]] is not None for j in designed):
                mix, mix_regs = _mix(choice, synth, designed, names, support_regs, nominal)
                mix_label = _mix_label(choice, labels, designed, names, state["mixes"])
                if mix_label not in docs:
                    recs_mix = _sweep({mix_label: mix}, plants, trajs, payloads, dt, period,
                                      accuracy, designed, pool, workers, scheduler, cache_dir,
                                      progress, results, keep=keep_all)
                    _merge(runs_all, recs_mix)
                else:
                    recs_mix = [r for r in recs_it if r["label"] == mix_label]
                final = {names[j]: evaluate(recs_mix, names[j], strict=strict)
                         for j in designed}
                bad = [jn for jn, e in final.items() if not e.passed]
                outcome.update(mix=mix, mix_regs=mix_regs, mix_label=mix_label, final=final,
                               final_runs=recs_mix)
                if not bad:
                    for jn in choice:
                        alt = [f"{m} (cost {costs[jn][m]:.4g})" for m, e in evals[jn].items()
                               if e.passed and m != choice[jn]
                               and (jn, m) not in state["excluded"]]
                        trace.add("decide", f"{jn}: {choice[jn]}, the least complex method "
                                  f"that passes every case (cost {costs[jn][choice[jn]]:.4g}; "
                                  f"worst error {final[jn].worst_error:.3g} in "
                                  f"{final[jn].worst_case})"
                                  + (f"; also passing, more complex: {', '.join(alt)}"
                                     if alt else ""), joint=jn, method=choice[jn])
                    outcome["met"] = True
                    break
                for jn in bad:
                    state["excluded"].add((jn, choice[jn]))
                    trace.add("decide", f"{choice[jn]} on {jn} passes alone but fails in the "
                              f"combined design: {final[jn].reason()}", joint=jn,
                              method=choice[jn], iteration=it)
                continue
            if it + 1 >= max_iterations:
                break
            # remedies for the joints no method passes
            acted = _remedy(state, choice, evals, costs, designed, names, methods, accuracy,
                            trajs, payloads, makers, trace, it)
            if not acted:
                trace.add("decide", "no remedy is left (no method with a knob to tighten, "
                          "no larger drive): stop", iteration=it)
                break
        else:
            pass
        if not outcome.get("met"):
            _closest(outcome, designed, names, accuracy, trace, plants=outcome["plants"],
                     trajs=trajs, payloads=payloads, dt=dt, period=period, pool=pool,
                     workers=workers, scheduler=scheduler, cache_dir=cache_dir,
                     progress=progress, results=results, runs_all=runs_all, strict=strict)
        if store == "final":  # the final design's runs again, with their time series
            stage("storing the runs", 0.9)
            _sweep({outcome["mix_label"]: outcome["mix"]}, outcome["plants"], trajs, payloads,
                   dt, period, accuracy, designed, pool, workers, scheduler, cache_dir,
                   progress, results, keep=True, stored=True)
    stage("outputs", 0.95)
    doc = write_outputs(out, req=req, arm=state["arm"], nominal=outcome["nominal"],
                        trajectories=trajs, outcome=outcome, runs=runs_all, results=results,
                        decoupling=dec, drive_info=drive_info, recs=recs, methods=methods,
                        designed=designed, trace=trace,
                        settings={"payload_range": [float(lo), float(hi)],
                                  "payloads": payloads, "uncertainty": float(uncertainty),
                                  "samples": sample_ids, "seed": seed, "period": period,
                                  "dt": dt, "max_methods": max_methods,
                                  "max_iterations": max_iterations, "strict": strict,
                                  "counterbalance": counterbalance,
                                  "workers": workers, "scheduler": scheduler},
                        sources=sources or {}, store_runs=store,
                        wall=time.perf_counter() - t0, parts_before=parts(arm),
                        stage_times=stage.times)
    stage("done", 1.0)
    if doc["status"] != "met":
        raise DesignNotMet(doc["failure"]["text"], doc)
    return doc


# ------------------------------------------------------------------ steps


class _Stages:
    """Calls ``progress(text, fraction)`` (if callable) and times each stage (wall, s)."""

    def __init__(self, progress) -> None:
        self.progress = progress if callable(progress) else None
        self.times: dict[str, float] = {}
        self._cur: tuple[str, float] | None = None

    def __call__(self, text: str, frac: float) -> None:
        now = time.perf_counter()
        if self._cur is not None:
            name = self._cur[0].split(":")[-1].strip()
            self.times[name] = self.times.get(name, 0.0) + now - self._cur[1]
        self._cur = (text, now)
        if self.progress is not None:
            self.progress(text, frac)


def _stages(progress) -> _Stages:
    return _Stages(progress)


def _pool(stack: ExitStack, workers, scheduler):

    if scheduler is None and (workers or default_workers()) == 1:
        return None

    warm_worker()       # the kernels loaded here: forked workers start with them
    return stack.enter_context(Pool(workers=workers, scheduler=scheduler, warm=warm_worker))


def _plants(arm, payloads, sample_ids, uncertainty, seed) -> list[dict]:
    out = []
    for pi, p in enumerate(payloads):
        loaded = C.with_payload(arm, p)
        for k in sample_ids:
            plant, f = C.perturbed(loaded, uncertainty, k, seed)
            out.append({"payload_index": pi, "payload": p, "sample": k, "plant": plant,
                        "factors": f})
    return out


#: bandwidth of the support PIDs, rad/s (capped at 0.25/period)
SUPPORT_BANDWIDTH = 200.0


def _support(nominal, support: list[int], period: float) -> list:
    """PID regulators of the driven joints the requirements do not name, as the Fig. 3
    study drives them: poles at min(200 rad/s, 0.25/period), ζ = 1, k_i = k_p·ω_n/10,
    plus the velocity feed-forward k_ff = k_w·i_r/k_u that cancels the back-EMF at the
    reference speed."""

    regs = []
    bw = min(SUPPORT_BANDWIDTH, 0.25 / period)
    for j in support:
        try:
            reg = synthesize(nominal, j, "pid", period=period, spec={"bandwidth": bw})
        except ManipcadError as exc:
            raise ManipcadError(f"cannot design the PID of the joint "
                                f"{nominal.joint_names[j]!r} the requirements do not name: "
                                f"{exc}") from None
        d = nominal.drives[j]
        kff = back_emf_feedforward(d)
        reg.params[PID_FF] = kff
        reg.law += f"; + {kff:.6g}·q̇_ref (k_ff = k_w·i_r/k_u)"
        reg.design["kff"] = kff
        regs.append(reg)
    return regs


def _fill(s, designed, nominal, period) -> list:
    """PID regulators for the designed joints a method could not be synthesized for (so
    the arm is controlled; those joints are not judged for the method)."""
    missing = [j for j in designed if j not in s.regulators]
    return _support(nominal, missing, period) if missing else []


def _label(method: str, level: int) -> str:
    return method if level == 0 else f"{method}@{level}"


def _document(nominal, regs) -> dict:

    regs = sorted(regs, key=lambda r: r.joints[0])
    return regulators_document(regs, robot=nominal)


def _mix(choice, synth, designed, names, support_regs, nominal) -> tuple[dict, list]:
    """The combination's regulator file mapping and its regulators (joint order)."""
    regs = sorted([*(synth[choice[names[j]]].regulators[j] for j in designed), *support_regs],
                  key=lambda r: r.joints[0])
    return _document(nominal, regs), regs


def _mix_label(choice, labels, designed, names, mixes: dict) -> str:
    """The label of a combination's runs: the method's when every joint has the same,
    else ``mixK``, numbered in the order the combinations are first tried."""
    used = {labels[choice[names[j]]] for j in designed}
    if len(used) == 1:
        return used.pop()
    key = tuple(sorted((jn, labels[m]) for jn, m in choice.items()))
    return mixes.setdefault(key, f"{DESIGN}{len(mixes) + 1}")


def _case_id(label: str, p: dict, ti: int) -> str:
    return f"{label}-p{p['payload_index']}-u{p['sample']}-t{ti}"


def _sweep(docs, plants, trajs, payloads, dt, period, accuracy, designed, pool, workers,
           scheduler, cache_dir, progress, results, keep: bool = False,
           stored: bool = False) -> list[dict]:

    tasks, meta = [], []
    for label, doc in docs.items():
        for p in plants:
            for ti, tr in enumerate(trajs):
                tasks.append({"plant": p["plant"], "trajectory": tr, "regulators": doc,
                              "t_end": float(tr.duration)})
                meta.append({"id": _case_id(label, p, ti), "label": label,
                             "payload": p["payload"], "payload_index": p["payload_index"],
                             "sample": p["sample"], "sample_name": C.sample_name(p["sample"]),
                             "trajectory": ti, "factors": p["factors"]})
    bar = progress if progress is True else False
    res = run_sweep(tasks, common={"dt": dt, "every": every_for(dt, [period]),
                                   "accuracy": accuracy, "judged": tuple(designed),
                                   "keep_result": keep},
                    workers=workers, scheduler=scheduler, pool=pool, cache_dir=cache_dir,
                    progress=bar)
    out = []
    for m, r in zip(meta, res, strict=True):
        rec = {**m, "status": r["status"], "message": r["message"],
               "max_error": r["max_error"], "checks": r["checks"], "peak": r["peak"],
               "envelope": r["envelope"], "regulators": tasks[len(out)]["regulators"]}
        if keep:
            results[m["id"]] = (r.get("result"), tasks[len(out)])
        out.append(rec)
    out_counts = getattr(res, "computed", 0), getattr(res, "cached", 0)
    key = "_stored" if stored else "_counts"
    results.setdefault(key, [0, 0])
    results[key][0] += out_counts[0]
    results[key][1] += out_counts[1]
    return out


def _merge(runs_all: list[dict], new: list[dict]) -> None:
    """Add runs to the list of every run; a run of the same id (a later round) replaces it."""
    at = {r["id"]: k for k, r in enumerate(runs_all)}
    for r in new:
        if r["id"] in at:
            runs_all[at[r["id"]]] = r
        else:
            at[r["id"]] = len(runs_all)
            runs_all.append(r)


def _remedy(state, choice, evals, costs, designed, names, methods, accuracy, trajs,
            payloads, makers, trace, it) -> bool:
    """Tighter synthesis or the next drive up for the joints no method passes."""
    acted = False
    stuck = [j for j in designed if choice[names[j]] is None]
    for j in stuck:
        jn = names[j]
        best = closest(evals[jn], costs[jn], accuracy)
        if best is None:
            continue
        e = evals[jn][best]
        rating = any(not why.startswith("tracking") for _, whys in e.failing for why in whys)
        if rating:
            tried = state["tried"].setdefault(jn, set())
            new, label = next_drive_up(state["arm"], j, trajs, payloads, makers=makers,
                                       tried=tried)
            if new is not None:
                tried.add(label)
                state["arm"] = new
                trace.add("remedy", f"{jn}: the closest method {best} fails a rating check; "
                          f"next drive up: {label}", joint=jn, iteration=it)
                acted = True
                continue
            trace.add("remedy", f"{jn}: {best} fails a rating check and no larger drive "
                      f"is available ({label})", joint=jn, iteration=it)
    if stuck:
        tight = [m for m in methods if m in TIGHTENABLE]
        if tight:
            for m in tight:
                state["levels"][m] += 1
            trace.add("remedy", f"{', '.join(names[j] for j in stuck)}: no method passes; "
                      f"tighter synthesis of {', '.join(tight)} (level "
                      f"{state['levels'][tight[0]]})", iteration=it)
            acted = True
    return acted


def _closest(outcome, designed, names, accuracy, trace, *, plants, trajs, payloads, dt, period,
             pool, workers, scheduler, cache_dir, progress, results, runs_all, strict) -> None:
    """The closest design when none meets the requirements: per joint its chosen method
    or the nearest one, verified as a whole; the case it fails and why."""
    evals, costs, synth = outcome["evals"], outcome["costs"], outcome["synth"]
    labels = outcome["labels"]
    choice = {}
    for j in designed:
        jn = names[j]
        c = outcome["choice"].get(jn) or closest(evals[jn], costs[jn], accuracy)
        if c is None:
            raise ManipcadError(f"no method could be synthesized for {jn}; see the trace")
        choice[jn] = c
    mix, mix_regs = _mix(choice, synth, designed, names, outcome["support"], outcome["nominal"])
    mix_label = _mix_label(choice, labels, designed, names, outcome["mixes"])
    if mix_label in outcome["docs"]:
        recs_mix = [r for r in runs_all if r["label"] == mix_label]
    else:
        recs_mix = _sweep({mix_label: mix}, plants, trajs, payloads, dt, period, accuracy,
                          designed, pool, workers, scheduler, cache_dir, progress, results)
        _merge(runs_all, recs_mix)
    final = {names[j]: evaluate(recs_mix, names[j], strict=strict) for j in designed}
    outcome.update(choice=choice, mix=mix, mix_regs=mix_regs, mix_label=mix_label, final=final,
                   final_runs=recs_mix, met=False)
    bad = [jn for jn, e in final.items() if not e.passed]
    for jn in bad or list(final):
        trace.add("decide", f"{jn}: no design meets the requirements; closest: {choice[jn]}, "
                  f"worst error {final[jn].worst_error:.3g} in {final[jn].worst_case}; "
                  f"{final[jn].reason()}", joint=jn, method=choice[jn])


__all__ = ["run_design", "DesignNotMet", "DESIGN"]
