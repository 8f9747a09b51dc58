"""Trajectory ``type: waypoints``: moves through poses with a dwell at each."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from manipcad.errors import InputError, ManipcadWarning
from manipcad.trajectories import (
    load_trajectory,
    quintic,
    save_trajectory,
    trajectory_from_dict,
    trapezoidal,
    waypoints,
)

POINTS = [[0.0, 0.2, -0.1], [0.8, -0.4, 0.3], [0.1, 0.5, 0.3], [-0.6, 0.0, 0.0]]


def test_each_move_is_the_point_to_point_law():
    """Move k equals a quintic move from P_k to P_{k+1} in T_k, shifted by its start."""
    T = [0.5, 0.8, 0.4]
    W = [0.2, 0.3, 0.0, 0.25]
    traj = waypoints(POINTS, move_time=T, dwell=W)
    assert traj.duration == pytest.approx(sum(T) + sum(W), rel=1e-15)
    start = 0.0
    for k in range(3):
        start += W[k]
        ref = quintic(POINTS[k], POINTS[k + 1], T[k])
        tt = np.linspace(0.0, T[k], 41)[1:-1]
        got = traj.sample(start + tt)
        want = ref.sample(tt)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_allclose(g, w, rtol=1e-9, atol=1e-12)
        start += T[k]


def test_trapezoidal_thirds_and_limits():
    """profile trapezoidal: the synchronised trapezoidal move whose limits give thirds."""
    traj = waypoints(POINTS[:2], move_time=0.9, dwell=0.1, profile="trapezoidal")
    D = np.abs(np.subtract(POINTS[1], POINTS[0]))
    ref = trapezoidal(POINTS[0], POINTS[1], v_max=1.5 * D / 0.9, a_max=4.5 * D / 0.81)
    assert ref.duration == pytest.approx(0.9, rel=1e-12)
    assert ref.t_accel == pytest.approx(0.3, rel=1e-12)
    tt = np.linspace(0.0, 0.9, 37)
    got, want = traj.sample(0.1 + tt), ref.sample(tt)
    for g, w in zip(got[:2], want[:2], strict=True):
        np.testing.assert_allclose(g, w, rtol=1e-9, atol=1e-12)
    # the acceleration jumps at the thirds: compare between them
    inner = np.min(np.abs(tt[:, None] - [0.0, 0.3, 0.6, 0.9]), axis=1) > 1e-9
    np.testing.assert_allclose(got[2][inner], want[2][inner], rtol=1e-9)


@pytest.mark.parametrize("profile", ["quintic", "trapezoidal"])
def test_derivatives_consistent_and_stops_hold(profile):
    traj = waypoints(POINTS, move_time=0.5, dwell=[0.3, 0.2, 0.2, 0.4], profile=profile)
    t = np.linspace(0.0, traj.duration, 20001)
    q, qd, qdd = traj.sample(t)
    dt = t[1] - t[0]
    # velocity is the derivative of position; position continuous
    np.testing.assert_allclose(np.gradient(q, dt, axis=0)[1:-1], qd[1:-1], atol=2e-3)
    assert np.abs(np.diff(q, axis=0)).max() < 1e-3
    stops = traj.dwell_intervals()
    np.testing.assert_allclose(stops, [[0, 0.3], [0.8, 1.0], [1.5, 1.7], [2.2, 2.6]], atol=1e-12)
    for k, (a, b) in enumerate(stops):
        inside = (t > a + 1e-9) & (t < b - 1e-9)
        assert inside.any()
        np.testing.assert_array_equal(q[inside], np.broadcast_to(POINTS[k], q[inside].shape))
        assert not qd[inside].any() and not qdd[inside].any()
    # the end holds the last pose
    qe, qde, _ = traj.sample(traj.duration + 1.0)
    assert qe.tolist() == POINTS[-1] and not qde.any()


def test_yaml_round_trip(tmp_path):
    text = ("type: waypoints\npoints: [[0, 0.2], [0.5, -0.3], [1.0, 0.0]]\n"
            "move_time: 0.5\ndwell: [0.3, 0.1, 0.2]\nprofile: trapezoidal\n")
    p = tmp_path / "w.yaml"
    p.write_text(text)
    traj = load_trajectory(p)
    assert traj.kind == "waypoints" and traj.n == 2 and traj.duration == pytest.approx(1.6)
    save_trajectory(traj, tmp_path / "back.yaml")
    again = load_trajectory(tmp_path / "back.yaml")
    t = np.linspace(0, 1.7, 50)
    for a, b in zip(traj.sample(t), again.sample(t), strict=True):
        np.testing.assert_array_equal(a, b)
    assert again.to_dict() == traj.to_dict()


@pytest.mark.parametrize(("data", "field", "reason"), [
    ({"points": [[0.0]], "move_time": 1.0}, "points", "at least two poses"),
    ({"points": [[0.0], [1.0]], "move_time": 0.0}, "move_time[0]", "> 0"),
    ({"points": [[0.0], [1.0], [2.0]], "move_time": [1.0, 1.0, 1.0]}, "move_time",
     "expected 2"),
    ({"points": [[0.0], [1.0]], "move_time": 1.0, "dwell": [0.1, -0.1]}, "dwell[1]", ">= 0"),
    ({"points": [[0.0], [1.0]], "move_time": 1.0, "profile": "cubic"}, "profile", ""),
    ({"points": [[0.0, 1.0], [1.0]], "move_time": 1.0}, "points", ""),
    ({"points": [[0.0], [1.0]]}, "move_time", "missing"),
])
def test_bad_fields_named(data, field, reason):
    with pytest.raises(InputError) as info:
        trajectory_from_dict({"type": "waypoints", **data}, "w.yaml")
    assert info.value.source == "w.yaml"
    assert info.value.field.startswith(field)
    assert reason in info.value.reason


def test_dither_whole_cycles_at_the_end_of_each_dwell(tmp_path):
    """``dither``: every dwell after the first ends with the whole cycles of
    P + a·sin(2πf·τ) that fit in it; the moves and the first dwell are unchanged."""
    a = np.array([0.01, 0.0, 0.02])
    plain = waypoints(POINTS, move_time=0.5, dwell=0.45)
    # 2 whole cycles: too few for the identification at stops (the first is the start
    # transient), said with the field and the frequencies that work
    with pytest.warns(ManipcadWarning, match=r"dither_frequency 5 Hz gives 2 whole cycle\(s\) "
                      r"in the 0.45 s dwell.*needs 3 whole cycles.*dither_frequency >= 6.67 Hz"):
        traj = waypoints(POINTS, move_time=0.5, dwell=0.45, dither=a, dither_frequency=5.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ManipcadWarning)
        waypoints(POINTS, move_time=0.5, dwell=0.6, dither=a, dither_frequency=5.0)  # 3: fine
    with pytest.warns(ManipcadWarning, match=r"period over 0.5 s.*>= 2 Hz"):
        waypoints(POINTS, move_time=0.5, dwell=3.0, dither=a, dither_frequency=1.5)
    iv = traj.dither_intervals()
    np.testing.assert_allclose(iv[1:, 1] - iv[1:, 0], 0.4)         # 2 whole cycles of 0.2 s
    assert iv[0, 0] == iv[0, 1] and np.allclose(iv[:, 1], plain.dwell_intervals()[:, 1])
    t = np.linspace(0.0, traj.duration, 3001)
    q, qd, qdd = traj.sample(t)
    q0, qd0, _ = plain.sample(t)
    on = np.zeros(t.size, dtype=bool)
    for s, e in iv:
        on |= (t > s) & (t < e)
    k = np.searchsorted(iv[:, 1], t[on])
    start = iv[k, 0]
    np.testing.assert_allclose(q[on] - q0[on], np.sin(2 * np.pi * 5.0 * (t[on] - start))[:, None]
                               * a, atol=1e-12)
    np.testing.assert_allclose(q[~on], q0[~on], atol=1e-12)
    np.testing.assert_allclose(np.gradient(q[on][:40], t[on][:40], axis=0)[1:-1],
                               qd[on][:40][1:-1], rtol=0, atol=2e-3)
    assert np.all(qd0[on] == 0)
    save_trajectory(traj, tmp_path / "d.yaml")
    with pytest.warns(ManipcadWarning, match="dither_frequency"):
        back = load_trajectory(tmp_path / "d.yaml")
    assert back.to_dict() == traj.to_dict() and back.to_dict()["dither_frequency"] == 5.0
    with pytest.raises(InputError, match=r"dither\[1\].*>= 0"):
        waypoints(POINTS, move_time=0.5, dither=[0.01, -0.01, 0.0])
    with pytest.raises(InputError, match="dither_frequency.*> 0"):
        waypoints(POINTS, move_time=0.5, dither=0.01, dither_frequency=0.0)
