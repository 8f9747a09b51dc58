"""``manipcad synthesize``: design regulators and save them to a regulator file.

::

    manipcad synthesize ROBOT --method M (--joint J [--joint J2 ...] | --all)
                        [--spec KEY=VALUE ...] [--option KEY=VALUE ...] [--period S]
                        [--load-range LO,HI] [--realization observable|controllable]
                        [-t TRAJECTORY.yaml  (the reference of --spec max_error=...)]
                        [--rounds N] [--dt S]  (the verify-and-tighten loop of max_error)
                        --out reg.yaml [--force] [--json]
    manipcad synthesize --list

Several joints give one file with one group per joint (one group in all for a method
that spans joints, ``computed_torque_full``). The file holds everything needed to run
the regulators with no re-synthesis (:mod:`manipcad.control.files`); ``manipcad simulate
ROBOT -t T.yaml -r reg.yaml`` runs it.

``--spec max_error=E`` with ``-t`` designs against the coupled model: the regulators are
simulated on the whole robot along the trajectory (the other driven joints under ``pid``)
and each joint that misses E is re-designed for a tighter nominal target, for at most
``--rounds`` simulations (:func:`manipcad.expert.verify.synthesize_to_spec`); the command
prints each round and exits 1 when E is not reached (the file is written either way).
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Annotated, Any

import typer
import yaml
from rich import box

from manipcad.cli.app import app, console, err_console, guarded
from manipcad.cli.options import dt_option, force_flag, json_flag, option, ws_option
from manipcad.cli.tables import Table
from manipcad.control import METHODS, realization_complexity
from manipcad.control import synthesize as run_synthesis
from manipcad.control.files import regulators_document, save_regulators
from manipcad.errors import InputError
from manipcad.expert.engine import base_complexity
from manipcad.model.load import load_robot
from manipcad.trajectories import load_trajectory


def _pairs(items: list[str] | None, flag: str) -> dict[str, Any]:
    """KEY=VALUE pairs; values read as YAML scalars (numbers, true/false, [lists])."""
    out: dict[str, Any] = {}
    for item in items or ():
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(flag, "", f"expected KEY=VALUE, got {item!r}")
        try:
            v = yaml.safe_load(value)
        except yaml.YAMLError:
            raise InputError(flag, key, f"cannot read the value {value!r}") from None
        if isinstance(v, str):
            try:
                v = float(v)
            except ValueError:
                pass
        out[key.strip()] = v
    return out


def method_table() -> Table:
    """The registry as a table: method, paper section, signals, complexity, summary."""

    t = Table(box=box.SIMPLE_HEAD, title="synthesis methods (manipcad.control.METHODS)")
    for col in ("method", "section", "ops", "stored", "signals it needs; what it is"):
        t.add_column(col, overflow="fold")
    for name, m in METHODS.items():
        c = base_complexity(None, name)
        t.add_row(name, m.section, str(c["ops_per_period"]), str(c["gains_stored"]),
                  f"{' '.join(c['signals'])}; {m.summary}")
    t.caption = ("ops: arithmetic operations per control period and numbers stored, counted "
                 "from the compiled law on the Fig. 2 arm's turning drive")
    return t


@app.command()
@guarded
def synthesize(
    robot: Annotated[str | None, typer.Argument(
        help="A catalog robot name or a robot file.")] = None,
    method: option(str | None, "--method -m", "Synthesis method (see --list).") = None,
    joint: option(list[str] | None, "--joint -j", "Joint name or number 1..n; repeat for "
                  "several.") = None,
    all_joints: option(bool, "--all", "Every joint with a drive.") = False,
    spec: option(list[str] | None, "--spec", "Spec entry KEY=VALUE, e.g. bandwidth=40 (rad/s), "
                 "damping=1, max_error=1e-3 (rad); repeat.") = None,
    option: option(list[str] | None, "--option", "Method option KEY=VALUE, e.g. order=2, "
                   "feedforward=false, grid=[8,1]; repeat.") = None,
    period: option(float | None, "--period", "Control period, s (default 1e-4).") = None,
    load_range: option(str | None, "--load-range", "H_ii range LO,HI of the joint, kg·m² (default: "
                       "over the joint limits).") = None,
    realization: option(str | None, "--realization", "ace_tf: observable (quasi-stationary) or "
                        "controllable (filter first).") = None,
    trajectory: option(Path | None, "--trajectory -t", "The reference a --spec max_error=... is "
                       "asked on.") = None,
    rounds: option(int, "--rounds", "With --spec max_error and -t: the most coupled simulations of "
                   "the verify-and-tighten loop (0: design on the nominal model only).") = 6,
    dt: dt_option("Integration step of those simulations, s.") = 1e-4,
    out: option(str | None, "--out -o", "Regulator file to write (YAML); with --ws the regulator's "
                "NAME in the workspace.") = None,
    ws: ws_option("Workspace: the robot may be its item name, and the regulator file is "
        "stored and indexed there (regulators/NAME).") = None,
    force: force_flag("Replace an existing file.") = False,
    as_json: json_flag("Print the file as JSON.") = False,
    list_methods: option(bool, "--list", "List the methods with their signals, complexity and "
                         "section.") = False,
) -> None:
    """Synthesize regulators (paper section 3 and baselines) and save them to a file."""

    if list_methods:
        if as_json:

            typer.echo(json.dumps([{"method": name, "section": m.section, "summary": m.summary,
                                    **base_complexity(None, name)}
                                   for name, m in METHODS.items()], indent=2))
            return
        console.print(method_table())
        return
    if robot is None:
        raise InputError("ROBOT", "", "missing: give a robot (or --list)")
    if method is None:
        raise InputError("--method", "", f"missing; one of {', '.join(METHODS)}")
    if method not in METHODS:
        raise InputError("--method", "", f"unknown method {method!r}; one of "
                         f"{', '.join(METHODS)}")
    if not joint and not all_joints:
        raise InputError("--joint", "", "missing: give --joint J (repeatable) or --all")
    if joint and all_joints:
        raise InputError("--all", "", "give --joint or --all, not both")
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace, resolve_input

    space = Workspace(ws) if ws is not None else None
    if out is None and not as_json:
        raise InputError("--out", "", "missing: the regulator file to write (or --json)")
    if space is None and out is not None:
        out = Path(out)
        if out.exists() and not force:
            raise InputError(str(out), "", "exists; give --force to replace it")
    arm = load_robot(resolve_input("robot", robot, space))
    if all_joints:
        idx = [j for j in range(arm.n) if arm.drives and arm.drives[j] is not None]
        if not idx:
            raise InputError(robot, "drives", "the robot has no drives to design for")
    else:
        idx = []
        for name in joint:
            idx.append(_joint(arm, name))
    options = _pairs(option, "--option")
    if period is not None:
        options["period"] = period
    if realization is not None:
        options["realization"] = realization
    if load_range is not None:
        try:
            lo, hi = (float(v) for v in load_range.split(","))
        except ValueError:
            raise InputError("--load-range", "", f"expected LO,HI in kg·m², got "
                             f"{load_range!r}") from None
        options["load_range"] = (lo, hi)
    if trajectory is not None:

        options["reference"] = load_trajectory(trajectory, robot=arm)
    spec_d = _pairs(spec, "--spec") or None
    coupled = None
    if rounds < 0:
        raise InputError("--rounds", "", f"must be >= 0, got {rounds}")
    if not (dt > 0 and dt < 1):
        raise InputError("--dt", "", f"must be in (0, 1) s, got {dt}")
    if (spec_d and "max_error" in spec_d and trajectory is not None and rounds > 0
            and not METHODS[method].spans):
        # deferred: start-up cost: keeps manipcad.expert.verify out of the CLI's start
        from manipcad.expert.verify import synthesize_to_spec

        ref = options.pop("reference")
        with err_console.status(f"synthesizing {method} for {len(idx)} joint(s) against the "
                                f"coupled simulation along {trajectory}..."):
            coupled = synthesize_to_spec(arm, ref, idx, method, spec=spec_d, rounds=rounds,
                                         dt=dt, **options)
        regs = list(coupled.regulators)
    else:
        with err_console.status(f"synthesizing {method} for {len(idx)} joint(s)..."):
            regs = run_synthesis(arm, idx, method, spec=spec_d, **options)
    regs = regs if isinstance(regs, list) else [regs]
    doc = regulators_document(regs, robot=arm)
    if out is not None and space is None:
        save_regulators(regs, out, robot=arm)
    elif out is not None:

        with tempfile.TemporaryDirectory() as tmp:
            path = save_regulators(regs, Path(tmp) / f"{out}.yaml", robot=arm)
            item = space.add(path, kind="regulator", name=str(out), force=force)
        out = space.root / "regulators" / f"{item.name}.yaml"
    if as_json:
        typer.echo(json.dumps(doc, indent=2, default=str))
        if coupled is not None and not coupled.reached:
            err_console.print(coupled.why, highlight=False, soft_wrap=True)
            raise typer.Exit(1)
        return
    t = Table(box=box.SIMPLE_HEAD, title=f"{method} on {arm.name}")
    for col in ("joint(s)", "law", "ops/period", "stored", "signals"):
        t.add_column(col, overflow="fold")
    for r in regs:
        c = realization_complexity(r)
        t.add_row(", ".join(r.joint_names), r.describe(), str(c["ops_per_period"]),
                  str(c["gains_stored"]), ", ".join(c["signals"]))
    console.print(t)
    if coupled is not None:
        rt = Table(box=box.SIMPLE_HEAD, title=f"the coupled simulation (asked "
                   f"{coupled.asked:g}; other joints held by {coupled.held or 'nothing'})",
                   caption="per round: the nominal target the design was asked for, the "
                   "simulated max |e| (rad or m), the run checks other than the tracking "
                   "that fail")
        rt.add_column("round")
        for name in coupled.simulated:
            rt.add_column(f"{name}: target / simulated")
        rt.add_column("run checks failing")
        for k, rd in enumerate(coupled.rounds):
            rt.add_row(str(k + 1), *(f"{rd.targets[n]:.3g} / {rd.simulated[n]:.3g}"
                                     for n in coupled.simulated),
                       "; ".join(f"{n}: {', '.join(f)}" for n, f in rd.failing.items())
                       or "none")
        console.print(rt)
        style = "green" if coupled.reached else "red"
        console.print(f"[{style}]{coupled.why}[/]", highlight=False, soft_wrap=True)
    if out is not None:
        import shlex  # deferred: start-up cost: shlex loaded on first use

        run = (f"-r {shlex.quote(out.stem)} --ws {shlex.quote(str(space.root))}"
               if space is not None else f"-r {shlex.quote(str(out))}")
        console.print(f"wrote {out} (run it: manipcad simulate {shlex.quote(robot)} "
                      f"-t TRAJECTORY.yaml {run})", highlight=False, soft_wrap=True)
        if coupled is not None and coupled.others:
            console.print(f"{out.name} holds the regulator of {', '.join(coupled.simulated)} "
                          f"only. The coupled simulation held {coupled.held}; without regulators "
                          f"for them (-r), simulate and verify apply U = 0 to those joints",
                          highlight=False, soft_wrap=True)
    if coupled is not None and not coupled.reached:
        raise typer.Exit(1)


def _joint(arm, name: str) -> int:
    """A joint by name or by number 1..n."""
    if name in arm.joint_names:
        return arm.joint_names.index(name)
    try:
        k = int(name)
    except ValueError:
        raise InputError("--joint", "", f"no joint {name!r} in {arm.name!r}; joints: "
                         f"{', '.join(arm.joint_names)} (or numbers 1..{arm.n})") from None
    if not 1 <= k <= arm.n:
        raise InputError("--joint", "", f"joint number {k} out of 1..{arm.n}")
    return k - 1
