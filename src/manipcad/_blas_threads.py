"""One BLAS thread: manipcad's matrices are small, and BLAS threads only spin.

manipcad's linear algebra works on matrices of a robot's size (n ≤ 9 joints, the
drives' 2–4 states, a regulator's Riccati equation): far below the size where a
multithreaded BLAS pays. OpenBLAS (numpy's and scipy's wheels) still hands some of
those calls to its threads, which then busy-wait for the next call: measured on a
2-core machine, a claims-study cell took 2.89 s of CPU for 2.94 s of wall time with
two BLAS threads, and 1.42 s of CPU for 1.43 s with one. On a machine whose cores
are all busy (Dask workers, the test workers) the spinning threads take the cores
the work needs: two Dask workers ran each run 1.9 times slower than one process.

:func:`configure` is called when manipcad is imported, before numpy: unless the user
chose a thread count (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``,
``MKL_NUM_THREADS`` or ``MANIPCAD_BLAS_THREADS``), it sets ``OPENBLAS_NUM_THREADS``
and ``MKL_NUM_THREADS`` to 1 for the BLAS libraries loaded later (and for processes
started from this one), and limits the BLAS libraries already loaded (numpy imported
before manipcad) to the same count through threadpoolctl. ``MANIPCAD_BLAS_THREADS=N``
asks for N threads instead.
"""

from __future__ import annotations

import os
import sys

#: environment variables through which a user chooses the BLAS thread count
USER_CHOICE = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
               "MANIPCAD_BLAS_THREADS")


def configure() -> int | None:
    """Limit BLAS to one thread (or ``MANIPCAD_BLAS_THREADS``) unless the user chose.

    Returns:
        The thread count set, or None when the user's own choice was left alone.

    Example:
        >>> import os
        >>> n = configure()
        >>> n is None or os.environ["OPENBLAS_NUM_THREADS"] == str(n)
        True
    """
    wanted = os.environ.get("MANIPCAD_BLAS_THREADS")
    if wanted is None and any(v in os.environ for v in USER_CHOICE):
        return None
    try:
        n = int(wanted) if wanted is not None else 1
    except ValueError:
        n = 1
    n = max(n, 1)
    for var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = str(n)
    if "numpy" in sys.modules or "scipy" in sys.modules:  # BLAS already loaded
        # deferred: start-up cost: threadpoolctl loaded on first use
        from threadpoolctl import threadpool_limits

        threadpool_limits(n, user_api="blas")
    return n
