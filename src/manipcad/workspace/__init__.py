"""The designer's workspace: libraries of robots, motors, gears, trajectories,
regulators, results and studies, with an SQLite index (docs/workspace.md).

Python::

    from manipcad.workspace import Workspace
    ws = Workspace.init("my-ws")            # or Workspace() for ./manipcad-ws / $MANIPCAD_WORKSPACE
    ws.add("ur5.urdf")                     # kind recognized from the content
    ws.list("results", where="max_error<1e-3")

The results store (:mod:`manipcad.store.results`) writes each result folder.
"""

from manipcad.workspace.core import (
    Item,
    ItemList,
    Problem,
    Workspace,
    catalog_items,
    default_root,
    resolve_input,
)
from manipcad.workspace.frame import result_html, results_dataframe
from manipcad.workspace.names import KINDS, check_name, kind_of
from manipcad.workspace.where import METRICS, parse_where

__all__ = ["Workspace", "Item", "ItemList", "Problem", "default_root", "resolve_input",
           "catalog_items", "results_dataframe", "result_html", "KINDS", "check_name",
           "kind_of", "METRICS", "parse_where"]
