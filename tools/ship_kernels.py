"""Rebuild the shipped kernels (src/manipcad/kernels.tar.xz) after a kernel changed.

Compiles every kernel ``manipcad warmup`` compiles, for a generic CPU, on an empty cache
folder (about 40 s on two cores) and packs the folder; see manipcad._shipped_kernels.
Run from the repository: ``python tools/ship_kernels.py``.
"""

from manipcad._shipped_kernels import BUNDLE, build

if __name__ == "__main__":
    made = build()
    print(f"wrote {BUNDLE} ({BUNDLE.stat().st_size / 1e6:.1f} MB) for {made}")
