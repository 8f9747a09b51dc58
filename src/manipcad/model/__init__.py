"""The manipulator model: joints, links, drives, payloads, and their loaders."""

from manipcad.model.load import catalog_names, load_robot
from manipcad.model.robot import PRISMATIC, REVOLUTE, Drive, Robot

__all__ = ["Robot", "Drive", "REVOLUTE", "PRISMATIC", "load_robot", "catalog_names"]
