"""The python-control systems a regulator's law gives: the building blocks of
:func:`manipcad.control.export.to_control` that a method's own export calls.

Every regulator exports as a discrete-time nonlinear I/O system
(:func:`nonlinear_system`) whose update and output call the very compiled law the
simulator runs; its inputs are the signals the regulator reads (``needs``), its output
the amplifier input U (V), its states the regulator's state vector. Methods that are
linear time-invariant give a state-space system instead where their module says so
(``pid``, ``none``, ``none_sce``; ``lqr`` with its fixed gains, :func:`static_gain`).
"""

from __future__ import annotations

import numpy as np

from manipcad._lazy import ct
from manipcad.control.regulator import Regulator
from manipcad.control.signals import NSIG, NSTATE, SIGNALS


def _inputs(reg: Regulator) -> list[str]:
    return [s for s in SIGNALS if s in reg.needs and s not in ("H", "t")]


def nonlinear_system(reg: Regulator, law) -> ct.NonlinearIOSystem:
    """A discrete-time nonlinear I/O system (period ``reg.period``) running the compiled law.

    Inputs: the signals of ``reg.needs`` in :data:`~manipcad.control.signals.SIGNALS`
    order (units there); output ``U`` (V); states: the regulator's ``NSTATE`` state
    entries (zero at t = 0).

    Args:
        reg: a single-joint regulator.
        law: its method's compiled update ``law(p, s, sig, j, Ts) -> U``.
    """
    names = _inputs(reg)
    cols = [SIGNALS[s][0] for s in names]
    p = np.ascontiguousarray(reg.params, dtype=float)
    Ts = float(reg.period)

    def run(t, x, u):
        sig = np.zeros((1, NSIG))
        sig[0, cols] = u
        sig[0, 0] = t
        s = np.array(x, dtype=float)
        U = law(p, s, sig, 0, Ts)
        return U, s

    def update(t, x, u, params):
        return run(t, x, u)[1]

    def output(t, x, u, params):
        return np.array([run(t, x, u)[0]])

    return ct.nlsys(update, output, inputs=names, outputs=["U"], states=NSTATE, dt=Ts,
                    name=f"{reg.method}_{'_'.join(reg.joint_names) or reg.joints[0]}")


def static_gain(reg: Regulator, law, clip: int | None = None):
    """The regulator as a static gain U = D·u when its compiled law is linear in its
    signals and keeps no state; else None.

    D is read from the very law the simulator runs: its k-th entry is the output with
    the k-th input signal 1 and the others 0, the output limit (``params[clip]``) left
    out as in the other linear exports. The law is then checked linear (no offset,
    superposition at random signals, to 1e-9 relative) and memoryless (its state
    untouched), else None: e.g. a gain scheduled on H_ii.

    Args:
        reg: the regulator (one joint).
        law: its method's compiled update ``law(p, s, sig, j, Ts) -> U``.
        clip: the index of its output limit (V) in ``reg.params``, or None.

    Returns:
        A discrete-time :class:`control.StateSpace` with no state (period
        ``reg.period``), inputs as :func:`nonlinear_system`, output ``U`` (V); or None.

    Example:
        >>> import manipcad
        >>> from manipcad.control.lqr import LQ_ULIM, lqr_update
        >>> arm = manipcad.load_robot("cylindrical")
        >>> reg = manipcad.synthesize(arm, "turn", "lqr", period=1e-3)
        >>> static_gain(reg, lqr_update, LQ_ULIM).D.shape
        (1, 6)
        >>> static_gain(manipcad.synthesize(arm, "turn", "lqr_gs", period=1e-3),
        ...             lqr_update) is None
        True
    """
    names = _inputs(reg)
    cols = [SIGNALS[s][0] for s in names]
    p = np.array(reg.params, dtype=float)
    if clip is not None:
        p[clip] = np.inf
    Ts = float(reg.period)

    def out(u):
        sig = np.zeros((1, NSIG))
        sig[0, cols] = u
        s = np.zeros(NSTATE)
        U = law(p, s, sig, 0, Ts)
        return U, s

    U0, s0 = out(np.zeros(len(names)))
    D = np.array([out(e)[0] for e in np.eye(len(names))])
    u = np.random.default_rng(0).uniform(-1.0, 1.0, (3, len(names)))
    for v in u:
        U, s = out(v)
        if s.any() or abs(U - D @ v) > 1e-9 * max(1.0, np.abs(D * v).sum()):
            return None
    if U0 != 0.0 or s0.any():
        return None
    return ct.ss([], [], [], D[None, :], Ts, inputs=names, outputs=["U"],
                 name=f"{reg.method}_{'_'.join(reg.joint_names) or reg.joints[0]}")
