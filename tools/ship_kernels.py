"""Rebuild the shipped kernels (src/manipcad/kernels.tar.xz) after a kernel changed.

Compiles every kernel ``manipcad warmup`` compiles, for x86-64-v3, on an empty cache
folder (about 40 s on two cores) and packs the folder; see manipcad._shipped_kernels.
Does nothing when the bundle already fits these sources, this numba and this Python (a
rebuild is not byte for byte the same, and each would add 2 MB to git); ``--force``
rebuilds anyway. Run from the repository: ``python tools/ship_kernels.py``.
"""

import sys
from pathlib import Path

from manipcad._shipped_kernels import BUNDLE, build, mismatch, sources_digest

if __name__ == "__main__":
    why = mismatch(BUNDLE, sources_digest(Path(BUNDLE).parent))
    if not why and "--force" not in sys.argv[1:]:
        print(f"{BUNDLE} already fits these kernel sources (--force rebuilds it)")
        sys.exit(0)
    made = build()
    print(f"wrote {BUNDLE} ({BUNDLE.stat().st_size / 1e6:.1f} MB) for {made}")
