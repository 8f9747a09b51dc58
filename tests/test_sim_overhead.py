"""simulate()'s per-call work (session 6): sim/direct.py, the compiled core called without
numba's typing only for arguments whose key says their types are exactly those it was
compiled for; the start sampled once; the packed drives kept per robot; the memory reading
reused."""

import gc
import sys
import warnings
from collections import namedtuple
from pathlib import Path

import numba as nb
import numpy as np
import pytest

import manipcad
import manipcad.budget as budget
from manipcad.errors import ManipcadWarning
from manipcad.sim import simulate
from manipcad.sim.direct import DirectCall
from manipcad.sim.joint_limits import column_extremes

SIM = sys.modules["manipcad.sim.integrate"]
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@nb.cfunc("float64(float64)")
def _twice(x):
    return 2.0 * x


@nb.cfunc("float64(float64)")
def _thrice(x):
    return 3.0 * x


@nb.cfunc("int64(int64)")
def _plus_one(k):
    return k + 1


@nb.njit
def _apply(p, k):
    """p = (array, callback, nested tuple (array,)); sum of p.a times k through p.f."""
    return p.f(p.a.sum() * k) + p.inner[0][0]


@nb.njit
def _total(a, k):
    return a.sum() * k


Part = namedtuple("Part", "a f inner")


class Forbidden:
    """A dispatcher that must not be reached."""

    def __call__(self, *args):
        raise AssertionError("the call went through the dispatcher")


def test_second_call_goes_direct_and_agrees():
    f = DirectCall(_total)
    a = np.arange(4.0)
    assert f(a, 2) == _total(a, 2) == 12.0
    dispatcher = f.dispatcher
    f.dispatcher = Forbidden()
    assert f(np.ones(4), 3) == 12.0  # same types: the cached entry point
    f.dispatcher = dispatcher


@pytest.mark.parametrize("other", [
    np.ones(4, dtype=np.int64),                 # dtype
    np.ones((2, 2)),                            # dimensions
    np.ones(8)[::2],                            # layout (strided)
    np.ones(4).astype(np.float32),              # dtype
])
def test_a_different_type_never_takes_the_cached_entry(other):
    f = DirectCall(_total)
    f(np.ones(4), 2)
    f.dispatcher = Forbidden()
    with pytest.raises(AssertionError, match="through the dispatcher"):
        f(other, 2)
    f.dispatcher = _total
    assert f(other, 2) == _total(other, 2) == 2 * other.sum()


def test_read_only_array_and_argument_kinds_are_keys():
    f = DirectCall(_total)
    f(np.ones(4), 2)
    ro = np.ones(4)
    ro.flags.writeable = False
    f.dispatcher = Forbidden()
    for args in [(ro, 2), (np.ones(4), 2.0), (np.ones(4), True)]:
        with pytest.raises(AssertionError):
            f(*args)


def test_named_tuple_with_a_callback_keyed_by_class_fields_and_callback():
    f = DirectCall(_apply)
    inner = (np.array([0.5]),)
    p = Part(np.ones(3), _twice, inner)
    assert f(p, 2) == 12.5
    f.dispatcher = Forbidden()
    # another array of the same type, the same callback: direct
    assert f(Part(np.full(3, 2.0), _twice, inner), 1) == 12.5
    # another callback of the same signature: a new key (the dispatcher), same result rule
    with pytest.raises(AssertionError):
        f(Part(np.ones(3), _thrice, inner), 2)
    f.dispatcher = _apply
    assert f(Part(np.ones(3), _thrice, inner), 2) == 18.5
    f.dispatcher = Forbidden()
    assert f(Part(np.ones(3), _thrice, inner), 2) == 18.5  # now cached, the callback's own
    assert f(Part(np.ones(3), _twice, inner), 2) == 12.5
    # a class of the same name and fields (numba's fingerprint alone would not tell)
    Other = namedtuple("Part", "a f inner")
    with pytest.raises(AssertionError):
        f(Other(np.ones(3), _twice, inner), 2)
    # a nested field of another type
    with pytest.raises(AssertionError):
        f(Part(np.ones(3), _twice, (np.array([1]),)), 2)
    f.dispatcher = _apply
    assert f(Part(np.ones(3), _twice, (np.array([1]),)), 2) == 13.0


def test_a_callback_of_another_signature_goes_to_numba():
    f = DirectCall(_apply)
    f(Part(np.ones(3), _twice, (np.array([0.5]),)), 2)
    f.dispatcher = Forbidden()
    with pytest.raises(AssertionError):  # not the cached entry: numba's own typing
        f(Part(np.ones(3), _plus_one, (np.array([0.5]),)), 2)


def test_values_without_a_key_always_dispatch():
    @nb.njit
    def call(g, x):
        return g(x)

    @nb.njit
    def inc(x):
        return x + 1.0

    f = DirectCall(call)
    assert f(inc, 1.0) == 2.0
    assert f(inc, 2.0) == 3.0
    assert f._entry == {}  # a dispatcher argument has no key: never cached


def test_size_bounds_the_cache():
    f = DirectCall(_total, size=2)
    for a in (np.ones(2), np.ones(2, dtype=np.int64), np.ones(2, dtype=np.float32)):
        assert f(a, 1) == 2
    assert len(f._entry) == 2


# ------------------------------------------------------------ simulate()'s own work


def _puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot("puma560")


def _pd(robot, dt=1e-4):
    """The example PID of the PUMA (examples/pid_puma.yaml, 1 kHz)."""
    from manipcad.control.files import load_regulators

    return load_regulators(EXAMPLES / "pid_puma.yaml", robot, dt=dt)


def _arrays(res):
    return [res.t, res.q, res.qd, res.q_ref, res.qd_ref, res.u, res.current, res.tau]


def _same(a, b):
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(_arrays(a), _arrays(b),
                                                                     strict=True))


def test_start_is_the_trajectory_at_zero_for_every_kind():
    """The start q(0) taken from the first chunk's rows is, bit for bit, the trajectory
    sampled at t = 0 alone; a Cartesian path (rows depend on the batch) samples t = 0 apart."""
    from manipcad.trajectories import CartesianTrajectory, cosine, line, quintic, spline, waypoints

    robot = _puma()
    rng = np.random.default_rng(3)
    trajs = [quintic(rng.normal(size=6) * 0.2, rng.normal(size=6) * 0.2, 0.01),
             cosine(rng.normal(size=6) * 0.1, rng.uniform(1, 9, 6), duration=0.02),
             spline([0.0, 0.004, 0.01], rng.normal(size=(3, 6)) * 0.1),
             waypoints(rng.normal(size=(3, 6)) * 0.1, move_time=0.003, dwell=0.001),
             line(robot, [0.5, 0.0, 1.2], [0.5, -0.01, 1.2], 0.01, q0=[0, 0.8, -1.2, 0, 0.5, 0])]
    assert CartesianTrajectory.rows_independent is False
    for traj in trajs:
        res = simulate(robot, t_end=0.01, dt=1e-4, trajectory=traj, regulators=_pd(robot))
        q_start = traj.sample(np.zeros(1))[0][0]
        assert np.array_equal(res.q[0], q_start), type(traj).__name__
        assert np.array_equal(res.q_ref, traj.sample(res.t)[0])


def test_packed_drives_kept_per_robot_and_fresh_per_run():
    """Runs of one robot (its packed drives kept on it) equal runs of a fresh copy, whatever
    ran before: another order, no drives, a pickup (which writes the body table in the
    loop) or other transmissions."""
    from manipcad.drives.params import Transmission

    robot = _puma()
    kw = dict(t_end=0.02, dt=1e-4, q0=np.full(6, 0.1))
    regs = _pd(robot)
    runs = [dict(order=2, regulators=regs), dict(regulators=regs), dict(drives=False),
            dict(pickup={"mass": 2.0, "t": 0.01}, regulators=regs),
            dict(transmissions=[Transmission(1e4, 2.0, 0.0)] + [None] * 5, regulators=regs),
            dict(regulators=regs)]
    for opts in runs:
        res = simulate(robot, **kw, **opts)
        ref = simulate(robot.replace(), **kw, **opts)
        assert _same(res, ref), opts
    # kept beside the robot, not on it; gone with it
    from manipcad.sim.closed_loop import _DRIVES

    assert set(_DRIVES.get(robot)) == {(True, 2), (True, 3), (False, 3)}
    assert not any(k.startswith("_") for k in robot.__dict__)
    kept = len(_DRIVES)
    del robot, res, ref
    gc.collect()
    assert len(_DRIVES) < kept


def test_direct_call_gives_the_dispatchers_results(monkeypatch):
    """simulate() through DirectCall (generated then general kernels: other C callbacks)
    equals simulate() through numba's own dispatch of the compiled core."""
    from manipcad.codegen import generate

    robot = _puma()
    generate(robot)
    kw = dict(t_end=0.02, dt=1e-4, regulators=_pd(robot), q0=np.full(6, 0.1))
    fast = [simulate(robot, use_generated=g, **kw) for g in (True, False, True)]
    assert [r.settings["generated"] for r in fast] == [True, False, True]
    monkeypatch.setattr(SIM, "run", SIM.run.dispatcher)
    slow = [simulate(robot, use_generated=g, **kw) for g in (True, False, True)]
    assert all(_same(a, b) for a, b in zip(fast, slow, strict=True))


def test_memory_reading_reused_only_for_a_small_recent_need(monkeypatch):
    reads = []

    def available():
        reads.append(1)
        return 16 * 2**30

    monkeypatch.setattr(budget, "available_memory", available)
    monkeypatch.setattr(budget, "_last_budget", [0, -np.inf])
    budget.check_steps(1.0, 1e-4, floats_per_step=10)
    budget.check_steps(1.0, 1e-4, floats_per_step=10)
    assert len(reads) == 1  # the second within the second, a small need: reused
    budget.check_steps(1.0, 1e-8, floats_per_step=10)  # 0.8 GB: more than 1/16 of 8 GB
    assert len(reads) == 2
    monkeypatch.setattr(budget, "REUSE_SECONDS", 0.0)
    budget.check_steps(1.0, 1e-4, floats_per_step=10)
    assert len(reads) == 3
    with pytest.raises(budget.InputError, match="more than the"):
        budget.check_steps(1.0, 1e-9, floats_per_step=10)  # 80 GB: a new reading refuses


def test_quintic_profile_compiled_equals_numpys_expressions():
    """The compiled pass gives numpy's numbers bit for bit, for any shape and layout."""
    from manipcad.trajectories.quintic import quintic_profile

    rng = np.random.default_rng(5)
    for tau in (np.arange(10001) * 1e-4 / 1.3, rng.random(9), np.array(0.3), rng.random((7, 3)),
                rng.random((20, 4))[:, 1], np.array([0.0, 1.0, 0.5, 1e-300])):
        want = (tau**3 * (10.0 + tau * (-15.0 + 6.0 * tau)),
                30.0 * tau**2 * (1.0 - tau) ** 2,
                60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau))
        got = quintic_profile(tau)
        assert all(g.shape == w.shape and np.array_equal(g, w) for g, w in zip(got, want,
                                                                                 strict=True))


@pytest.mark.parametrize("shape", [(10001, 6), (1, 6), (3, 6), (5, 7), (100, 1), (7, 3),
                                   (1000, 9), (4, 8), (333, 5), (2, 16)])
def test_column_extremes_equal_numpys(shape):
    a = np.random.default_rng(sum(shape)).normal(size=shape)
    assert np.array_equal(column_extremes(a), np.stack([a.min(axis=0), a.max(axis=0)]))


def test_shared_zero_disturbance_rows_stay_zero():
    """The zero disturbance rows shared by runs without a disturbance are only read."""
    robot = _puma()
    kw = dict(t_end=0.02, dt=1e-4, q0=np.full(6, 0.1), regulators=_pd(robot))
    a = simulate(robot, **kw)
    b = simulate(robot, integrator="adaptive", **kw)
    c = simulate(robot, disturbance=np.zeros(6), **kw)
    assert np.array_equal(a.q, c.q) and np.isfinite(b.q).all()
    z = SIM._ZEROS[6]
    assert z.shape[0] >= SIM.CHUNK + 1 and not z.any()


def test_direct_call_from_threads():
    """Threads calling with keys new and old at once all get the dispatcher's results."""
    from concurrent.futures import ThreadPoolExecutor

    f = DirectCall(_total, size=3)
    arrays = [np.ones(5, dtype=dt) for dt in (np.float64, np.int64, np.float32, np.int32)]
    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(lambda i: f(arrays[i % 4], 2), range(400)))
    assert got == [10] * 400 and len(f._entry) <= 3
