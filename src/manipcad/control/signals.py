"""The signals a regulator may read, and the sizes of its parameter and state vectors.

At every sample the simulator fills one row per joint of the signal matrix
``sig`` (shape ``(n, NSIG)``), column indices ``S_*`` below; a regulator reads
the rows of its joints. Which signals a method reads is its ``needs`` (the
names in :data:`SIGNALS`); the moment constituents are computed only when a
regulator needs them.

The paper's h_i is the velocity constituent. As a *torque* (what a controller
measures or computes) it is ``c_i = Σ_jk c_ijk·q̇_j·q̇_k`` in N·m (signal
``c_i``); the laws of section 3 write it as ``h_i·q̇_i`` with a *coefficient*
h_i in N·m·s/rad, which the regulators take as ``Ḣ_ii`` (the momentum split,
docs/drive-equations.md §1.2) — the code calls that coefficient ``h`` /
``h_star`` (= h_i/i_r²), never a signal.
"""

from __future__ import annotations

#: column of the signal matrix: time, reference, measured state, armature current,
#: moment constituents of the joint, motor angle and speed
S_T, S_QREF, S_QDREF, S_QDDREF, S_Q, S_QD, S_I, S_HII, S_CI, S_QI, S_THM, S_WM = range(12)
NSIG = 12

#: signal name -> (column, unit, meaning)
SIGNALS: dict[str, tuple[int, str, str]] = {
    "t": (S_T, "s", "time"),
    "q_ref": (S_QREF, "rad | m", "reference position q*"),
    "q_dot_ref": (S_QDREF, "rad/s | m/s", "reference velocity q̇*"),
    "q_ddot_ref": (S_QDDREF, "rad/s² | m/s²", "reference acceleration q̈*"),
    "q": (S_Q, "rad | m", "measured joint position"),
    "q_dot": (S_QD, "rad/s | m/s", "measured joint velocity"),
    "i": (S_I, "A", "armature current"),
    "H_ii": (S_HII, "kg·m² | kg", "diagonal inertia constituent H_ii(q)"),
    "c_i": (S_CI, "N·m | N", "velocity torque (Coriolis/centrifugal) c_i(q, q̇)"),
    "Q_i": (S_QI, "N·m | N", "gravity constituent Q_i(q)"),
    "theta_m": (S_THM, "rad", "motor angle θ_m"),
    "omega_m": (S_WM, "rad/s", "motor speed ω_m"),
    "H": (-1, "kg·m²", "the whole joint-space inertia matrix H(q)"),
}

#: signals computed from the model (the moment constituents) rather than measured
MODEL_SIGNALS = frozenset({"H_ii", "c_i", "Q_i", "H"})

#: length of every regulator's parameter vector (float64) and state vector
NPARAM = 256
NSTATE = 16
