"""Rigid-body dynamics of the manipulator (paper section 4), compiled with numba.

One algorithm per module: :mod:`.rnea` (inverse, 4.1), :mod:`.crba` (mass
matrix, 4.2 method 1), :mod:`.aba` (O(n) forward, 4.2 method 2),
:mod:`.forward_crba` (mass matrix + Cholesky), :mod:`.components` (the split
P_i = H_ii q̈_i + h_i + Q_i + M_i), :mod:`.counts` (operation counts).
"""

from manipcad.dynamics.api import forward_dynamics, inverse_dynamics, mass_matrix
from manipcad.dynamics.components import TorqueComponents, torque_components
from manipcad.dynamics.counts import operation_counts

__all__ = ["inverse_dynamics", "mass_matrix", "forward_dynamics", "torque_components",
           "TorqueComponents", "operation_counts"]
