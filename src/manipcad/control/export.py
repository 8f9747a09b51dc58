"""Regulators as python-control systems (:func:`to_control`).

Every regulator exports as a discrete-time nonlinear I/O system running the very
compiled law the simulator runs (:func:`~manipcad.control.systems.nonlinear_system`);
a method whose law is linear time-invariant gives a state-space system instead where
its module says so (its registry entry's ``export``).
"""

from __future__ import annotations

from manipcad.control.registry import method
from manipcad.control.regulator import Regulator
from manipcad.control.systems import nonlinear_system
from manipcad.errors import ManipcadError


def to_control(reg: Regulator):
    """The regulator as a python-control system: inputs the signals it reads (``needs``,
    SI units as in :data:`~manipcad.control.signals.SIGNALS`), output the amplifier
    input U (V), discrete time with period ``reg.period`` (s).

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> sys = to_control(manipcad.synthesize(arm, "turn", "asvs", period=1e-3))
        >>> sys.dt, sys.output_labels
        (0.001, ['U'])
    """
    m = method(reg.method)
    if m.export is not None:
        return m.export(reg)
    if m.spans:
        raise ManipcadError(f"{reg.method}: a regulator spanning joints has no "
                            "python-control export")
    return nonlinear_system(reg, m.update)
