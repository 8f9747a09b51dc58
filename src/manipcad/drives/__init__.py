"""DC servo drives: amplifier, armature, motor, gear, elastic transmission (paper 3.1).

Modules:

- :mod:`~manipcad.drives.params`: the packed parameter vector the compiled
  kernels read, drive kinds and state orders, :class:`Transmission`.
- :mod:`~manipcad.drives.dc`: amplifier limit, armature circuit, dry friction,
  rigid-gear drive (compiled kernels).
- :mod:`~manipcad.drives.transmission`: elasticity and backlash (compiled).
- :mod:`~manipcad.drives.coupling`: all drives of a robot in one compiled call
  for the closed-loop simulator.
- :mod:`~manipcad.drives.linear`: T_m, k_p, T_e, the L-check, and the linear
  models as python-control objects.
- :mod:`~manipcad.drives.laws`: law (3), ACE (1), ASVS (4)-(5) kernels.
- :mod:`~manipcad.drives.model`: :class:`DriveModel`, one drive with a frozen load.

The equations and derivations are in docs/drive-equations.md.
"""

from manipcad.drives.linear import (
    DriveLinearization,
    drive_gain,
    electrical_time_constant,
    inductance_ratio,
    linearize,
    mechanical_time_constant,
    referred_load,
)
from manipcad.drives.model import DriveModel, DriveResponse
from manipcad.drives.params import Transmission, pack_drive, pack_drives, state_offsets

__all__ = [
    "DriveModel", "DriveResponse", "DriveLinearization", "Transmission",
    "linearize", "mechanical_time_constant", "drive_gain", "electrical_time_constant",
    "inductance_ratio", "referred_load", "pack_drive", "pack_drives", "state_offsets",
]
