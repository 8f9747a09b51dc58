"""Analyses along trajectories: coupling between the drives (paper section 2) and the
real-time moment components the adaptive regulators read (paper 4.1).

- :func:`coupling_analysis`: per joint, the own inertial, coupling, velocity and
  gravity constituents, the variation of H_ii, what a counterweight or spring
  takes off gravity, and the class decoupled / inertial / full.
- :func:`moment_components`: H_ii, h_i and Q_i of one state or a batch in one
  compiled call.
"""

from manipcad.analysis.coupling import CouplingReport, JointCoupling, coupling_analysis
from manipcad.analysis.realtime import MomentComponents, moment_components

__all__ = ["coupling_analysis", "CouplingReport", "JointCoupling", "moment_components",
           "MomentComponents"]
