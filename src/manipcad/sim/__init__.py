"""Closed-loop simulation: multibody dynamics + DC drives + sampled regulators (paper 5)."""

from manipcad.control.pid import pid
from manipcad.control.regulator import Regulator
from manipcad.sim.metrics import step_metrics
from manipcad.sim.simulate import SimulationDiverged, SimulationResult, simulate

__all__ = ["simulate", "SimulationResult", "SimulationDiverged", "Regulator", "pid",
           "step_metrics"]
