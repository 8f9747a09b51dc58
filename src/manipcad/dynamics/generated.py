"""Which robots have customized kernels to use: the registry :func:`manipcad.codegen.generate`
fills and the dynamics functions read.

``generate(robot)`` (with ``attach=True``) calls :func:`attach`; from then on
:func:`manipcad.inverse_dynamics`, :func:`manipcad.mass_matrix` and
:func:`manipcad.forward_dynamics` of that robot object (``use_generated=True``) call its
generated kernels. The registry is keyed by the robot object's identity
(:class:`manipcad.objcache.PerObject`): a changed copy (``robot.with_payload(...)``,
``robot.replace(...)``) or a pickled one is another object and has none until generated
for; an entry goes with its robot.
"""

from __future__ import annotations

from typing import Any

from manipcad.objcache import PerObject

_ATTACHED = PerObject()


def attach(robot, kernels: Any) -> None:
    """Let the dynamics functions use ``kernels`` (a
    :class:`~manipcad.codegen.GeneratedDynamics`) for this robot object.

    Example:
        >>> import manipcad
        >>> from manipcad.codegen import generate
        >>> arm = manipcad.load_robot("cylindrical")
        >>> attached(arm) is None
        True
        >>> gen = generate(arm)          # attaches
        >>> attached(arm) is gen, attached(arm.with_payload(1.0)) is None
        (True, True)
    """
    _ATTACHED.set(robot, kernels)


def attached(robot) -> Any:
    """The kernels attached to this robot object, or None."""
    return _ATTACHED.get(robot)


__all__ = ["attach", "attached"]
