"""The design's files: robot.yaml, regulators.yaml, trajectories/, design.json, report.html,
c/ and runs/.

- ``robot.yaml``: the designed arm (drives, counterweights) carrying the nominal payload
  (the middle of the range) at the tool point: the arm the regulators were designed for
  (``manipcad simulate`` runs the regulators on it without ``--allow-other-robot``).
- ``regulators.yaml``: the chosen method of every joint, one regulator file.
- ``trajectories/traj-K.yaml``: the trajectories, as the runs used them.
- ``design.json``: see :func:`design_document`.
- ``report.html``: one self-contained page (:mod:`manipcad.report.design`); its figures
  also as ``figures/envelope.png``, ``ratings.png``, ``methods.png``.
- ``c/``: the drive processor's C99: the arm's dynamics (``<prefix>.h/.c``) and the
  regulators' updates (``<prefix>_regulators.h/.c``).
- ``runs/<case>/``: the final design's runs (``store_runs="all"``: every run of the
  sweep) as result folders (:mod:`manipcad.store`), their inputs included (the plant's
  robot file, the trajectory, the regulators).
"""

from __future__ import annotations

import json
import math
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Any

from manipcad.codegen import generate
from manipcad.control.c_code import regulators_c
from manipcad.control.files import regulators_yaml
from manipcad.design.drives import parts
from manipcad.design.judge import margin, verdict
from manipcad.errors import ManipcadError, ManipcadWarning
from manipcad.fileio import atomic_write_text, json_safe
from manipcad.model.tree_file import save_robot
from manipcad.report.design import write_report
from manipcad.store import save_result
from manipcad.trajectories import save_trajectory

#: the design.json format's version
FORMAT = 1


def _fmt_cmd(parts: list[str]) -> str:
    import shlex  # deferred: start-up cost: shlex loaded on first use

    return " ".join(shlex.quote(str(p)) for p in parts)


def worst_margins(runs: list[dict], joints: list[str]) -> dict[str, dict]:
    """Per joint and check the smallest margin (1 − value/limit) over the runs, with the
    value, limit, unit, verdict and the run it happens in.

    Example:
        >>> from manipcad.design.judge import tracking_check
        >>> r = [{"id": "a", "checks": {"q1": {"tracking": tracking_check(1e-4, 1e-3, "rad")}}},
        ...      {"id": "b", "checks": {"q1": {"tracking": tracking_check(5e-4, 1e-3, "rad")}}}]
        >>> w = worst_margins(r, ["q1"])["q1"]["tracking"]
        >>> w["case"], round(w["margin"], 3)
        ('b', 0.5)
    """
    out: dict[str, dict] = {j: {} for j in joints}
    for r in runs:
        for j in joints:
            for name, c in (r["checks"].get(j) or {}).items():
                m = margin(c)
                cur = out[j].get(name)
                key = -math.inf if c.get("verdict") == "fail" and m is None else \
                    (math.inf if m is None else m)
                if cur is None or key < cur["_key"]:
                    out[j][name] = {"value": c.get("value"), "limit": c.get("limit"),
                                    "unit": c.get("unit", ""), "verdict": c.get("verdict"),
                                    "margin": m, "case": r["id"], "_key": key}
    for j in out:
        for c in out[j].values():
            c.pop("_key", None)
    return out


def _store_runs(folder: Path, runs: list[dict], results: dict, arm) -> None:
    """Every run as a result folder under ``folder`` (written beside, then swapped in)."""

    tmp = Path(tempfile.mkdtemp(prefix=".runs-new-", dir=folder.parent))
    try:
        for r in runs:
            res, task = results.get(r["id"], (None, None))
            if res is None:
                continue
            # the plant as it ran, saved in the result (metrics.json names it so; a
            # temporary file would be gone after the design)
            save_result(res, tmp / r["id"], inputs={"robot": task["plant"],
                                                    "trajectory": task["trajectory"],
                                                    "regulators": task["regulators"]},
                        joint_types=arm.joint_types, plot=False, csv=False,
                        run={"design_case": r["id"], "payload_kg": r["payload"],
                             "uncertainty_sample": r["sample"], "dt": None})
        old = None
        if folder.exists():
            old = folder.with_name(f".runs-old-{tmp.name}")
            folder.rename(old)
        tmp.rename(folder)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def write_c(folder: Path, nominal, regs, prefix: str = "design") -> list[str]:
    """The drive processor's C99 (dynamics and regulators) into ``folder``; the file names."""


    folder.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        gen = generate(nominal, attach=False)
    if not gen.generated:
        raise ManipcadError(f"cannot generate the dynamics code: {gen.reason}")
    hdr, src = gen.c_code(prefix)
    rh, rc = regulators_c(regs, nominal, prefix, source="regulators.yaml")
    files = {f"{prefix}.h": hdr, f"{prefix}.c": src, f"{prefix}_regulators.h": rh,
             f"{prefix}_regulators.c": rc}
    for name, text in files.items():
        atomic_write_text(folder / name, text)
    return sorted(files)


def support_failures(runs: list[dict], joints: list[str]) -> dict[str, dict[str, int]]:
    """Per joint the requirements do not name: each check it fails and in how many runs.

    Example:
        >>> r = [{"checks": {"lift": {"position": {"verdict": "fail"}}}}] * 2
        >>> support_failures(r, ["lift"])
        {'lift': {'position': 2}}
    """
    out: dict[str, dict[str, int]] = {}
    for jn in joints:
        for r in runs:
            for name, c in (r["checks"].get(jn) or {}).items():
                if c.get("verdict") == "fail":
                    out.setdefault(jn, {}).setdefault(name, 0)
                    out[jn][name] += 1
    return out


def joint_ratings(d) -> dict | None:
    """A drive's ratings referred to the joint: gear repeated-peak torque and motor peak
    torque·|i_r| (N·m; η = 1), motor max speed/|i_r| (rad/s), motor peak current (A).

    Example:
        >>> import manipcad
        >>> r = joint_ratings(manipcad.load_robot("cylindrical").drives[0])
        >>> sorted(r)
        ['gear_peak_torque', 'max_speed', 'motor_peak_torque', 'peak_current']
    """
    if d is None:
        return None
    r = abs(float(d.ratio))
    return {"gear_peak_torque": float(d.gear_peak_torque),
            "motor_peak_torque": float(d.peak_torque) * r,
            "max_speed": float(d.max_speed) / r,
            "peak_current": float(d.peak_torque) / float(d.k_m) if d.k_m else math.nan}


def write_outputs(out: Path, *, req, arm, nominal, trajectories, outcome, runs, results,
                  decoupling, drive_info, recs, methods, designed, trace, settings, sources,
                  store_runs, wall, parts_before, stage_times=None) -> dict:
    """Write every file of the design folder; return the design.json document."""

    out.mkdir(exist_ok=True)
    save_robot(nominal, out / "robot.yaml")
    atomic_write_text(out / "regulators.yaml", regulators_yaml(outcome["mix_regs"],
                                                               robot=nominal))
    tdir = out / "trajectories"
    tdir.mkdir(exist_ok=True)
    traj_files = []
    for k, tr in enumerate(trajectories):
        f = tdir / f"traj-{k}.yaml"
        save_trajectory(tr, f)  # the one trajectory writer (fileio.dump_yaml)
        traj_files.append(f"trajectories/traj-{k}.yaml")
    c_files = write_c(out / "c", nominal, outcome["mix_regs"])
    if store_runs != "none":
        _store_runs(out / "runs", runs if store_runs == "all" else outcome["final_runs"],
                    results, arm)
    doc = design_document(req=req, arm=arm, nominal=nominal, outcome=outcome, runs=runs,
                          decoupling=decoupling, drive_info=drive_info, recs=recs,
                          methods=methods, designed=designed, trace=trace, settings=settings,
                          sources=sources, traj_files=traj_files, c_files=c_files,
                          counts=results.get("_counts", [0, 0]), wall=wall,
                          parts_now=parts(arm), store_runs=store_runs,
                          stage_times=stage_times or {})
    atomic_write_text(out / "design.json", json.dumps(json_safe(doc), indent=2,
                                                      ensure_ascii=False) + "\n")

    write_report(out / "report.html", doc, runs, png_dir=out / "figures")
    return doc


def design_document(*, req, arm, nominal, outcome, runs, decoupling, drive_info, recs, methods,
                    designed, trace, settings, sources, traj_files, c_files, counts, wall,
                    parts_now, store_runs, stage_times=None) -> dict[str, Any]:
    """The design.json document.

    Keys: ``status`` ("met" | "not met"), ``accuracy`` (rad or m) and the joints it applies
    to, ``parts`` (per joint motor, gear, ratio, source), ``counterbalance`` (the
    decoupling report), ``methods`` (per designed joint), ``support`` and
    ``support_failures`` (the joints the requirements do not name: their PID, and each
    check they fail with the number of runs), ``worst_case_error``
    ({joint: rad or m} over the final design's runs), ``worst_margins`` (per joint and
    check), ``candidates`` (per method and joint: cost, worst error, passed, why not),
    ``cases`` (every run: id, method, payload, uncertainty sample, trajectory, status,
    max errors, per-joint verdicts, its folder), ``final_cases`` (the ids of the final
    design's runs), ``reproduce`` (the command that reruns the nominal case and the
    numbers it gives), ``rules`` (fired, excluded), ``trace`` (the decision trace),
    ``failure`` (when not met: the joint, the closest method, the case and why),
    ``settings``, ``executor`` (runs computed and read from the cache), ``files``.
    """
    names = list(arm.joint_names)
    dnames = [names[j] for j in designed]
    final_runs = outcome["final_runs"]
    driven = [n for n, d in zip(names, arm.drives, strict=True) if d is not None]
    worst = {}
    for jn in driven:
        vals = [(r["max_error"] or {}).get(jn) for r in final_runs]
        worst[jn] = math.inf if any(v is None for v in vals) else max(vals)
    nominal_id = None
    for r in final_runs:
        if r["sample"] == 0 and r["trajectory"] == 0 and \
                r["payload_index"] == len(settings["payloads"]) // 2:
            nominal_id = r["id"]
    nom = next((r for r in final_runs if r["id"] == nominal_id), None)
    reproduce = None
    if nom is not None:
        reproduce = {
            "case": nominal_id,
            "command": _fmt_cmd(["manipcad", "simulate", "robot.yaml", "-t", traj_files[0],
                                 "-r", "regulators.yaml", "--dt", repr(settings["dt"]),
                                 "--out", "nominal_run"]),
            "cwd": "the design folder",
            "max_error": nom["max_error"]}
    cand = {}
    for m in outcome["labels"]:
        per = {}
        for jn in dnames:
            e = outcome["evals"][jn].get(m)
            if e is None:
                continue
            per[jn] = {**e.to_dict(), "cost": outcome["costs"][jn].get(m),
                       "complexity": outcome["synth"][m].complexity.get(
                           names.index(jn)),
                       "reason": e.reason()}
        cand[outcome["labels"][m]] = {"method": m, "level": outcome["synth"][m].level,
                                      "spec": outcome["synth"][m].spec,
                                      "refused": {names[j]: why for j, why in
                                                  outcome["synth"][m].errors.items()},
                                      "joints": per}
    cases = []
    final_ids = {r["id"] for r in final_runs}
    for r in runs:
        cases.append({
            "id": r["id"], "method": r["label"], "payload": r["payload"],
            "sample": r["sample"], "sample_name": r["sample_name"],
            "trajectory": r["trajectory"], "status": r["status"], "message": r["message"],
            "max_error": r["max_error"],
            "verdict": {jn: verdict(r["checks"].get(jn) or {}, strict=settings["strict"])
                        for jn in names},
            "final": r["id"] in final_ids,
            "folder": (f"runs/{r['id']}" if store_runs == "all" or (
                store_runs == "final" and r["id"] in final_ids) else None),
            "factors": r["factors"]})
    met = bool(outcome.get("met"))
    peaks: dict[str, dict] = {}
    for k, jn in enumerate(names):
        vals = [r["peak"] for r in final_runs if r.get("peak")]
        peaks[jn] = {w: (max(v[w][k] for v in vals) if vals else None)
                     for w in ("torque", "speed", "current")}
    doc: dict[str, Any] = {
        "format": FORMAT,
        "status": "met" if met else "not met",
        "robot": arm.name,
        "accuracy": float(req.accuracy),
        "accuracy_joints": dnames,
        "requirements": json_safe(req.model_dump()),
        "parts": {jn: {**(p or {}), "source": drive_info["source"].get(jn)}
                  for jn, p in parts_now.items()},
        "selection": drive_info.get("selection"),
        "counterbalance": decoupling.to_dict(names),
        "methods": {jn: outcome["choice"].get(jn) for jn in dnames},
        "support": {names[j]: "pid" for j in range(arm.n)
                    if arm.drives[j] is not None and j not in designed},
        "support_failures": support_failures(final_runs, [
            names[j] for j in range(arm.n) if arm.drives[j] is not None and j not in designed]),
        "worst_case_error": worst,
        "worst_margins": worst_margins(final_runs, names),
        "peaks": peaks,
        "ratings": {jn: joint_ratings(d) for jn, d in zip(names, nominal.drives, strict=True)},
        "candidates": cand,
        "cases": cases,
        "final_cases": [r["id"] for r in final_runs],
        "reproduce": reproduce,
        "rules": {"fired": [{"id": rid, "text": recs.rule_texts.get(rid, rid)}
                            for rid in recs.fired],
                  "excluded": dict(recs.excluded),
                  "ranked": [r.method for r in recs], "verified": list(methods),
                  "derived": {k: getattr(v, "value", None) for k, v in recs.derived.items()},
                  "notes": list(recs.notes)},
        "trace": list(trace),
        "settings": settings,
        "sources": {k: (str(v) if not isinstance(v, list) else [str(x) for x in v])
                    for k, v in sources.items()},
        "executor": {"runs_computed": int(counts[0]), "runs_cached": int(counts[1]),
                     "wall_time_s": wall, "stage_wall_s": dict(stage_times or {})},
        "files": {"robot": "robot.yaml", "regulators": "regulators.yaml",
                  "figures": ["figures/envelope.png", "figures/ratings.png",
                              "figures/methods.png"],
                  "trajectories": traj_files, "report": "report.html",
                  "c": [f"c/{f}" for f in c_files],
                  "runs": "runs/" if store_runs != "none" else None},
        "units": {"accuracy": "rad (m for prismatic joints)",
                  "worst_case_error": "rad (m for prismatic joints)", "payload": "kg",
                  "period": "s", "dt": "s", "uncertainty": "fraction"},
    }
    if not met:
        bad = [jn for jn in dnames if not outcome["final"][jn].passed] or dnames
        jn = bad[0]
        e = outcome["final"][jn]
        first = e.failing[0] if e.failing else (e.worst_case, [])
        doc["failure"] = {
            "joint": jn, "closest_method": outcome["choice"].get(jn),
            "case": first[0], "why": first[1], "worst_error": e.worst_error,
            "text": (f"no design meets the requirements within {settings['max_iterations']} "
                     f"rounds: {jn} with {outcome['choice'].get(jn)} (the closest) fails in "
                     f"{len(e.failing)} of {e.runs} cases, e.g. {first[0]}: "
                     f"{', '.join(first[1]) or 'see design.json'}; worst error "
                     f"{e.worst_error:.3g} against {req.accuracy:.3g}")}
    return doc


__all__ = ["write_outputs", "design_document", "worst_margins", "write_c", "FORMAT"]
