"""Self-contained HTML reports: escaped text, tables and images embedded as base64.

A report is one file with no external reference (no scripts, no style sheets,
no image files): the figures are ``data:image/png;base64`` URIs, so the file
can be mailed or archived alone.

Example:
    >>> from manipcad.report.html import page, table
    >>> html = page("Demo", [table(["x", "unit"], [[1.5, "m"]])])
    >>> html.startswith("<!DOCTYPE html>") and '<td class="num">1.5</td>' in html
    True
"""

from __future__ import annotations

import base64
import html as _html
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 72em; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; margin-top: 1.8em;
     border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.92em; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; vertical-align: top; text-align: left; }
th { background: #f0f0f0; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
.holds { color: #176117; font-weight: 600; } .fails { color: #a01010; font-weight: 600; }
.partly { color: #8a5a00; font-weight: 600; } .na { color: #666; font-weight: 600; }
code, .law { font-family: ui-monospace, "SFMono-Regular", Menlo, monospace; font-size: 0.85em; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; }
.note { background: #fafae8; border-left: 4px solid #d8c860; padding: 0.4em 0.8em; }
"""


def esc(x: Any) -> str:
    """HTML-escaped text of any value."""
    return _html.escape(str(x), quote=True)


def fmt(x: Any, digits: int = 4) -> str:
    """A number in ``digits`` significant digits; nan/None as "–", others as text."""
    if x is None:
        return "–"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        if math.isnan(x):
            return "–"
        if math.isinf(x):
            return "∞" if x > 0 else "−∞"
        return f"{x:.{digits}g}"
    return str(x)


def table(header: Sequence[str], rows: Iterable[Sequence[Any]], *, digits: int = 4,
          raw_columns: Sequence[int] = (), classes: Sequence[str | None] | None = None) -> str:
    """An HTML table; numbers right-aligned in ``digits`` significant digits.

    Args:
        header: column titles (escaped).
        rows: cells; numbers are formatted, everything else escaped, except in
            ``raw_columns`` whose cells are inserted as HTML (already escaped).
        digits: significant digits of numbers.
        raw_columns: indices of columns holding HTML.
        classes: an optional CSS class per row (None for none).
    """
    out = ["<table>", "<tr>" + "".join(f"<th>{esc(h)}</th>" for h in header) + "</tr>"]
    for r, row in enumerate(rows):
        cls = classes[r] if classes is not None and r < len(classes) else None
        cells = []
        for c, v in enumerate(row):
            if c in raw_columns:
                cells.append(f"<td>{v}</td>")
            elif isinstance(v, int | float) and not isinstance(v, bool):
                cells.append(f'<td class="num">{esc(fmt(v, digits))}</td>')
            else:
                cells.append(f"<td>{esc(fmt(v, digits))}</td>")
        attr = f' class="{esc(cls)}"' if cls else ""
        out.append(f"<tr{attr}>" + "".join(cells) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


def png_data_uri(png: bytes | str | Path) -> str:
    """A ``data:image/png;base64,...`` URI of PNG bytes or of a PNG file."""
    data = png if isinstance(png, bytes) else Path(png).read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG image")
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def figure(png: bytes | str | Path, caption: str, alt: str = "") -> str:
    """A ``<figure>`` with the PNG embedded (base64) and an escaped caption."""
    return (f'<figure><img src="{png_data_uri(png)}" alt="{esc(alt or caption)}">'
            f"<figcaption>{esc(caption)}</figcaption></figure>")


def section(title: str, *parts: str) -> str:
    """An ``<h2>`` section; ``parts`` are HTML."""
    return f"<section><h2>{esc(title)}</h2>\n" + "\n".join(parts) + "\n</section>"


def paragraph(text: str, *, cls: str | None = None) -> str:
    """A paragraph of escaped text."""
    attr = f' class="{esc(cls)}"' if cls else ""
    return f"<p{attr}>{esc(text)}</p>"


def page(title: str, body: Sequence[str], *, subtitle: str = "") -> str:
    """A complete HTML5 document with the inline style sheet; ``body`` parts are HTML."""
    sub = f"<p>{esc(subtitle)}</p>" if subtitle else ""
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f"<title>{esc(title)}</title>\n<style>{_STYLE}</style>\n</head>\n<body>\n"
            f"<h1>{esc(title)}</h1>\n{sub}\n" + "\n".join(body) + "\n</body>\n</html>\n")


__all__ = ["esc", "fmt", "table", "png_data_uri", "figure", "section", "paragraph", "page"]
