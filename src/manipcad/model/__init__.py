"""The manipulator model: joints, links, drives, payloads, and their loaders."""

from manipcad.model.load import catalog_names, load_robot
from manipcad.model.robot import PRISMATIC, REVOLUTE, Drive, Robot
from manipcad.model.to_urdf import robot_to_urdf
from manipcad.model.tree_file import save_robot

__all__ = ["Robot", "Drive", "REVOLUTE", "PRISMATIC", "load_robot", "catalog_names",
           "save_robot", "robot_to_urdf"]
