"""Export to Pinocchio: the functions live in :mod:`manipcad.model.to_pinocchio`
(``Robot.to_pinocchio()``); kept here for the existing imports."""

from manipcad.model.to_pinocchio import depth_first_order, to_pinocchio

__all__ = ["to_pinocchio", "depth_first_order"]
