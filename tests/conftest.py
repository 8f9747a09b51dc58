"""Shared fixtures: random robots and their Pinocchio twins."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from manipcad.model.robot import Drive, Robot


def random_tree(seed: int, n: int = 7, *, chain: bool = False, drives: bool = False) -> Robot:
    """A random tree (or chain) of revolute and prismatic joints with full inertias."""
    rng = np.random.default_rng(seed)
    types = rng.choice(["revolute", "prismatic"], n)
    parent = np.arange(n) - 1 if chain else [-1] + [int(rng.integers(-1, i)) for i in range(1, n)]
    A = rng.normal(size=(n, 3, 3))
    inertia = A @ A.transpose(0, 2, 1) * 0.05 + 0.001 * np.eye(3)
    drv = None
    if drives:
        drv = [Drive(J=rng.uniform(1e-5, 1e-4), ratio=rng.uniform(-100, 100),
                     k_v=rng.uniform(0, 1e-3), M_f=(rng.uniform(0, 0.05), rng.uniform(0, 0.05)))
               for _ in range(n)]
    return Robot.from_arrays(
        f"tree{seed}", types, parent, Rotation.random(n, random_state=seed).as_matrix(),
        rng.normal(size=(n, 3)) * 0.3, rng.uniform(0.5, 3.0, n), rng.normal(size=(n, 3)) * 0.1,
        inertia, offset=rng.normal(size=n), drives=drv,
        gravity=rng.normal(size=3) * 5.0)


@pytest.fixture(params=range(6))
def tree(request) -> Robot:
    return random_tree(request.param, n=3 + request.param, chain=request.param % 2 == 0)


def rel_err(a, b) -> float:
    """Largest difference relative to the largest magnitude (1 when both are tiny)."""
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1.0))
