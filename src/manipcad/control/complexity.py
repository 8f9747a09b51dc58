"""Realization complexity of a regulator, counted from the code that runs.

The compiled update of the regulator's method is run in plain Python (its own source,
``py_func``, with its compiled callees replaced the same way; see
:mod:`manipcad.dynamics.counts`) on counting numbers, with the regulator's own
parameters: the multiplications (divisions included), additions (subtractions included)
and function calls (square roots, exponentials) of one control period are counted, the
parameter entries it reads are the numbers it must store (a gain table counts whole),
and the signal columns it reads are the signals it must measure or compute. The first
period (which fills the history of the load differences) is run and not counted.
"""

from __future__ import annotations

import numpy as np

from manipcad.control.registry import method
from manipcad.control.regulator import Regulator
from manipcad.control.signals import NSTATE, SIGNALS
from manipcad.dynamics.counts import Counted, _plain, _Tally


class _Reads:
    """An array stand-in that records which entries are read and returns Counted values."""

    def __init__(self, values: np.ndarray, offset: int = 0, log: set | None = None) -> None:
        self.values = values
        self.offset = offset
        self.log = set() if log is None else log

    def __getitem__(self, idx):
        if isinstance(idx, slice):
            start = (idx.start or 0) + self.offset
            return _Reads(self.values, start, self.log)
        if isinstance(idx, tuple):
            self.log.add(idx)
            return Counted(self.values[idx])
        k = int(idx) + self.offset
        self.log.add(k)
        return Counted(self.values[k])


def _signals(n: int) -> np.ndarray:
    """A generic moving state: nonzero errors, speeds, current and moment constituents."""
    sig = np.zeros((n, len(SIGNALS) - 1))
    for j in range(n):
        sig[j] = [0.01, 0.30, 1.1, 0.9, 0.28, 1.0, 0.7, 0.05 + 0.01 * j, 0.02, -0.3, 30.0, 95.0]
    return sig


def realization_complexity(reg: Regulator) -> dict:
    """Operations per period, numbers stored and signals read by a regulator.

    Returns:
        ``{"mul", "add", "func", "ops_per_period", "gains_stored", "signals", "period"}``:
        counts of one control period, the parameter entries the law reads (a gain table
        whole), the names of the signals it reads, the period in s.

    Example:
        >>> import manipcad
        >>> reg = manipcad.synthesize(manipcad.load_robot("cylindrical"), "turn", "none")
        >>> c = realization_complexity(reg)
        >>> c["ops_per_period"], c["signals"]
        (2, ['q_ref', 'q'])
    """
    m = method(reg.method)
    law = _plain(m.update)
    n = max(max(reg.joints) + 1, 1) if all(isinstance(j, int) for j in reg.joints) else 1
    joints = list(reg.joints) if n > 1 or isinstance(reg.joints[0], int) else [0]
    sig_vals = _signals(n)
    H_vals = np.eye(n) * 0.05 + 0.01
    state = np.empty(NSTATE, dtype=object)
    for k in range(NSTATE):
        state[k] = Counted(0.0)
    tally = None
    p_log: set = set()
    s_log: set = set()
    for rep in range(2):
        p = _Reads(np.asarray(reg.params, dtype=float))
        sig = _Reads(sig_vals)
        H = np.empty((n, n), dtype=object)
        for idx in np.ndindex(n, n):
            H[idx] = Counted(H_vals[idx])
        U = np.empty(n, dtype=object)
        Counted.tally = _Tally()
        if m.spans:
            law(p, state, sig, H, np.array(joints), len(joints), float(reg.period), U)
        else:
            law(p, state, sig, joints[0], float(reg.period))
        tally = Counted.tally
        if rep == 1:
            p_log, s_log = p.log, sig.log
    stored = set(p_log)
    if m.table:   # a gain table counts whole
        stored |= set(m.table.entries(np.asarray(reg.params)))
    cols = {c for (_, c) in s_log}
    names = [name for name, (c, _, _) in SIGNALS.items() if c in cols]
    if m.spans:
        names.append("H")
    return {"mul": tally.mul, "add": tally.add, "func": tally.func,
            "ops_per_period": tally.mul + tally.add + tally.func,
            "gains_stored": len(stored), "signals": names, "period": reg.period}
