"""The PUMA 560 job the simulator benchmarks share: the catalog PUMA 560 with its six DC
drives, PD + back-EMF feed-forward on every joint (the gains of examples/pid_puma.yaml,
V/rad and V·s/rad, the integral left out; ±40 V), a quintic move from ``Q_START`` to
``Q_END`` (rad), sampled every ``DT`` (s).

Imported by bench_simulator.py, _bench_integrators.py, bench_codegen.py, rk4_job.py and
bench_friction.py, run from this folder.
"""

from __future__ import annotations

import warnings

import numpy as np

import manipcad
from manipcad.control import pid
from manipcad.errors import ManipcadWarning

DT = 1e-4
KP = np.array([-930.0, 950.0, -580.0, 320.0, 340.0, 320.0])
KD = np.array([-27.0, 9.0, -4.5, 8.3, 9.5, 8.3])
KFF = np.array([-14.28, 24.58, -12.25, 5.70, 5.39, 5.75])
U_LIMIT = 40.0
Q_START = np.array([0.0, 0.5, -0.5, 0.0, 0.3, 0.0])
Q_END = np.array([0.8, 0.2, -0.1, 0.5, -0.3, 1.0])


def load_puma() -> manipcad.Robot:
    """The catalog PUMA 560 (its load-time warnings silenced)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot("puma560")


def pd_regulators(period: float = DT) -> list:
    """The PD + feed-forward regulators of every joint, sampled every ``period`` s."""
    return [pid(j, kp=KP[j], kd=KD[j], kff=KFF[j], u_limit=U_LIMIT, period=period)
            for j in range(len(KP))]
