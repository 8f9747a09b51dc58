"""The online payload estimator (compiled RLS with forgetting) against batch least squares."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipcad
from manipcad.dynamics.identification import identify_payload, payload_regressor
from manipcad.dynamics.rls import (
    STATE_SIZE,
    OnlinePayloadEstimator,
    rls_operation_counts,
    rls_update,
)
from manipcad.errors import InputError, ManipcadWarning
from manipcad.trajectories import cosine


@pytest.fixture(scope="module")
def puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot("puma560")


def _stream(T=400, k=3, seed=0):
    rng = np.random.default_rng(seed)
    g = rng.normal(size=(T, k))
    y = 2.7 * g + rng.normal(size=(T, k)) * 0.3
    w = rng.uniform(0.5, 2.0, k)
    return y, g, w


def test_update_equals_batch_least_squares():
    """λ = 1: the recursion is batch weighted least squares Σ w g y / Σ w g², every period."""
    y, g, w = _stream()
    state = np.zeros(STATE_SIZE)
    for t in range(y.shape[0]):
        m = rls_update(state, y[t], g[t], w, 1.0, 0.0)
        batch = np.sum(w * g[:t + 1] * y[:t + 1]) / np.sum(w * g[:t + 1] ** 2)
        assert m == pytest.approx(batch, rel=1e-12)
    assert state[2] == y.shape[0]


def test_forgetting_equals_exponentially_weighted_batch():
    y, g, w = _stream(seed=1)
    lam = 0.97
    state = np.array([1.0, 5.0, 0.0])  # a prior: m_0 = 1 kg with information 5
    T = y.shape[0]
    for t in range(T):
        m = rls_update(state, y[t], g[t], w, lam, 0.0)
    decay = lam ** np.arange(T - 1, -1, -1)[:, None]
    num = np.sum(decay * w * g * y) + lam**T * 5.0 * 1.0
    den = np.sum(decay * w * g**2) + lam**T * 5.0
    assert m == pytest.approx(num / den, rel=1e-12)


def test_no_information_keeps_the_estimate_and_floor_holds():
    state = np.array([1.3, 0.0, 0.0])
    assert rls_update(state, np.zeros(2), np.zeros(2), np.ones(2), 0.9, 0.0) == 1.3
    state = np.array([1.3, 1e-9, 0.0])
    rls_update(state, np.zeros(2), np.zeros(2), np.ones(2), 0.5, 2.0)
    assert state[1] == 2.0  # S floored


def test_estimator_matches_batch_identification(puma):
    """Along a motion (torques from the loaded robot's inverse dynamics with drives), the
    online estimate with λ = 1 and one drive equals identify_payload's one-drive least
    squares on the same samples; with all drives it converges to the true mass."""
    t = np.linspace(0.0, 3.0, 600)
    q, qd, qdd = cosine([0.6, -0.5, 0.7, 0.8, 0.6, 0.9], [2.0, 3.0, 2.5, 4.0, 3.5, 3.0],
                        3.0).sample(t)
    com = (0.02, -0.01, 0.06)
    tau = manipcad.inverse_dynamics(puma.with_payload(2.4, com), q, qd, qdd)
    rng = np.random.default_rng(3)
    noisy = tau + rng.normal(size=tau.shape) * 0.01 * np.sqrt(np.mean(tau**2, axis=0))
    one = OnlinePayloadEstimator(puma, com=com, forgetting=1.0, joints=["elbow"])
    online = one.run(q, qd, qdd, noisy)[-1]
    batch = identify_payload(puma, q, qd, qdd, noisy, com=com, joints=["elbow"],
                             method="motion")
    assert online == pytest.approx(batch.mass, rel=1e-9)
    every = OnlinePayloadEstimator(puma, com=com, forgetting=1.0)
    clean = every.run(q, qd, qdd, tau)
    assert clean[-1] == pytest.approx(2.4, rel=1e-9)
    # the regressor it uses is the batch one
    g = payload_regressor(puma, q[100], qd[100], qdd[100], com=com)
    assert np.allclose(g, payload_regressor(puma, q[100], qd[100], qdd[100], com=com))


def test_pickup_converges_within_two_percent(puma):
    """A mass step mid-motion (a pickup): with λ = 0.995 at 1 kHz (memory T = 0.2 s) the
    old data's weight decays as exp(-t/T), so the estimate comes within 2 % of the new
    mass after about T·ln(|Δm| / (0.02·m)) = 0.75 s."""
    dt = 1e-3
    t = np.arange(0.0, 3.0, dt)
    q, qd, qdd = cosine([0.6, -0.5, 0.7, 0.8, 0.6, 0.9], [2.0, 3.0, 2.5, 4.0, 3.5, 3.0],
                        3.0).sample(t)
    before = manipcad.inverse_dynamics(puma.with_payload(0.5), q, qd, qdd)
    after = manipcad.inverse_dynamics(puma.with_payload(3.0), q, qd, qdd)
    tau = np.where((t < 1.0)[:, None], before, after)
    tau = tau + np.random.default_rng(4).normal(size=tau.shape) * 0.01 * np.sqrt(
        np.mean(tau**2, axis=0))
    est = OnlinePayloadEstimator(puma, forgetting=0.995)
    m = est.run(q, qd, qdd, tau)
    assert abs(m[990] / 0.5 - 1) < 0.05  # tracking the first mass before the pickup
    off = np.abs(m / 3.0 - 1) > 0.02
    settled = t[np.flatnonzero(off)[-1] + 1] - 1.0
    predicted = 0.2 * np.log(2.5 / (0.02 * 3.0))
    assert 0.6 * predicted < settled < 1.2 * predicted, (settled, predicted)
    assert est.mass == pytest.approx(3.0, rel=0.02)


def test_operation_counts():
    """4k + 2 multiplications and 3k + 2 additions per period for k drives (docstring)."""
    for k in (1, 3, 6):
        assert rls_operation_counts(k) == {"mul": 4 * k + 2, "add": 3 * k + 2}


def test_bad_arguments(puma):
    with pytest.raises(InputError, match="forgetting"):
        OnlinePayloadEstimator(puma, forgetting=1.5)
    with pytest.raises(InputError, match="joints"):
        OnlinePayloadEstimator(puma, joints=["knee"])
    est = OnlinePayloadEstimator(puma)
    with pytest.raises(InputError, match="qd"):
        est.run(np.zeros((3, 6)), np.zeros((2, 6)), np.zeros((3, 6)), np.zeros((3, 6)))
