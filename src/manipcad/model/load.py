"""``load_robot``: one entry for catalog names, robot files (DH, URDF + drives, tree), URDFs."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from manipcad.catalog.files import part_names
from manipcad.errors import InputError
from manipcad.fileio import check_readable, read_bytes, read_yaml, scan_xml
from manipcad.model.robot import Robot
from manipcad.model.tree_file import is_tree_file, load_tree_robot
from manipcad.model.yaml_robot import load_yaml_robot

CATALOG = resources.files("manipcad.model") / "catalog"


def catalog_names(kind: str = "robots") -> list[str]:
    """Names of the built-in catalog entries of a kind: "robots", "motors" or "gears"
    (the motors and gears of the built-in part files; ``manipcad catalog list`` shows
    the whole parts library)."""
    if kind in ("motors", "gears"):
        return part_names(kind)
    folder = CATALOG / kind
    return sorted(p.name.rsplit(".", 1)[0] for p in folder.iterdir()
                  if p.name.endswith((".yaml", ".urdf")))


def load_robot(source: str | Path | Robot) -> Robot:
    """Load a robot from a built-in catalog name, a YAML file or a URDF file.

    Args:
        source: a catalog name (see ``manipcad robots list``), a path ending in
            .urdf, or a .yaml/.yml robot file of any of the three forms of
            docs/robot-files.md: a DH table (``joints:`` with ``dh:``), a URDF
            with drives (``urdf:``), or the tree form :func:`save_robot` writes
            (``convention: tree``); an MJCF file (.xml/.mjcf, MuJoCo's parser);
            URDF or MJCF text; a Robotics Toolbox ``DHRobot``/``ERobot``, a
            Pinocchio ``Model`` or a ``mujoco.MjModel`` (:mod:`manipcad.model.foreign`);
            or a :class:`Robot` (returned as it is).

    Returns:
        The validated :class:`Robot`.

    Raises:
        InputError: naming the file, the field and the reason.

    Example:
        >>> import manipcad
        >>> manipcad.load_robot("puma560").n
        6
    """
    if isinstance(source, Robot):
        return source
    if not isinstance(source, str | Path | bytes):
        # deferred: start-up cost: keeps manipcad.model.foreign out of import manipcad
        from manipcad.model.foreign import robot_from_object

        return robot_from_object(source)
    if isinstance(source, bytes) or isinstance(source, str) and source.lstrip().startswith("<"):
        # deferred: start-up cost: keeps manipcad.model.foreign out of import manipcad
        from manipcad.model.foreign import robot_from_xml_text

        return robot_from_xml_text(source)
    text = str(source)
    if not text.strip():
        check_readable(text)  # "empty file name"
    path = Path(text)
    if path.suffix.lower() in (".yaml", ".yml", ".urdf", ".xml", ".mjcf") or path.exists():
        check_readable(text)
        return _load_path(path)
    for ext in (".yaml", ".urdf"):
        entry = CATALOG / "robots" / f"{text}{ext}"
        if entry.is_file():
            with resources.as_file(entry) as p:
                return _load_path(Path(p))
    raise InputError(text, "", "not a file and not a catalog robot; catalog robots: "
                     + ", ".join(catalog_names()))


def _load_path(path: Path) -> Robot:
    if path.suffix.lower() == ".urdf":
        # deferred: start-up cost: keeps manipcad.model.urdf out of import manipcad
        from manipcad.model.urdf import load_urdf

        return load_urdf(path)
    if path.suffix.lower() in (".xml", ".mjcf"):
        # deferred: start-up cost: keeps manipcad.model.foreign out of import manipcad
        from manipcad.model.foreign import load_xml_robot

        return load_xml_robot(path)
    # deferred: start-up cost: keeps manipcad.model.urdf_drives out of import manipcad
    from manipcad.model.urdf_drives import is_urdf_robot_file, load_urdf_robot

    data = read_yaml(path) if path.is_file() else None
    if is_urdf_robot_file(data):
        return load_urdf_robot(path)
    if is_tree_file(data):
        return load_tree_robot(path)
    return load_yaml_robot(path)


#: MJCF elements that read other files whatever their attributes
_MJCF_FILE_ELEMENTS = ("include",)


def referenced_files(path: str | Path) -> list[tuple[str, str]]:
    """The other files a robot file makes its loader read, as (field, reference) pairs.

    A robot YAML file: its ``urdf:`` (URDF + drives) and the motors and gears it gives
    as .yaml paths (``joints[2].drive.motor``; catalog names are not files). An MJCF
    file: its ``<include>`` elements and every ``file*`` attribute (meshes, textures,
    height fields, skins, models), which MuJoCo reads from wherever they point. A URDF
    names none that manipcad reads (meshes are not read). A file that must stand alone
    (an upload in ``manipcad ui``) is one for which this is empty.

    Args:
        path: the robot file (.yaml/.yml, .xml/.mjcf, .urdf).

    Returns:
        ``[(field, reference), ...]`` in file order; ``[]`` for a self-contained file.

    Raises:
        InputError: the file cannot be read or parsed (YAML; XML with an entity
            declaration or not well-formed).

    Example:
        >>> import pathlib, tempfile
        >>> p = pathlib.Path(tempfile.mkdtemp()) / "arm.yaml"
        >>> _ = p.write_text("name: arm\\nurdf: /elsewhere/arm.urdf\\ndrives: {}\\n")
        >>> referenced_files(p)
        [('urdf', '/elsewhere/arm.urdf')]
    """
    path = Path(path)
    suffix = path.suffix.lower()
    found: list[tuple[str, str]] = []
    if suffix in (".yaml", ".yml"):
        def walk(node, where: str) -> None:
            if isinstance(node, dict):
                for key, value in node.items():
                    field = f"{where}.{key}" if where else str(key)
                    if key == "urdf" and not where and isinstance(value, str):
                        found.append((field, value))
                    elif key in ("motor", "gear"):
                        names = value if isinstance(value, list) else [value]
                        found.extend((field, v) for v in names if isinstance(v, str)
                                     and v.lower().endswith((".yaml", ".yml")))
                    else:
                        walk(value, field)
            elif isinstance(node, list):
                for k, value in enumerate(node):
                    walk(value, f"{where}[{k}]")

        walk(read_yaml(path), "")
    elif suffix in (".xml", ".mjcf"):
        def element(tag: str, attrs: dict[str, str]) -> None:
            if tag in _MJCF_FILE_ELEMENTS:
                found.append((tag, attrs.get("file", "")))
            found.extend((f"{tag}.{key}", value) for key, value in attrs.items()
                         if key.startswith("file") and tag not in _MJCF_FILE_ELEMENTS)

        scan_xml(read_bytes(path), str(path), element)
    return found
