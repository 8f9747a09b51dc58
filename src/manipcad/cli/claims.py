"""``manipcad study claims``: where the paper's claims hold, as maps over speed and load ratio.

::

    manipcad study claims [--arm light|industrial|heavy|FILE] [--grid quick|full]
                          [--workers N | --scheduler ADDRESS] --out DIR

Writes claims.json, claims.png and report.html into DIR (the cells' cache in
DIR/cache: a rerun computes only new cells). See :mod:`manipcad.study.claims`.
"""

from __future__ import annotations

import math
from pathlib import Path

from rich import box
from rich.markup import escape

from manipcad.cli.app import console, guarded
from manipcad.cli.options import Scheduler, Workers, dt_option, option, progress_flag
from manipcad.cli.study import StudyOut, StudyWs, study_app, study_folder
from manipcad.cli.tables import Table


@study_app.command("claims")
@guarded
def claims(
    out: StudyOut,
    ws: StudyWs = None,
    arm: option(str, "--arm", "light (the catalog Fig. 2 arm), industrial (+3 kg arm, 2 kg "
                "payload, CSF-20 on the turn), heavy (+5 kg arm, 5 kg payload, extra reach "
                "reduction) or a robot file of a cylindrical arm: exactly the joints turn "
                "(revolute), lift, reach (prismatic), in this order, each with a drive.") = "light",
    grid: option(str, "--grid", "quick (4 × 4 cells) or full (7 × 7).") = "quick",
    workers: Workers = None,
    scheduler: Scheduler = None,
    dt: dt_option() = 1e-4,
    progress: progress_flag("cells done") = True,
) -> None:
    """Claims maps: each claim's measured ratio over speed scale × load ratio; writes
    claims.json, claims.png and report.html into --out."""
    # deferred: start-up cost: keeps manipcad.study.claims out of the CLI's start
    from manipcad.study.claims import run_claims

    with study_folder(out, ws) as folder:
        doc = run_claims(folder, arm=arm, grid=grid, workers=workers, scheduler=scheduler,
                         dt=dt, progress=progress)
    t = Table(title=f"where the claims hold (arm {doc['arm']['name']}, grid {grid}: "
                    f"{len(doc['grid']['load_ratio'])} load ratios × "
                    f"{len(doc['grid']['speed_scale'])} speeds)", box=box.SIMPLE_HEAD)
    for col in ("claim", "threshold", "range of the ratio", "where it holds"):
        t.add_column(col, justify="right" if col == "threshold" else "left")
    for cid, c in doc["claims"].items():
        vals = [v for row in c["ratio"] for v in row if v is not None and math.isfinite(v)]
        rng = f"{min(vals):.3g} .. {max(vals):.3g}" if vals else "-"
        t.add_row(cid, f"{c['threshold']:g}", rng, c["where_it_holds"])
    console.print(t)
    s = doc["settings"]
    where = Path(out) if ws is None else Path(ws) / "studies" / out
    console.print(f"{s['cells_computed']} cells computed, {s['cells_cached']} from the cache; "
                  f"wrote {escape(str(where / 'claims.json'))}, claims.png, report.html",
                  highlight=False, soft_wrap=True)
