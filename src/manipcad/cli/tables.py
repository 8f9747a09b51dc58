"""Tables that print their text as given: no markup, no emoji codes.

rich reads a table cell's text as console markup: a regulator law holding
``[ρ(Ḣ*+h*+k_v)/(k_m k_u)]`` loses the bracketed term, and ``[red]`` in a file or
joint name changes colour. :class:`Table` takes every text cell, column header and
title literally; a cell meant to be coloured is made with :func:`styled`.
"""

from __future__ import annotations

from typing import Any

from rich import table as _table
from rich.text import Text


def styled(text: str, style: str) -> Text:
    """A table cell (or printable text) shown in ``style`` (e.g. "green", "bold red"),
    its text taken literally.

    Example:
        >>> styled("[a] + b", "red").plain
        '[a] + b'
    """
    return Text(str(text), style=style)


def _literal(x: Any, style: str = "") -> Any:
    return Text(x, style=style) if isinstance(x, str) else x


class Table(_table.Table):
    """A :class:`rich.table.Table` whose text (cells, headers, title, caption) is shown
    literally; rich renderables (e.g. :func:`styled` text) are passed through.

    Example:
        >>> import io
        >>> from rich.console import Console
        >>> t = Table(title="law")
        >>> t.add_column("joint [1]")
        >>> t.add_row("U = [ρ(H+h)]·i_r·q̇ :fire:")
        >>> c = Console(width=60, emoji=False, file=io.StringIO())
        >>> with c.capture() as cap:
        ...     c.print(t)
        >>> "[ρ(H+h)]·i_r·q̇ :fire:" in cap.get() and "joint [1]" in cap.get()
        True
    """

    def __init__(self, *headers: Any, title: Any = None, caption: Any = None,
                 **kwargs: Any) -> None:
        super().__init__(*(_literal(h) for h in headers),
                         title=_literal(title, "table.title"),
                         caption=_literal(caption, "table.caption"), **kwargs)

    def add_column(self, header: Any = "", *args: Any, **kwargs: Any) -> None:
        super().add_column(_literal(header), *args, **kwargs)

    def add_row(self, *renderables: Any, **kwargs: Any) -> None:
        super().add_row(*(_literal(r) for r in renderables), **kwargs)
