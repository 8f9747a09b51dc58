"""Closed-loop simulation: multibody dynamics + DC drives + sampled regulators (paper 5).

The simulator runs any :class:`manipcad.control.Regulator` through the regulator
registry's compiled dispatch; it names no method.
"""

from manipcad.sim.metrics import step_metrics
from manipcad.sim.simulate import (
    JointLimitExceeded,
    SimulationDiverged,
    SimulationResult,
    simulate,
)

__all__ = ["simulate", "SimulationResult", "SimulationDiverged", "JointLimitExceeded",
           "step_metrics"]
