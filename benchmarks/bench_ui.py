"""Benchmark: ``manipcad ui`` page loads and a simulation started from the page vs the CLI.

Usage::

    python benchmarks/bench_ui.py [--t-end 2.0] [--loads 3] [--json out.json]

What is timed (wall clock, ``time.perf_counter``), in one run on one machine:

* **page load**: each page of the application in headless Chromium (Debian's
  ``/usr/bin/chromium`` driven by Playwright), from ``page.goto`` to the page
  built and live: its websocket connected and its content shown (pages build once
  their tab is connected, for the tab's own state), median of ``--loads`` loads.
* **simulation from the page**: a PUMA 560 run of ``--t-end`` s (dt = 1e-4 s,
  a PID on every joint, the laws (2) on every joint), from the click on
  "Simulate" to the page showing "done" (worker process start, imports, run,
  storing into the workspace, the page's poll every 0.25 s).
* **the same ``manipcad simulate``**: the CLI as a subprocess on the same
  robot, trajectory and regulator files (process start, imports, run, writing
  the result folder), after one warm-up run of each.
* **the Robots page's 3-D view**: /robots from ``page.goto`` to its projected stick
  view (SVG) drawn; a pose slider clicked to the view redrawn (the server's round
  trip); the interactive WebGL view from its button's click to its canvas drawn
  (software WebGL in headless Chromium); medians of ``--loads``, after one
  untimed load of the view (plotly.js compiled once, as the CLI gets a warm-up
  run). Also, in a fresh browser: the main menu, 3 s, then /robots to its view
  drawn (the first figure, plotly.js compiled while the main menu was idle).
* **other pages while a run goes**: the load time of /robots while the page's
  run is in progress (the worker is a separate process).

Targets: pages < 1 s; page run <= 1.5x the CLI's.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run"]
PAGES = ("/", "/robots", "/drives", "/trajectories", "/requirements", "/synthesis",
         "/simulation", "/results", "/identification")


def prepare(ws_dir: Path, t_end: float) -> tuple[Path, Path]:
    """A workspace with the trajectory and the PID regulators (through the UI's API)."""
    import manipcad
    from manipcad.errors import ManipcadWarning
    from manipcad.ui import logic

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = manipcad.load_robot("puma560")
    ws = logic.open_workspace(ws_dir)
    traj = logic.make_trajectory({"type": "cosine", "amplitude": [0.2] * 6,
                                  "omega": [3.0] * 6, "duration": t_end}, arm)
    logic.save_trajectory_to(ws, traj, "move")
    logic.synthesize_to(ws, arm, "pid", name="pid")
    return ws.resolve("trajectories", "move"), ws.resolve("regulators", "pid")


def cli_run(traj: Path, reg: Path, out: Path, t_end: float) -> float:
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "manipcad", "simulate", "puma560", "-t", str(traj),
                    "-r", str(reg), "--out", str(out), "--t-end", str(t_end), "--force"],
                   check=True, env=env, capture_output=True)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--loads", type=int, default=3)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()

    from playwright.sync_api import sync_playwright
    from test_ui_browser import _fill, _open, _pick, _slide, _start, _stop

    tmp = Path(tempfile.mkdtemp())
    traj, reg = prepare(tmp / "ws", args.t_end)
    cli_run(traj, reg, tmp / "warm", args.t_end)          # compile / load the kernels
    proc, base = _start(tmp / "ws")
    out: dict = {"t_end_s": args.t_end}
    try:
        with sync_playwright() as pw:
            # a fresh browser: the main menu, 3 s of reading it, then /robots to its view
            fresh = pw.chromium.launch(executable_path="/usr/bin/chromium", args=FLAGS)
            page = fresh.new_page(viewport={"width": 1400, "height": 900})
            _open(page, base + "/")
            time.sleep(3.0)
            t0 = time.perf_counter()
            _open(page, base + "/robots")
            page.locator("[data-testid=stick-view] .scatterlayer .trace").nth(5).wait_for()
            out["fresh_robots_3d_view_s"] = time.perf_counter() - t0
            fresh.close()
            browser = pw.chromium.launch(executable_path="/usr/bin/chromium", args=FLAGS)
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            loads = {}
            for path in PAGES:
                times = []
                for _ in range(args.loads):
                    t0 = time.perf_counter()
                    _open(page, base + path)
                    times.append(time.perf_counter() - t0)
                loads[path] = statistics.median(times)
            out["page_load_s"] = loads
            views, lives, moves, gls = [], [], [], []
            view = "[data-testid=stick-view] .scatterlayer .trace"
            _open(page, base + "/robots")             # warm-up: plotly.js compiled once
            page.locator(view).nth(5).wait_for()      # (the fresh-browser row above: cold)
            for _ in range(args.loads):
                t0 = time.perf_counter()
                _open(page, base + "/robots")
                lives.append(time.perf_counter() - t0)
                # the projected 3-D view's six traces drawn (SVG): floor ... gripper
                page.locator(view).nth(5).wait_for()
                views.append(time.perf_counter() - t0)
                title = page.locator("[data-testid=stick-view] .gtitle")
                before = title.text_content()
                t0 = time.perf_counter()
                _slide(page, "pose-1", 0.9)
                page.wait_for_function("b => document.querySelector("
                                       "'[data-testid=stick-view] .gtitle').textContent != b",
                                       arg=before)
                moves.append(time.perf_counter() - t0)
            for _ in range(args.loads):                 # after: its teardown costs a load
                _open(page, base + "/robots")
                page.locator(view).nth(5).wait_for()
                t0 = time.perf_counter()
                page.get_by_test_id("open-webgl").click()
                page.locator("[data-testid=stick-webgl] .gl-container canvas").first.wait_for()
                gls.append(time.perf_counter() - t0)
            out["robots_3d_view_s"] = statistics.median(views)
            out["robots_3d_view_samples_s"] = views
            out["robots_live_samples_s"] = lives
            out["robots_pose_redraw_s"] = statistics.median(moves)
            out["robots_webgl_on_demand_s"] = statistics.median(gls)

            def page_run(name: str) -> tuple[float, float]:
                _open(page, base + "/simulation")
                _pick(page, "sim-reg", "pid")
                _fill(page, "sim-dt", "1e-4")
                _fill(page, "sim-name", name)
                status = page.get_by_test_id("sim-status")
                t0 = time.perf_counter()
                page.get_by_test_id("sim-run").click()
                other = float("nan")
                while True:
                    text = status.inner_text()
                    if f"results/{name}" in text or text.startswith(("error", "cancelled")):
                        break
                    if text.startswith("running") and other != other:
                        p2 = browser.new_page()
                        t1 = time.perf_counter()
                        _open(p2, base + "/robots")
                        other = time.perf_counter() - t1
                        p2.close()
                    time.sleep(0.05)
                wall = time.perf_counter() - t0
                assert text.startswith("done"), text
                return wall, other

            page_run("warm")                                    # the worker's first run
            ui_wall, other = page_run("bench")
            browser.close()
    finally:
        _stop(proc)
    cli_wall = cli_run(traj, reg, tmp / "cli", args.t_end)
    out.update(ui_run_s=ui_wall, cli_run_s=cli_wall, ratio=ui_wall / cli_wall,
               robots_page_during_run_s=other)
    print(f"page load (median of {args.loads}, to the page built and live):")
    for path, t in out["page_load_s"].items():
        print(f"  {path:15s} {1e3 * t:7.0f} ms")
    print(f"  /robots with its 3-D view drawn {1e3 * out['robots_3d_view_s']:7.0f} ms "
          "(projected, SVG; each: "
          f"{', '.join(f'{1e3 * t:.0f}' for t in out['robots_3d_view_samples_s'])} ms; "
          "of which the page live: "
          f"{', '.join(f'{1e3 * t:.0f}' for t in out['robots_live_samples_s'])} ms)")
    print(f"  the same, first figure of a fresh browser (3 s on the main menu before) "
          f"{1e3 * out['fresh_robots_3d_view_s']:5.0f} ms")
    print(f"  a pose slider moved -> view redrawn {1e3 * out['robots_pose_redraw_s']:5.0f} ms")
    print(f"  interactive WebGL view, on demand (click -> drawn) "
          f"{1e3 * out['robots_webgl_on_demand_s']:5.0f} ms")
    print(f"PUMA 560, {args.t_end:g} s at dt = 1e-4 s, PID on 6 joints:")
    print(f"  from the page (click -> 'done')      {ui_wall:6.2f} s")
    print(f"  manipcad simulate (process, wall)     {cli_wall:6.2f} s")
    print(f"  ratio page / CLI                      {ui_wall / cli_wall:6.2f}  (target <= 1.5)")
    print(f"  /robots loaded during the run in      {1e3 * other:6.0f} ms")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
