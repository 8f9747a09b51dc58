"""All of a robot's drives in one compiled call, for the closed-loop simulator.

The simulator stacks every joint's drive states into one vector ``xd``;
joint j's states are ``xd[off[j]:off[j+1]]`` with ``off =
state_offsets(table)`` (see :mod:`manipcad.drives.params` for the per-kind
state order). At every RK4 stage it calls :func:`drive_rates` with the stage's
joint (q, q̇) and the held amplifier inputs U, gets the joint torques ``tau``
and the drive-state derivatives ``dxd``, then runs the multibody forward
dynamics with ``tau``:

- rigid kinds (1, 2): ``tau[j] = i_r·k_m·i``; the multibody model adds
  ``J·i_r²``, ``k_v·i_r²·q̇``, ``|i_r|·M_f·sign(q̇)`` for that joint;
- elastic kinds (3, 4): ``tau[j] = τ_s`` (transmission torque); the multibody
  model must NOT add those drive terms for that joint;
- kind 0 (no drive): ``tau[j]`` and ``dxd`` are left untouched (the caller
  decides, e.g. a torque-controlled joint).
"""

from __future__ import annotations

import numba
import numpy as np

from manipcad.drives.dc import rigid_drive_rate
from manipcad.drives.params import KIND_ELASTIC, KIND_ELASTIC_STATIC, KIND_RIGID, P_KIND
from manipcad.drives.transmission import elastic_motor_modal, elastic_motor_rhs


@numba.njit(cache=True)
def drive_rates(table: np.ndarray, off: np.ndarray, xd: np.ndarray, U: np.ndarray,
                q: np.ndarray, qd: np.ndarray, tau: np.ndarray, dxd: np.ndarray,
                gm: np.ndarray | None = None) -> None:
    """Joint torques and drive-state derivatives of all drives.

    Args:
        table: (n, NPAR) packed drives (:func:`manipcad.drives.params.pack_drives`).
        off: (n + 1,) int64 state offsets (:func:`manipcad.drives.params.state_offsets`).
        xd: stacked drive states (A, rad, rad/s per kind), shape (off[n],).
        U: (n,) amplifier inputs, V.
        q: (n,) joint coordinates, rad (m).
        qd: (n,) joint velocities, rad/s (m/s).
        tau: (n,) output joint torques from the drives, N·m (N).
        dxd: output, shape of xd: drive-state derivatives.
        gm: (n, 3 or more) the elastic gears' modes (the hybrid plant of
            :mod:`manipcad.sim.events`) in columns 0 and 1: contact and motor shaft, the
            ``c`` and ``s`` of :func:`manipcad.drives.transmission.elastic_motor_modal`
            (nan: from the state); column 2 receives the torque a stuck shaft's friction
            holds, N·m (where ``gm[j, 1] == 0``); None: both modes from the state.

    Example:
        >>> import numpy as np
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.params import pack_drives, state_offsets
        >>> from manipcad.drives.coupling import drive_rates
        >>> d = Drive(J=1e-4, ratio=10, R=1.0, L=1e-2, k_m=.1, k_w=.1)
        >>> t = pack_drives([d, d]); off = state_offsets(t)
        >>> tau = np.zeros(2); dxd = np.zeros(off[-1])
        >>> drive_rates(t, off, np.array([1.0, 0.0]), np.array([1.0, 0.0]),
        ...             np.zeros(2), np.zeros(2), tau, dxd)
        >>> tau.tolist(), dxd.tolist()
        ([1.0, 0.0], [0.0, 0.0])
    """
    n = table.shape[0]
    for j in range(n):
        kind = int(table[j, P_KIND])
        p = table[j]
        o = off[j]
        if kind == KIND_RIGID:
            di, t = rigid_drive_rate(xd[o], U[j], qd[j], p)
            dxd[o] = di
            tau[j] = t
        elif kind == KIND_ELASTIC or kind == KIND_ELASTIC_STATIC:
            if gm is None:
                tau[j] = elastic_motor_rhs(xd[o:off[j + 1]], U[j], q[j], qd[j], p,
                                           dxd[o:off[j + 1]])
            else:
                tau[j], T = elastic_motor_modal(xd[o:off[j + 1]], U[j], q[j], qd[j], p,
                                                dxd[o:off[j + 1]], gm[j, 0], gm[j, 1])
                if gm[j, 1] == 0.0:
                    gm[j, 2] = T
        elif kind != 0:  # KIND_RIGID_STATIC: no state
            _, t = rigid_drive_rate(0.0, U[j], qd[j], p)
            tau[j] = t
