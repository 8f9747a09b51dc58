"""manipcad: computer-aided design of high-accuracy control for robot manipulators.

The main names are re-exported here; see the sub-packages for the rest.
"""

from manipcad._blas_threads import configure as _configure_blas_threads

_configure_blas_threads()  # before numpy is imported: see manipcad._blas_threads

from manipcad._numba_cache import configure as _configure_numba_cache

_configure_numba_cache()

from manipcad.analysis import coupling_analysis, moment_components
from manipcad.control import Regulator, load_regulators, save_regulators, synthesize
from manipcad.control.estimator import PayloadEstimator
from manipcad.dynamics import (
    forward_dynamics,
    inverse_dynamics,
    mass_matrix,
    operation_counts,
    torque_components,
)
from manipcad.dynamics.identification import PayloadEstimate, identify_payload
from manipcad.errors import InputError, ManipcadError, ManipcadWarning, ModelError
from manipcad.expert import Requirements, recommend
from manipcad.model import Drive, Robot, catalog_names, load_robot, save_robot
from manipcad.sim import SimulationResult, simulate
from manipcad.sizing import DriveRequirements, ratio_sweep, required_drive, torque_speed_plot
from manipcad.trajectories import load_trajectory, save_trajectory
from manipcad.version import __version__

__all__ = [
    "__version__",
    "Robot", "Drive", "load_robot", "save_robot", "catalog_names",
    "inverse_dynamics", "mass_matrix", "forward_dynamics", "torque_components",
    "operation_counts", "load_trajectory", "save_trajectory",
    "identify_payload", "PayloadEstimate", "PayloadEstimator", "coupling_analysis",
    "moment_components",
    "synthesize", "Regulator", "load_regulators", "save_regulators", "simulate",
    "SimulationResult", "Requirements", "recommend",
    "required_drive", "DriveRequirements", "ratio_sweep", "torque_speed_plot",
    "ManipcadError", "ModelError", "InputError", "ManipcadWarning",
]
