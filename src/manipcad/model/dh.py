"""Denavit-Hartenberg tables mapped onto the internal joint placements.

Modified DH (Craig, Khalil-Kleinfinger; the paper's convention): row i holds
a_{i-1}, alpha_{i-1}, d_i, theta_i and

    T_{i-1,i} = Rot_x(alpha_{i-1}) · Trans_x(a_{i-1}) · Rot_z(theta_i) · Trans_z(d_i),

which is already "fixed placement, then motion about z". The link frame is the
proximal one, so link data need no change.

Standard DH (Denavit-Hartenberg 1955, Corke's toolbox): row i holds
a_i, alpha_i, d_i, theta_i and

    T_{i-1,i} = Rot_z(theta_i) · Trans_z(d_i) · Trans_x(a_i) · Rot_x(alpha_i),

with the link data given in the distal frame i. We cut each row after its
motion: the body frame of link i is frame i-1 moved by the joint, and the fixed
part Trans_x(a_i)·Rot_x(alpha_i) becomes the placement of the next joint (or of
the tool for the last row). Link centres and inertias are carried from frame i
into that body frame. Both conventions then give the same dynamics.
"""

from __future__ import annotations

import numpy as np


def rot_x(alpha: float) -> np.ndarray:
    """Rotation about x by alpha (rad)."""
    c, s = np.cos(alpha), np.sin(alpha)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_z(theta: float) -> np.ndarray:
    """Rotation about z by theta (rad)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def modified_placement(a: float, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Placement (R, p) = Rot_x(alpha)·Trans_x(a) of a modified-DH row (a, alpha in m, rad)."""
    return rot_x(alpha), np.array([a, 0.0, 0.0])


def standard_distal(a: float, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """The fixed part Trans_x(a)·Rot_x(alpha) of a standard-DH row: the distal
    frame i in the body frame of link i (m, rad)."""
    return rot_x(alpha), np.array([a, 0.0, 0.0])


def distal_to_body(R: np.ndarray, p: np.ndarray, com: np.ndarray,
                   inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Carry a centre of mass (m) and an inertia about it (kg·m²) given in the
    distal frame (R, p in the body frame) into the body frame."""
    return R @ com + p, R @ inertia @ R.T
