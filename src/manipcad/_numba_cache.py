"""Key numba's on-disk cache to the source of all compiled kernels.

numba's ``cache=True`` checks only the file of the function it compiles, so a
kernel whose callee or constants (in another file) changed would run stale machine
code. We hash the kernel sources (the modules that import numba and the package's
modules they import: :func:`manipcad._shipped_kernels.kernel_sources`) and point
``NUMBA_CACHE_DIR`` at a folder named after that hash; a change anywhere in them
recompiles everything once. A user-set ``NUMBA_CACHE_DIR`` is respected.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import time
from pathlib import Path

from numba.core import config

from manipcad import _shipped_kernels


def configure() -> None:
    """Set NUMBA_CACHE_DIR to ~/.cache/manipcad/numba-<hash of the package's folder>-<hash
    of the kernel sources>; a new folder starts with the shipped kernels where they fit
    (:mod:`manipcad._shipped_kernels`; ``MANIPCAD_SHIPPED_KERNELS=0`` compiles them all
    here instead, for this machine's CPU)."""
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    root = Path(__file__).parent
    digest = _shipped_kernels.sources_digest(root)
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "manipcad"
    # numba keys its cache files by the path of their source too: another copy of the
    # package (a second venv, a checkout) gets its own folders, or the warm-up's marks
    # (manipcad.sim.warm) would claim kernels this copy cannot load
    copy = hashlib.sha1(str(root.resolve()).encode()).hexdigest()[:8]
    here = base / f"numba-{copy}-{digest}"
    try:
        base.mkdir(parents=True, exist_ok=True)
        if not here.is_dir():
            _shipped_kernels.start(here, root, digest)
        here.mkdir(exist_ok=True)
        # this copy's older versions, and folders named before the copy was in the name
        for old in [*base.glob(f"numba-{copy}-*"), *base.glob("numba-" + "?" * 16)]:
            # stale versions go after a day (another process may still be using a fresh one)
            if old != here and time.time() - old.stat().st_mtime > 86400:
                shutil.rmtree(old, ignore_errors=True)
    except OSError:
        return  # read-only home: numba's default (next to the sources) applies
    os.environ["NUMBA_CACHE_DIR"] = str(here)
    if "numba" in sys.modules:

        config.reload_config()
