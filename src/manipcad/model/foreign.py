"""``load_robot`` for what is not a manipcad file: other libraries' objects and XML text.

- a Robotics Toolbox ``DHRobot``/``ERobot`` (:mod:`manipcad.model.from_rtb`),
- a Pinocchio ``Model`` (:mod:`manipcad.model.from_pinocchio`),
- a ``mujoco.MjModel`` and MJCF files or text (:mod:`manipcad.model.mjcf`),
- URDF text (:func:`manipcad.model.urdf.robot_from_urdf_string`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from manipcad.errors import InputError
from manipcad.model.from_pinocchio import robot_from_pinocchio
from manipcad.model.from_rtb import robot_from_rtb
from manipcad.model.mjcf import load_mjcf, robot_from_mjcf_string, robot_from_mujoco
from manipcad.model.robot import Robot
from manipcad.model.urdf import load_urdf, robot_from_urdf_string


def robot_from_object(obj: Any) -> Robot:
    """A robot from another library's model object (see the module docstring).

    Raises:
        InputError: an object of no supported type (its type named).

    Example:
        >>> robot_from_object(3.0)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: load_robot: got a float; expected a catalog name, ...
    """
    module = type(obj).__module__.split(".")[0]
    kind = type(obj).__name__
    if module == "roboticstoolbox" or hasattr(obj, "rne") and hasattr(obj, "links"):

        return robot_from_rtb(obj)
    if module == "pinocchio" and kind == "Model" or hasattr(obj, "jointPlacements"):

        return robot_from_pinocchio(obj)
    if module == "mujoco" and kind == "MjModel":

        return robot_from_mujoco(obj)
    raise InputError("load_robot", "", f"got a {kind}; expected a catalog name, a file, "
                     "URDF/MJCF text, a roboticstoolbox robot, a pinocchio.Model or a "
                     "mujoco.MjModel")


def robot_from_xml_text(text: str | bytes) -> Robot:
    """A robot from URDF (``<robot>``) or MJCF (``<mujoco>``) text."""
    head = text[:4096].decode("utf-8", "replace") if isinstance(text, bytes) else text[:4096]
    if "<mujoco" in head:

        return robot_from_mjcf_string(text.decode() if isinstance(text, bytes) else text)

    return robot_from_urdf_string(text)


def load_xml_robot(path: Path) -> Robot:
    """An .xml/.mjcf file: MJCF (``<mujoco>``) through MuJoCo, URDF (``<robot>``) otherwise."""
    head = path.read_bytes()[:4096].decode("utf-8", "replace")
    if "<mujoco" in head:

        return load_mjcf(path)
    if "<robot" in head:

        return load_urdf(path)
    raise InputError(str(path), "", "an XML file that is neither MJCF (<mujoco>) nor URDF "
                     "(<robot>)")
