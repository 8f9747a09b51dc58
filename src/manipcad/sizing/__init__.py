"""Drive sizing: the torques, speeds, currents, voltages and powers a motion needs.

- :func:`required_drive` (:mod:`.requirements`): per joint, joint- and
  motor-side peak and RMS torque, peak speed, peak and RMS current, peak
  voltage, peak and mean mechanical and electrical power, and the check of
  every motor against its continuous and peak torque, speed and voltage
  limits with margins (:mod:`.limits`);
- :func:`ratio_sweep` (:mod:`.sweep`): a joint's feasible gear-ratio range
  and best ratio for its motor;
- :func:`torque_speed_plot` (:mod:`.plot`): required motor torque vs speed
  against each motor's envelope.

:mod:`.motion` samples the trajectory and runs the inverse dynamics,
:mod:`.motor` refers it to the motor, :mod:`.stats` holds peak/RMS/mean.
Equations and conventions: docs/sizing.md.

Example:
    >>> import manipcad
    >>> from manipcad import sizing
    >>> from manipcad.trajectories import cosine
    >>> move = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], 1.6)
    >>> sizing.required_drive(manipcad.load_robot("cylindrical"), move).peak_motor_torque.shape
    (3,)
"""

from manipcad.sizing.limits import LIMITS, LimitCheck
from manipcad.sizing.plot import torque_speed_plot
from manipcad.sizing.requirements import DriveRequirements, required_drive
from manipcad.sizing.sweep import RatioSweep, ratio_sweep

__all__ = ["required_drive", "DriveRequirements", "LimitCheck", "LIMITS",
           "ratio_sweep", "RatioSweep", "torque_speed_plot"]
