"""Regulators: the synthesis methods of the paper (section 3) and the classical baselines.

One registry (:mod:`manipcad.control.registry`) lists the methods; each is one module
holding its synthesis, its compiled control-period update, its file layout and its
python-control export. ``synthesize(robot, joint, method, spec=..., **options)`` returns a
:class:`Regulator` that :func:`manipcad.simulate` runs, that saves to a file
(:func:`save_regulators`, :func:`load_regulators`), that says its law with numbers
(``describe()``) and the signals it needs (``needs``); its realization complexity is
counted from its code (:func:`realization_complexity`) and it exports to
python-control (:func:`to_control`). Methods (see docs/synthesis.md):

- ``none``: a plain P position loop, no adaptation; ``none_sce``: the SCE of ``ace_de``
  without the corrector (:mod:`.baselines`);
- ``pid`` (:mod:`.pid`), ``computed_torque`` (:mod:`.computed_torque`), and the
  centralized ``computed_torque_full`` over all joints (:mod:`.computed_torque_full`);
- ``ace_tf``: adaptive corrective element (1) + SCE, observable or controllable
  realization (:mod:`.ace_tf`); ``ace_de``: control law (3) + SCE (:mod:`.ace_de`);
- ``asvs`` / ``vss``: variable-structure law (4)-(5), slope adapted to the load or fixed
  for the worst case (:mod:`.asvs`);
- ``lqr`` / ``lqr_gs``: quadratic-criterion gains (6)-(7), fixed at the nominal load or
  scheduled from a gain table (:mod:`.lqr`).
"""

from __future__ import annotations

from manipcad.control.complexity import realization_complexity
from manipcad.control.export import to_control
from manipcad.control.files import load_regulators, save_regulators
from manipcad.control.method import Method
from manipcad.control.pid import pid
from manipcad.control.registry import METHODS, dispatch, kind_of, method
from manipcad.control.regulator import Regulator
from manipcad.control.synthesis import synthesize

__all__ = ["synthesize", "METHODS", "Regulator", "Method", "method", "kind_of", "dispatch",
           "pid", "load_regulators", "save_regulators", "realization_complexity", "to_control"]
