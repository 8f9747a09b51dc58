"""Heavy optional-at-start modules, imported on first use.

python-control imports matplotlib.pyplot and scipy.signal (about 1.7 s on the
2-core reference machine); most commands (``robots show``, ``size``, a simulation
from files, every Dask worker) never touch it. ``ct`` stands for ``import control
as ct``: the first attribute looked up imports python-control.

Example:
    >>> from manipcad._lazy import ct
    >>> ct.tf([1.0], [1.0, 1.0]).dcgain()
    np.float64(1.0)
"""

from __future__ import annotations

import importlib


class LazyModule:
    """A module imported at its first attribute access.

    Args:
        name: the module's import name, e.g. "control".
    """

    __slots__ = ("_name",)

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr: str):
        return getattr(importlib.import_module(self._name), attr)

    def __repr__(self) -> str:
        return f"<lazy module {self._name!r}>"


#: python-control (``import control as ct``), imported on first use
ct = LazyModule("control")
