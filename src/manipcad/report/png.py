"""PNG files of RGBA images written in bands of rows, each band encoded on its own.

A band's rows are filtered (PNG filter 1, "Sub": each byte less the byte of the pixel to
its left, so a row depends on no other row) and deflated with a sync flush (the stream
ends on a byte boundary, no final block): bands encoded by separate processes join into
one zlib stream, whose Adler-32 checksum is combined from theirs (:func:`adler32_combine`).
So a figure drawn in groups of panels on several workers is encoded there too, and this
process only joins the bands (:func:`manipcad.report.claims.save_bands`). Any PNG reader
decodes the same pixels as from a file written whole; the bytes depend on the bands.
"""

from __future__ import annotations

import dataclasses
import struct
import zlib
from pathlib import Path

import numpy as np

from manipcad.fileio import atomic_write_bytes

#: zlib's compression level (6: zlib's default, as Pillow's PNG writer)
LEVEL = 6
_MOD = 65521  # Adler-32's modulus


@dataclasses.dataclass(frozen=True)
class Band:
    """Rows ``first .. first + rows - 1`` of an RGBA image, filtered and deflated.

    Attributes:
        first: the band's first row.
        rows: its number of rows.
        width: the image's width, pixels.
        data: raw deflate data, sync-flushed (no final block).
        adler: Adler-32 of the filtered rows.
        size: length of the filtered rows, bytes.
    """

    first: int
    rows: int
    width: int
    data: bytes
    adler: int
    size: int


def encode_rows(rgba: np.ndarray, first: int = 0, stop: int | None = None) -> Band:
    """The band of rows ``first:stop`` of an RGBA image (uint8, (height, width, 4)).

    Example:
        >>> band = encode_rows(np.full((3, 2, 4), 255, np.uint8), 1)
        >>> band.first, band.rows, band.size
        (1, 2, 18)
    """
    a = np.asarray(rgba)
    if a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] != 4:
        raise ValueError(f"expected an RGBA uint8 image (height, width, 4), got {a.dtype} "
                         f"{a.shape}")
    a = a[first:stop]
    h, w = a.shape[0], a.shape[1]
    flat = a.reshape(h, 4 * w)
    f = np.empty((h, 1 + 4 * w), np.uint8)
    f[:, 0] = 1                                         # filter type 1 (Sub)
    f[:, 1:5] = flat[:, :4]
    np.subtract(flat[:, 4:], flat[:, :-4], out=f[:, 5:])  # modulo 256
    raw = f.tobytes()
    z = zlib.compressobj(LEVEL, zlib.DEFLATED, -15)
    data = z.compress(raw) + z.flush(zlib.Z_SYNC_FLUSH)
    return Band(int(first), h, w, data, zlib.adler32(raw), len(raw))


def adler32_combine(adler1: int, adler2: int, len2: int) -> int:
    """Adler-32 of two byte strings joined, from theirs and the second one's length
    (zlib's ``adler32_combine``).

    Example:
        >>> a, b = b"claims ", b"maps"
        >>> adler32_combine(zlib.adler32(a), zlib.adler32(b), len(b)) == zlib.adler32(a + b)
        True
    """
    rem = len2 % _MOD
    s1 = adler1 & 0xFFFF
    s2 = (rem * s1) % _MOD
    s1 = (s1 + (adler2 & 0xFFFF) + _MOD - 1) % _MOD
    s2 = (s2 + (adler1 >> 16) + (adler2 >> 16) + _MOD - rem) % _MOD
    return s1 | (s2 << 16)


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(
        ">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


def write_png(path: str | Path, bands: list[Band], *, dpi: float = 100.0) -> Path:
    """Join bands that cover an RGBA image's rows, in order, into a PNG file.

    Args:
        path: the file.
        bands: the bands, first row first, each starting where the one before ends, the
            first at row 0, all of one width.
        dpi: the resolution written into the file (pHYs), dots per inch.

    Returns:
        The path written.

    Example:
        >>> import tempfile
        >>> from PIL import Image
        >>> img = np.arange(5 * 3 * 4, dtype=np.uint8).reshape(5, 3, 4)
        >>> p = write_png(Path(tempfile.mkdtemp()) / "x.png",
        ...               [encode_rows(img, 0, 2), encode_rows(img, 2)])
        >>> np.array_equal(np.asarray(Image.open(p)), img)
        True
    """
    if not bands or bands[0].first != 0:
        raise ValueError("the bands must start at row 0")
    width = bands[0].width
    adler, at = 1, 0
    for b in bands:
        if b.first != at or b.width != width:
            raise ValueError(f"band at row {b.first} (width {b.width}): expected row {at}, "
                             f"width {width}")
        adler = adler32_combine(adler, b.adler, b.size)
        at += b.rows
    final = zlib.compressobj(LEVEL, zlib.DEFLATED, -15).flush()  # an empty final block
    stream = b"\x78\x9c" + b"".join(b.data for b in bands) + final + struct.pack(">I", adler)
    ppm = int(dpi / 0.0254 + 0.5)
    png = (b"\x89PNG\r\n\x1a\n"
           + _chunk(b"IHDR", struct.pack(">IIBBBBB", width, at, 8, 6, 0, 0, 0))
           + _chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1))
           + _chunk(b"IDAT", stream) + _chunk(b"IEND", b""))

    return atomic_write_bytes(path, png)
