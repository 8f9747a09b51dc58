"""Closed-loop test data for payload identification, made by the project's simulator.

The arm carries the payload (the simulator's ``payload``), PID regulators hold
each joint along a ``waypoints`` motion with dwells, the drives have their
dry and viscous friction, and the recorded drive torques and armature currents
get Gaussian noise. Identification sees only the unloaded robot and the
recorded, noisy samples.
"""

from __future__ import annotations

import warnings
from functools import cache
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import numpy as np

import manipcad
from manipcad.control import synthesize
from manipcad.control.design import damping_floor, nominal_drive
from manipcad.errors import ManipcadWarning
from manipcad.model.robot import Drive
from manipcad.sim import simulate
from manipcad.trajectories import waypoints

#: noise of the measured signals: this fraction of each drive's RMS (torque and current)
NOISE = 0.01


def erd_robots() -> Path:
    """The robots folder of example-robot-data (a test dependency)."""
    try:  # example-robot-data 6 ships data only, under the cmeel prefix
        d = Path(distribution("example-robot-data").locate_file(
            "cmeel.prefix/share/example-robot-data/robots"))
    except PackageNotFoundError:  # pragma: no cover
        d = None
    if d is None or not d.is_dir():  # pragma: no cover - older releases
        from example_robot_data.path import EXAMPLE_ROBOT_DATA_MODEL_DIR  # type: ignore

        d = Path(EXAMPLE_ROBOT_DATA_MODEL_DIR)
    return d


def ur10_with_drives() -> manipcad.Robot:
    """The UR10 of example-robot-data with harmonic-drive joints (our assumption:
    101:1 gears, motor data of the 1 kW / 0.2 kW class, dry friction of a few % of
    the joints' torques)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = manipcad.load_robot(erd_robots() / "ur_description" / "urdf" / "ur10_robot.urdf")
    big = dict(J=1.5e-4, ratio=101.0, k_v=1.0e-4, M_f=(0.06, 0.06), R=0.25, L=0.3e-3,
               k_m=0.13, k_w=0.13, k_u=1.0, u_max=60.0)
    small = dict(J=3.0e-5, ratio=101.0, k_v=2.0e-5, M_f=(0.012, 0.012), R=1.0, L=0.5e-3,
                 k_m=0.06, k_w=0.06, k_u=1.0, u_max=60.0)
    drives = tuple(Drive(**(big if j < 3 else small)) for j in range(arm.n))
    return arm.replace(drives=drives)


def load(name: str) -> manipcad.Robot:
    if name == "ur10":
        return ur10_with_drives()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot(name)


#: per robot: poses (rad or m) around which the waypoints are drawn, their spread, and
#: the payload (kg, com m in the link frame, link)
SETUPS = {
    "puma560": dict(center=[0.0, -0.3, 0.3, 0.0, 0.3, 0.0], spread=[0.8, 0.6, 0.6, 1.0, 0.8, 1.0],
                    mass=3.2, com=[0.02, -0.01, 0.06], link=None),
    "ur10": dict(center=[0.0, -1.2, 1.0, -1.2, -1.4, 0.0], spread=[0.8, 0.5, 0.6, 0.8, 0.8, 1.0],
                 mass=3.2, com=[0.01, 0.08, 0.02], link="wrist_3_link"),
    "cylindrical": dict(center=[0.0, 0.5, 0.25], spread=[1.0, 0.15, 0.2],
                        mass=1.0, com=[0.0, 0.0, 0.05], link=None),
}


@cache
def run(name: str, stops: int = 14, move_time: float = 0.7, dwell: float = 0.5,
        seed: int = 0, dt: float = 2e-4, every: int = 1, bandwidth: float = 80.0,
        dither: float = 0.0):
    """Simulate ``name`` carrying its payload through random waypoints with dwells.

    Returns a dict: robot (unloaded), t, q, qd, tau, current (noisy), traj, setup,
    payload (the simulator's payload dict, com in the body frame).
    """
    robot = load(name)
    s = SETUPS[name]
    rng = np.random.default_rng(seed)
    pts = np.asarray(s["center"]) + rng.uniform(-1, 1, (stops, robot.n)) * np.asarray(s["spread"])
    pts[0] = s["center"]
    traj = (waypoints(pts, move_time=move_time, dwell=dwell, profile="quintic")
            if not dither else waypoints(pts, move_time=move_time, dwell=dwell,
                                         profile="quintic", dither=dither,
                                         dither_frequency=5.0))
    if s["link"] is None:
        body, c_body = robot.n - 1, np.asarray(s["com"], float)
    else:
        from manipcad.dynamics.identification import link_frame

        body, R, p, _ = link_frame(robot, s["link"])
        assert body == robot.n - 1
        c_body = R @ np.asarray(s["com"], float) + p
    payload = {"mass": s["mass"], "com": c_body.tolist()}
    loaded = robot.with_payload(s["mass"], c_body)
    # the bandwidth asked, or the lowest that keeps the drive's damping where that is higher
    regs = [synthesize(loaded, j, "pid", period=1e-3,
                       spec={"bandwidth": max(bandwidth, damping_floor(
                           nominal_drive(loaded, j)[5], 1.0))})
            for j in range(robot.n)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        res = simulate(robot, t_end=traj.duration, dt=dt, trajectory=traj, regulators=regs,
                       payload=payload, every=every)
    noise = np.random.default_rng(seed + 1)
    tau = res.tau + noise.normal(size=res.tau.shape) * NOISE * np.sqrt(np.mean(res.tau**2, 0))
    cur = res.current + noise.normal(size=res.current.shape) * NOISE * np.sqrt(
        np.mean(res.current**2, 0))
    return {"robot": robot, "t": res.t, "q": res.q, "qd": res.qd, "tau": tau, "current": cur,
            "traj": traj, "setup": s, "payload": payload, "result": res}
