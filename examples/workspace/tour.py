"""The workspace tour of docs/workspace.md, from Python (run from the repository root:
``python examples/workspace/tour.py [FOLDER]``, default FOLDER /tmp/manipcad-tour-py).

The same steps as tour.sh; the results are stored with ``Workspace.store_result``.
"""

from __future__ import annotations

import shutil
import sys
import warnings
from pathlib import Path

import manipcad
from manipcad.control import load_regulators
from manipcad.errors import ManipcadWarning
from manipcad.model.load import CATALOG
from manipcad.sim import simulate
from manipcad.store import every_for
from manipcad.trajectories import load_trajectory
from manipcad.workspace import Workspace
from manipcad.workspace.runs import compare, rerun

EX = Path(__file__).resolve().parents[1]
out = Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/manipcad-tour-py")
shutil.rmtree(out, ignore_errors=True)
out.mkdir(parents=True)
ws = Workspace.init(out / "ws")

ws.add(EX / "ur5" / "ur5.yaml", name="ur5")
motor = out / "my_re40.yaml"
motor.write_text((CATALOG / "motors" / "maxon_re40_148877.yaml").read_text())
ws.add(motor)
ws.add(EX / "ur5" / "pick.yaml", name="pick")
(out / "pick_slow.yaml").write_text((EX / "ur5" / "pick.yaml").read_text()
                                    .replace("move_time: 1.5", "move_time: 2.5"))
ws.add(out / "pick_slow.yaml")
with warnings.catch_warnings():
    warnings.simplefilter("ignore", ManipcadWarning)
    arm = manipcad.load_robot(ws.resolve("robot", "ur5"))
for method, period in (("pid", 1e-3), ("ace_de", 1e-4)):   # synthesized, saved, added
    regs = manipcad.synthesize(arm, "all", method, spec={"bandwidth": 40.0}, period=period)
    manipcad.save_regulators(regs, out / f"{method}.yaml", robot=arm)
    ws.add(out / f"{method}.yaml", robot="ur5")

dt, t_end = 1e-4, 1.0
n = 0
for traj_name in ("pick", "pick_slow"):
    traj = load_trajectory(ws.resolve("trajectory", traj_name), robot=arm)
    for reg_name in ("pid", "ace_de"):
        n += 1
        regs = load_regulators(ws.resolve("regulator", reg_name), arm, dt=dt)
        every = every_for(dt, [r.period for r in regs])   # one sample per period
        res = simulate(arm, t_end=t_end, dt=dt, trajectory=traj, regulators=regs,
                       every=every)
        ws.store_result(res, name=f"run{n}", robot="ur5", trajectory=traj_name,
                        regulators=[reg_name],
                        run={"t_end": t_end, "dt": dt, "every": every, "drives": True})

for item in ws.list("results", where="max_error<2.5e-3"):
    print(item.name, f"max |e| = {item.metrics['max_error']:.3g} rad")
rows, fig = compare(ws, ["run1", "run3"])
fig.savefig(out / "compare.png")
print("re-run identical:", rerun(ws, "run1").identical)
print("bundle:", ws.export("run1", out / "share"))
print("check:", ws.check() or "clean")
