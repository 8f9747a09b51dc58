"""Synthesis of adaptive regulators for manipulator drives (paper section 3).

``synthesize(robot, joint, method, *, spec=None, **options)`` returns a
:class:`SynthesizedRegulator` the closed-loop simulator runs
(:func:`manipcad.sim.simulate`); it says its law with numbers
(``describe()``), the signals it needs (``needs``), its realization complexity
(``realization_complexity()``) and exports its linear parts to python-control
(``linear``). Methods (one module each; see docs/synthesis.md):

- ``none``: a plain proportional position loop, no adaptation (:mod:`.baselines`);
- ``pid``: PID designed on the drive at a nominal load (:mod:`.baselines`);
- ``computed_torque``: decentralized computed torque through the drive model
  (:mod:`.baselines`);
- ``ace_de``: control law (3) after a stationary corrective element (:mod:`.ace_de`);
- ``ace_tf``: adaptive corrective element (1), quasi-stationary, after an SCE (:mod:`.ace_tf`);
- ``asvs`` / ``vss``: variable-structure law (4)-(5), slope adapted to the load
  or fixed for the worst case (:mod:`.asvs`);
- ``lqr`` / ``lqr_gs``: quadratic-criterion gains, fixed at the nominal load or
  scheduled from a gain table (:mod:`.lqr`).
"""

from __future__ import annotations

from manipcad.errors import ManipcadError
from manipcad.synthesis._common import SynthesizedRegulator
from manipcad.synthesis.ace_de import synthesize_ace_de
from manipcad.synthesis.ace_tf import synthesize_ace_tf
from manipcad.synthesis.asvs import synthesize_asvs, synthesize_vss
from manipcad.synthesis.baselines import (
    synthesize_computed_torque,
    synthesize_none,
    synthesize_pid,
)
from manipcad.synthesis.lqr import synthesize_lqr, synthesize_lqr_gs

METHODS = {
    "none": synthesize_none,
    "pid": synthesize_pid,
    "ace_de": synthesize_ace_de,
    "ace_tf": synthesize_ace_tf,
    "asvs": synthesize_asvs,
    "vss": synthesize_vss,
    "lqr": synthesize_lqr,
    "lqr_gs": synthesize_lqr_gs,
    "computed_torque": synthesize_computed_torque,
}


def synthesize(robot, joint, method: str, *, spec=None, **options) -> SynthesizedRegulator:
    """Synthesize a regulator for one joint's drive.

    Args:
        robot: a :class:`~manipcad.model.robot.Robot` with drives.
        joint: joint index or name.
        method: one of :data:`METHODS`.
        spec: the closed-loop spec of the method (see each method; e.g.
            ``{"bandwidth": 30.0, "damping": 1.0}`` rad/s and ζ).
        **options: method options (``period`` s, ``load_range`` (H_min, H_max)
            kg·m², ``order`` 2|3, ...).

    Returns:
        :class:`SynthesizedRegulator`.

    Raises:
        ManipcadError: unknown method or option, missing drive parameters,
            an unreachable spec.

    Example:
        >>> import manipcad
        >>> from manipcad.synthesis import synthesize
        >>> reg = synthesize(manipcad.load_robot("cylindrical"), "turn", "none")
        >>> reg.needs
        ('q', 'q_ref')
    """
    try:
        fn = METHODS[method]
    except (KeyError, TypeError):
        raise ManipcadError(f"unknown synthesis method {method!r}; known: "
                            f"{', '.join(METHODS)}") from None
    if "load_range" in options:
        options["load_range_"] = options.pop("load_range")
    try:
        return fn(robot, joint, spec=spec, **options)
    except TypeError as exc:
        if "unexpected keyword" in str(exc):
            raise ManipcadError(f"{method}: {exc}") from None
        raise


__all__ = ["synthesize", "METHODS", "SynthesizedRegulator"]
