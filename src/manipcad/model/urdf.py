"""URDF loader: a URDF file mapped onto the internal kinematic tree.

Only the standard library's XML parser is used. What is read:

- ``<robot name>``: the robot's name (the file's stem if absent).
- ``<link>``: its ``<inertial>`` (``<origin xyz rpy>``, ``<mass value>``,
  ``<inertia ixx ixy ixz iyy iyz izz>``; SI units: m, rad, kg, kg·m²). The
  inertia is about the centre of mass, in the axes of the inertial origin frame.
  A link without ``<inertial>`` is massless. Visual and collision data are
  ignored.
- ``<joint>`` of type revolute, continuous, prismatic or fixed: ``<parent
  link>``, ``<child link>``, ``<origin xyz rpy>`` (default identity),
  ``<axis xyz>`` (default (1, 0, 0), normalised), ``<limit lower upper>``
  (rad or m) and ``<limit velocity effort>`` (rad/s or m/s; N·m or N: the
  robot's :attr:`~manipcad.model.robot.Robot.velocity_limits` and
  :attr:`~manipcad.model.robot.Robot.effort_limits`, which the run checks and
  the sizing enforce; a value of 0 or none given means no limit, as 0 is the
  placeholder exporters write). Continuous joints are revolute joints without
  position limits (±inf); a
  missing ``lower`` or ``upper`` attribute means no limit on that side (the URDF
  specification's default of 0 would freeze the joint). ``<mimic>`` is read
  as an independent joint, as Pinocchio does by default, with a loud
  :class:`~manipcad.errors.ManipcadWarning` naming both joints (the coupling is
  not modelled; lock the joint to remove it); ``<dynamics>``,
  ``<calibration>`` and ``<safety_controller>`` are ignored, so the robot has
  no drives. Floating and planar joints are not supported.

URDF's rpy is a fixed-axis roll-pitch-yaw: ``R = Rz(yaw)·Ry(pitch)·Rx(roll)``.

Mapping onto :class:`~manipcad.model.robot.Robot` (joint motion about local z):

- A movable joint with unit axis ``a`` gets the placement
  ``T_origin · R_align``, where ``R_align`` is the smallest rotation taking z
  onto ``a`` (see :func:`align_z`: identity for ``a = z``, a half turn about x
  for ``a = -z``). The
  link's body frame is that frame after the motion; the URDF child link frame
  is the body frame rotated back by ``R_alignᵀ``, so the child link's centre of
  mass and inertia are carried into the body frame by ``R_alignᵀ``. As
  ``Rot(a, q) = R_align·Rot_z(q)·R_alignᵀ`` (and likewise for a translation),
  the motion is exactly the URDF's.
- A fixed joint merges its child link into the body of its parent link
  (masses, centres and inertias combined with
  :func:`~manipcad.model.robot.combine_bodies`); joints further out are placed
  through the fixed transform. Links fixed to the root link form the base,
  whose mass does not matter for a fixed base and is dropped.
- Joint order is the URDF's order of movable joints, except that a parent must
  precede its children: if the file lists a child joint before the joint that
  carries it, the joints are sorted topologically, each time taking the
  earliest joint in file order whose parent is already placed. A file that
  lists parents first keeps its order exactly.
- ``link_names`` are the child links of the movable joints; the tool frame is
  the identity on the last link. ``Robot.frames`` keeps every URDF link's own
  frame in the body that carries it (:meth:`Robot.link_frame`), so a centre of
  mass or a tool given in a URDF link frame can be placed exactly.
- ``lock`` (joint name -> value) turns movable joints into fixed joints at
  that value before the tree is built (a gripper's fingers, a joint held by a
  brake); the value must lie within the joint's limits.

An inertia that is positive semi-definite but breaks the triangle inequality
(no rigid body has it) loads with a :class:`~manipcad.errors.ManipcadWarning`.

No entity is expanded: a file declaring an XML entity (the 'billion laughs' bomb, an
external entity naming another file) is refused (:func:`manipcad.fileio.scan_xml`).

Every error in the file (malformed XML, a missing or duplicated element, a bad
number, an unknown or unsupported joint type, a joint naming a link that does
not exist, several root links, a link with two parents, a cycle) raises
:class:`~manipcad.errors.InputError` naming the file, the element (for
example ``joint 'elbow'.axis``) and the reason.
"""

from __future__ import annotations

import heapq
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from manipcad.errors import InertiaWarning, InputError, ManipcadWarning, ModelError
from manipcad.fileio import read_bytes, scan_xml
from manipcad.model.robot import (
    PRISMATIC,
    REVOLUTE,
    Robot,
    combine_bodies,
    triangle_breach,
    triangle_message,
)

MOVABLE = {"revolute": REVOLUTE, "continuous": REVOLUTE, "prismatic": PRISMATIC}
SUPPORTED_TYPES = ("revolute", "continuous", "prismatic", "fixed")
UNSUPPORTED_TYPES = ("floating", "planar")


def load_urdf(path: str | Path, lock: dict[str, float] | None = None) -> Robot:
    """Load a fixed-base robot from a URDF file.

    Args:
        path: the URDF file.
        lock: joint name -> fixed value (rad or m): these movable joints become
            fixed joints at that value (e.g. a gripper's fingers), so the robot
            has fewer joints. Default none.

    Returns:
        The validated :class:`Robot` (SI units; no drives; gravity (0, 0, -9.81) m/s²).

    Raises:
        InputError: naming the file, the element and the reason (see the module
            docstring for what is checked).

    Warns:
        ManipcadWarning: as :func:`~manipcad.model.yaml_robot.load_yaml_robot`.

    Example:
        >>> from manipcad.model.urdf import load_urdf
        >>> robot = load_urdf("ur5_robot.urdf")  # doctest: +SKIP
        >>> robot.n  # doctest: +SKIP
        6
    """
    path = Path(path)
    source = str(path)
    text = read_bytes(path, source)
    return _build(_parse_xml(text, source), source, default_name=path.stem, lock=lock)


def robot_from_urdf_string(text: str | bytes, source: str = "<string>",
                           lock: dict[str, float] | None = None) -> Robot:
    """Load a robot from URDF text (see :func:`load_urdf`).

    Args:
        text: the URDF document.
        source: the name used in error messages and stored as ``Robot.source``.
        lock: joint name -> fixed value, rad or m (see :func:`load_urdf`).
    """
    return _build(_parse_xml(text, source), source, default_name="robot", lock=lock)


def _warn_mimic(source: str, joint: str, mimic: ET.Element) -> None:
    """Warn that a ``<mimic>`` joint is loaded as an independent joint (no coupling)."""
    leader = mimic.get("joint", "?")
    factor, offset = mimic.get("multiplier", "1"), mimic.get("offset", "0")
    warnings.warn(
        f"{source}: joint {joint!r} mimics {leader!r} (q = {factor}·q_{leader} + {offset}) "
        "but manipcad loads it as an INDEPENDENT joint: the coupling is not modelled, so "
        "torques, dynamics and simulations treat it as a free degree of freedom; lock it "
        f"(load_urdf(..., lock={{{joint!r}: value}})) or drive it to follow {leader!r}",
        ManipcadWarning, stacklevel=4)


def _locked_origin(j: _Joint, value: float) -> tuple[np.ndarray, np.ndarray]:
    """The fixed transform of a movable joint held at ``value`` (rad or m):
    its origin followed by the motion about (or along) its axis."""
    if MOVABLE[j.kind] == REVOLUTE:
        a = j.axis
        K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
        Rm = np.eye(3) + np.sin(value) * K + (1.0 - np.cos(value)) * (K @ K)
        return j.R @ Rm, j.p.copy()
    return j.R.copy(), j.p + j.R @ (j.axis * value)


# ---------------------------------------------------------------- parsing


@dataclass
class _Joint:
    name: str
    kind: str  # URDF type
    parent: str  # parent link name
    child: str  # child link name
    R: np.ndarray  # origin rotation (parent link <- joint)
    p: np.ndarray  # origin translation in the parent link frame, m
    axis: np.ndarray  # unit axis in the joint frame
    limits: tuple[float, float]
    index: int  # position in the file
    velocity: float = np.inf  # |q̇| limit, rad/s or m/s (inf: none)
    effort: float = np.inf  # |P| limit, N·m or N (inf: none)


@dataclass
class _Inertial:
    mass: float  # kg
    com: np.ndarray  # in the link frame, m
    inertia: np.ndarray  # about the centre of mass, link axes, kg·m²


def _parse_xml(text: str | bytes, source: str) -> ET.Element:
    scan_xml(text, source)       # no entity declarations: ElementTree would expand them
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InputError(source, "", f"malformed XML: {exc}") from None
    if root.tag != "robot":
        raise InputError(source, "", f"root element is <{root.tag}>, expected <robot>")
    return root


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF rotation of fixed-axis roll, pitch, yaw (rad): Rz(yaw)·Ry(pitch)·Rx(roll)."""
    cr, sr = np.cos(rpy[0]), np.sin(rpy[0])
    cp, sp = np.cos(rpy[1]), np.sin(rpy[1])
    cy, sy = np.cos(rpy[2]), np.sin(rpy[2])
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def align_z(axis: np.ndarray) -> np.ndarray:
    """A rotation taking the z axis onto the unit vector ``axis``.

    For an axis with ``axis_z >= 0`` it is the smallest such rotation (the
    identity for +z); otherwise it is a half turn about x followed by the
    smallest rotation onto the mirrored axis (exactly the half turn about x
    for -z), which keeps the formula well conditioned near -z.
    """
    a = np.asarray(axis, dtype=float)
    if a[2] < 0.0:
        flip = np.diag([1.0, -1.0, -1.0])  # half turn about x, its own inverse
        return flip @ align_z(flip @ a)
    c = a[2]  # cos of the angle between z and a, >= 0 here
    k = np.array([-a[1], a[0], 0.0])  # z × a, |k| = sin
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + K + K @ K / (1.0 + c)


def _floats(text: str | None, count: int, source: str, field: str,
            default: tuple[float, ...] | None = None) -> np.ndarray:
    """Parse ``count`` whitespace-separated finite numbers from an attribute."""
    if text is None:
        if default is None:
            raise InputError(source, field, "missing")
        return np.array(default, dtype=float)
    parts = text.split()
    if len(parts) != count:
        raise InputError(source, field, f"expected {count} number{'s' * (count > 1)}, "
                         f"got {text!r}")
    try:
        values = np.array([float(s) for s in parts])
    except ValueError:
        raise InputError(source, field, f"not a number: {text!r}") from None
    if not np.all(np.isfinite(values)):
        raise InputError(source, field, f"must be finite, got {text!r}")
    return values


def _limit(text: str | None, source: str, field: str, default: float) -> float:
    if text is None:
        return default
    try:
        value = float(text)
    except ValueError:
        raise InputError(source, field, f"not a number: {text!r}") from None
    if np.isnan(value):
        raise InputError(source, field, "not a number: 'nan'")
    return value


def _origin(elem: ET.Element, source: str, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(R, p) of an optional ``<origin>`` child (identity if absent)."""
    origin = elem.find("origin")
    if origin is None:
        return np.eye(3), np.zeros(3)
    xyz = _floats(origin.get("xyz"), 3, source, f"{where}.origin.xyz", (0.0, 0.0, 0.0))
    rpy = _floats(origin.get("rpy"), 3, source, f"{where}.origin.rpy", (0.0, 0.0, 0.0))
    return rpy_matrix(rpy), xyz


def _name(elem: ET.Element, source: str, what: str, index: int) -> str:
    name = elem.get("name")
    if name is None or not name.strip():
        raise InputError(source, f"{what} #{index + 1}", "has no name attribute")
    return name


def _read_inertial(link: ET.Element, name: str, source: str) -> _Inertial:
    where = f"link {name!r}.inertial"
    inertial = link.find("inertial")
    if inertial is None:
        return _Inertial(0.0, np.zeros(3), np.zeros((3, 3)))
    R, p = _origin(inertial, source, where)
    mass_el = inertial.find("mass")
    if mass_el is None:
        raise InputError(source, f"{where}.mass", "missing (an <inertial> needs a <mass>)")
    mass = float(_floats(mass_el.get("value"), 1, source, f"{where}.mass.value")[0])
    if mass < 0:
        raise InputError(source, f"{where}.mass.value", f"must be >= 0 kg, got {mass}")
    in_el = inertial.find("inertia")
    if in_el is None:
        raise InputError(source, f"{where}.inertia", "missing (an <inertial> needs an <inertia>)")
    v = {}
    for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
        v[key] = float(_floats(in_el.get(key), 1, source, f"{where}.inertia.{key}")[0])
    I_local = np.array([[v["ixx"], v["ixy"], v["ixz"]],
                        [v["ixy"], v["iyy"], v["iyz"]],
                        [v["ixz"], v["iyz"], v["izz"]]])
    eig = np.linalg.eigvalsh(I_local)
    tol = 1e-12 * max(1.0, float(np.abs(I_local).max()))
    if eig[0] < -tol:
        raise InputError(source, f"{where}.inertia", "tensor is not positive semi-definite "
                         f"(eigenvalues {np.array2string(eig, precision=6)} kg·m²)")
    breach = triangle_breach(I_local)
    if breach is not None:
        warnings.warn(f"{source}: {where}.inertia: {triangle_message(breach)}",
                      InertiaWarning, stacklevel=4)
    return _Inertial(mass, p, R @ I_local @ R.T)


def _read_joint(elem: ET.Element, index: int, source: str, links: dict[str, ET.Element]
                ) -> _Joint:
    name = _name(elem, source, "joint", index)
    where = f"joint {name!r}"
    kind = elem.get("type")
    if kind is None:
        raise InputError(source, f"{where}.type", "missing")
    if kind in UNSUPPORTED_TYPES:
        raise InputError(source, f"{where}.type", f"joint type {kind!r} is unsupported "
                         f"(supported: {', '.join(SUPPORTED_TYPES)})")
    if kind not in SUPPORTED_TYPES:
        raise InputError(source, f"{where}.type", f"unknown joint type {kind!r} "
                         f"(supported: {', '.join(SUPPORTED_TYPES)})")
    ends = {}
    for tag in ("parent", "child"):
        el = elem.find(tag)
        if el is None or el.get("link") is None:
            raise InputError(source, f"{where}.{tag}", f"missing <{tag} link=...>")
        link = el.get("link")
        if link not in links:
            raise InputError(source, f"{where}.{tag}", f"link {link!r} does not exist")
        ends[tag] = link
    if ends["parent"] == ends["child"]:
        raise InputError(source, where, f"parent and child are the same link "
                         f"{ends['parent']!r} (a loop)")
    R, p = _origin(elem, source, where)
    axis = np.array([0.0, 0.0, 1.0])
    limits = (-np.inf, np.inf)
    rates = {"velocity": np.inf, "effort": np.inf}
    if kind in MOVABLE:
        axis_el = elem.find("axis")
        raw = None if axis_el is None else axis_el.get("xyz")
        axis = _floats(raw, 3, source, f"{where}.axis", (1.0, 0.0, 0.0))
        norm = float(np.linalg.norm(axis))
        if norm < 1e-12:
            raise InputError(source, f"{where}.axis", f"must be non-zero, got {raw!r}")
        axis = axis / norm
        lim = elem.find("limit")
        if kind != "continuous" and lim is not None:
            lo = _limit(lim.get("lower"), source, f"{where}.limit.lower", -np.inf)
            hi = _limit(lim.get("upper"), source, f"{where}.limit.upper", np.inf)
            if lo > hi:
                raise InputError(source, f"{where}.limit", f"lower {lo} > upper {hi}")
            limits = (lo, hi)
        for key in rates if lim is not None else ():
            v = _limit(lim.get(key), source, f"{where}.limit.{key}", 0.0)
            if v < 0:
                raise InputError(source, f"{where}.limit.{key}", f"must be >= 0, got {v}")
            rates[key] = v if v > 0 else np.inf   # 0: the exporters' placeholder, no limit
    return _Joint(name, kind, ends["parent"], ends["child"], R, p, axis, limits, index,
                  **rates)


# --------------------------------------------------------------- building


def _build(root: ET.Element, source: str, default_name: str,
           lock: dict[str, float] | None = None) -> Robot:
    name = root.get("name") or default_name
    lock = dict(lock or {})

    links: dict[str, ET.Element] = {}
    for i, el in enumerate(root.findall("link")):
        link = _name(el, source, "link", i)
        if link in links:
            raise InputError(source, f"link {link!r}", "defined twice")
        links[link] = el
    if not links:
        raise InputError(source, "", "no <link> elements")

    joints: list[_Joint] = []
    mimics: list[tuple[str, ET.Element]] = []
    seen: set[str] = set()
    parent_joint: dict[str, _Joint] = {}  # child link -> the joint carrying it
    for i, el in enumerate(root.findall("joint")):
        j = _read_joint(el, i, source, links)
        if j.name in seen:
            raise InputError(source, f"joint {j.name!r}", "defined twice")
        seen.add(j.name)
        other = parent_joint.get(j.child)
        if other is not None:
            raise InputError(source, f"joint {j.name!r}.child",
                             f"link {j.child!r} already has the parent joint {other.name!r}; "
                             "a link with two parents closes a loop, which URDF cannot describe")
        parent_joint[j.child] = j
        if j.name in lock:
            if j.kind not in MOVABLE:
                raise InputError(source, f"lock.{j.name}", f"joint {j.name!r} is {j.kind}, "
                                 "not movable; only movable joints can be locked")
            value = float(lock.pop(j.name))
            lo, hi = j.limits
            if not np.isfinite(value) or not lo <= value <= hi:
                raise InputError(source, f"lock.{j.name}", f"must be a finite value within "
                                 f"the joint's limits [{lo:g}, {hi:g}], got {value}")
            j.R, j.p = _locked_origin(j, value)
            j.kind = "fixed"
        mimic = el.find("mimic")
        if mimic is not None and j.kind in MOVABLE:
            mimics.append((j.name, mimic))
        joints.append(j)
    names = {j.name for j in joints}
    for follower, mimic in mimics:
        leader = mimic.get("joint")
        if leader not in names:
            raise InputError(source, f"joint {follower!r}.mimic", f"mimics joint {leader!r}, "
                             "which the file does not have")
        _warn_mimic(source, follower, mimic)

    if lock:
        raise InputError(source, f"lock.{next(iter(lock))}", "no joint of that name; joints "
                         "are " + ", ".join(j.name for j in joints))
    roots = [link for link in links if link not in parent_joint]
    if len(roots) > 1:
        raise InputError(source, "", f"{len(roots)} root links (links no joint carries): "
                         f"{', '.join(repr(r) for r in roots)}; a URDF needs exactly one")
    if not roots:
        raise InputError(source, "", "no root link: every link has a parent joint, so the "
                         "joints form a cycle")

    children: dict[str, list[_Joint]] = {link: [] for link in links}
    for j in joints:
        children[j.parent].append(j)

    # Walk the tree from the root: body of each link and the link frame in it.
    # body -1 is the base; movable joint k (file order among movable ones) is body k.
    link_body: dict[str, int] = {roots[0]: -1}
    link_T: dict[str, tuple[np.ndarray, np.ndarray]] = {roots[0]: (np.eye(3), np.zeros(3))}
    movable = [j for j in joints if j.kind in MOVABLE]
    body_of_joint = {j.name: k for k, j in enumerate(movable)}
    joint_parent_body: dict[str, int] = {}
    placement: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    stack = [roots[0]]
    while stack:
        link = stack.pop()
        body = link_body[link]
        Rl, pl = link_T[link]
        for j in children[link]:
            # frame of the URDF joint origin in the body of the parent link
            Ro, po = Rl @ j.R, Rl @ j.p + pl
            if j.kind in MOVABLE:
                Ra = align_z(j.axis)
                placement[j.name] = (Ro @ Ra, po)
                joint_parent_body[j.name] = body
                link_body[j.child] = body_of_joint[j.name]
                link_T[j.child] = (Ra.T, np.zeros(3))
            else:
                link_body[j.child] = body
                link_T[j.child] = (Ro, po)
            stack.append(j.child)

    unreached = [link for link in links if link not in link_body]
    if unreached:
        raise InputError(source, "", "the joints form a cycle through the links "
                         f"{', '.join(repr(x) for x in unreached)} (not reachable from the "
                         f"root link {roots[0]!r})")

    if not movable:
        raise InputError(source, "", "no movable joint (revolute, continuous or prismatic)")

    # Order: file order of movable joints, parents first (smallest topological order).
    n = len(movable)
    kids: list[list[int]] = [[] for _ in range(n)]
    ready: list[int] = []
    for k, j in enumerate(movable):
        pb = joint_parent_body[j.name]
        if pb < 0:
            ready.append(k)
        else:
            kids[pb].append(k)
    heapq.heapify(ready)
    order: list[int] = []
    while ready:
        k = heapq.heappop(ready)
        order.append(k)
        for c in kids[k]:
            heapq.heappush(ready, c)
    new_index = {k: i for i, k in enumerate(order)}

    # Link inertias, each carried into its body frame and merged.
    mass = np.zeros(n)
    com = np.zeros((n, 3))
    inertia = np.zeros((n, 3, 3))
    for link, el in links.items():
        body = link_body[link]
        if body < 0:
            continue  # the base: its mass does not matter for a fixed base
        ine = _read_inertial(el, link, source)
        Rl, pl = link_T[link]
        c_b = Rl @ ine.com + pl
        I_b = Rl @ ine.inertia @ Rl.T
        i = new_index[body]
        m, c, I = combine_bodies(mass[i], com[i], inertia[i], ine.mass, c_b, I_b)
        mass[i], com[i], inertia[i] = m, c, 0.5 * (I + I.T)

    ordered = [movable[k] for k in order]
    parent = [-1 if joint_parent_body[j.name] < 0 else new_index[joint_parent_body[j.name]]
              for j in ordered]
    try:
        return Robot.from_arrays(
            name=name,
            joint_types=[MOVABLE[j.kind] for j in ordered],
            parent=parent,
            placement_R=np.array([placement[j.name][0] for j in ordered]).reshape(n, 3, 3),
            placement_p=np.array([placement[j.name][1] for j in ordered]).reshape(n, 3),
            mass=mass,
            com=com,
            inertia=inertia,
            joint_names=[j.name for j in ordered],
            limits=np.array([j.limits for j in ordered]).reshape(n, 2),
            velocity_limits=[j.velocity for j in ordered],
            effort_limits=[j.effort for j in ordered],
            link_names=[j.child for j in ordered],
            source=source,
            frames=[(link, -1 if link_body[link] < 0 else new_index[link_body[link]],
                     link_T[link][0], link_T[link][1]) for link in links],
        )
    except ModelError as exc:
        raise InputError(source, "", str(exc)) from None
