"""Values kept beside an object while it lives, keyed by its identity.

The model's objects are frozen data (:class:`~manipcad.model.robot.Robot`): what a layer
above derives from one (the generated kernels of a robot, the simulator's packed drives)
is kept in that layer's own :class:`PerObject`, never written onto the object, and goes
when the object goes.
"""

from __future__ import annotations

import weakref
from typing import Any


class PerObject:
    """A mapping from live objects (by identity, not by equality) to values.

    An entry goes when its object is collected; the object need not be hashable (a
    frozen dataclass holding arrays is not), only weakly referable. A value must not
    refer to its object (it would keep it alive).

    Example:
        >>> class Box:
        ...     pass
        >>> cache, box = PerObject(), Box()
        >>> cache.get(box) is None
        True
        >>> cache.set(box, 42)
        >>> cache.get(box), len(cache)
        (42, 1)
        >>> del box
        >>> len(cache)
        0
    """

    __slots__ = ("_entries",)

    def __init__(self) -> None:
        self._entries: dict[int, tuple[weakref.ref, Any]] = {}

    def get(self, obj: Any, default: Any = None) -> Any:
        """The value kept for ``obj``, or ``default``."""
        entry = self._entries.get(id(obj))
        if entry is None or entry[0]() is not obj:
            return default
        return entry[1]

    def set(self, obj: Any, value: Any) -> None:
        """Keep ``value`` for ``obj`` (replacing what was kept) until ``obj`` is collected."""
        key = id(obj)
        entries = self._entries

        def gone(ref: weakref.ref, key: int = key) -> None:
            entry = entries.get(key)
            if entry is not None and entry[0] is ref:
                del entries[key]

        entries[key] = (weakref.ref(obj, gone), value)

    def pop(self, obj: Any, default: Any = None) -> Any:
        """Forget ``obj``'s value; returns it (or ``default``)."""
        value = self.get(obj, default)
        if self.get(obj, self) is not self:
            del self._entries[id(obj)]
        return value

    def __len__(self) -> int:
        return len(self._entries)


__all__ = ["PerObject"]
