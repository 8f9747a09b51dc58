"""Write examples/identify_puma.csv: a PUMA 560 carrying an unknown payload, with torques
from Pinocchio (an implementation independent of manipcad's dynamics).

Usage::

    python examples/make_identify_puma.py            # writes examples/identify_puma.csv
    manipcad identify puma560 --data examples/identify_puma.csv --com 0,0,0.08

The data: the catalog PUMA 560 carries a 2.5 kg point mass 0.08 m out along
the flange axis (a gripper with a part), unknown to the identification. All six
joints follow cosine laws q_i = A_i (1 - cos ω_i t) for 2 s, sampled at 50 Hz.
The drive torques are

    tau = RNEA_Pinocchio(model with the payload as an extra body, armature J·i_r²)
          + k_v·i_r²·q̇ + |i_r|·M_f±·sign(q̇)       (the drives' friction, written out here)
          + Gaussian noise of 0.5 % of each drive's torque RMS (seed 0),

where the Pinocchio model is the PUMA exported by manipcad.model.to_pinocchio
(joint order and offsets mapped as documented there) with the payload appended
to the last joint as its own body, so the loaded dynamics are Pinocchio's alone.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin

import manipcad
from manipcad.model.to_pinocchio import to_pinocchio
from manipcad.trajectories import cosine

PAYLOAD_KG = 2.5
PAYLOAD_COM = (0.0, 0.0, 0.08)  # m, in the flange (last link) frame
NOISE = 0.005  # fraction of each drive's torque RMS
OUT = Path(__file__).with_name("identify_puma.csv")


def pinocchio_torques(robot, q, qd, qdd, mass, com) -> np.ndarray:
    """Drive torques (N, n) of ``robot`` carrying a point mass, by Pinocchio + friction."""
    model, order = to_pinocchio(robot, armature=True)
    last = model.getJointId(robot.joint_names[-1])
    model.appendBodyToJoint(last, pin.Inertia(mass, np.asarray(com, float), np.zeros((3, 3))),
                            pin.SE3.Identity())
    data = model.createData()
    tau = np.empty_like(q)
    for k in range(q.shape[0]):
        t = pin.rnea(model, data, (q[k] + robot.offset)[order], qd[k][order], qdd[k][order])
        tau[k, order] = t
    for i, d in enumerate(robot.drives):  # the drives' friction, joint-referred
        if d is None:
            continue
        v = qd[:, i]
        dry = np.where(v > 0, d.M_f[0], np.where(v < 0, -d.M_f[1], 0.0)) * abs(d.ratio)
        tau[:, i] += d.k_v * d.ratio**2 * v + dry
    return tau


def main() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", manipcad.ManipcadWarning)  # published data quirks
        puma = manipcad.load_robot("puma560")
    traj = cosine([0.8, -0.6, 0.7, 1.0, -0.8, 1.2], [3.0, 2.2, 3.7, 4.1, 5.3, 4.7],
                  duration=2.0)
    t = np.linspace(0.0, 2.0, 101)
    q, qd, qdd = traj.sample(t)
    tau = pinocchio_torques(puma, q, qd, qdd, PAYLOAD_KG, PAYLOAD_COM)
    rng = np.random.default_rng(0)
    tau = tau + rng.normal(size=tau.shape) * NOISE * np.sqrt(np.mean(tau**2, axis=0))
    n = puma.n
    header = (["t"] + [f"q{i}" for i in range(1, n + 1)] + [f"qd{i}" for i in range(1, n + 1)]
              + [f"qdd{i}" for i in range(1, n + 1)] + [f"tau{i}" for i in range(1, n + 1)])
    lines = [
        "# PUMA 560 (manipcad catalog) carrying an unknown payload; made by",
        "# examples/make_identify_puma.py (torques: Pinocchio RNEA with the payload as a body,",
        "# rotor inertia and drive friction, plus 0.5 % Gaussian noise).",
        "# Units: t s; q rad; qd rad/s; qdd rad/s^2; tau N·m (drive torque at the joint).",
        "# True payload: 2.5 kg at (0, 0, 0.08) m in the flange frame.",
        ",".join(header),
    ]
    rows = np.column_stack([t, q, qd, qdd, tau])
    lines += [",".join(f"{x + 0.0:.7g}" for x in row) for row in rows]  # no "-0"
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"wrote {OUT} ({len(rows)} samples)")


if __name__ == "__main__":
    main()
