"""Fuzz tests of every file kind: mutate valid robot, trajectory, regulator and
CSV files (delete, duplicate, retype, huge, NaN, inf, deep, aliased) and require that
each either loads and passes the model checks or raises the project's own error
(:class:`~manipcad.errors.ManipcadError`), never another exception, within a set time
and memory. The whole module runs in well under a minute.
"""

from __future__ import annotations

import math
import resource
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from manipcad.errors import ManipcadError, ManipcadWarning
from manipcad.fileio import parse_yaml
from manipcad.model.load import load_robot

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ROBOT_TEXT = (EXAMPLES / "two_link.yaml").read_text()
TRAJ_TEXTS = [
    (EXAMPLES / "fig3_laws.yaml").read_text(),
    "type: quintic\nq_start: [0, 0.1]\nq_end: [1.0, -0.5]\nduration: 2.0\n",
    "type: trapezoidal\nq_start: [0, 0]\nq_end: [1, 2]\nv_max: [1, 1.5]\na_max: 4\n",
    "type: spline\ntimes: [0, 0.5, 1.0, 2.0]\npoints: [[0, 0], [0.2, 0.1], [0.5, -0.1], "
    "[1.0, 0]]\n",
]
REG_TEXT = (EXAMPLES / "pid_cylindrical.yaml").read_text()
CSV_LINES = (EXAMPLES / "identify_puma.csv").read_text().splitlines()[:60]

#: per-example limits: time (s) and growth of the peak resident memory (bytes)
TIME_LIMIT = 5.0
MEMORY_LIMIT = 300 * 2**20

FUZZ = settings(max_examples=150, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# ------------------------------------------------------------------ mutations

WEIRD_SCALARS = [None, True, "", "abc", [], {}, 0, -1, 1e308, -1e308, 1e-320,
                 float("nan"), float("inf"), float("-inf"), "x" * 20000, list(range(5000)),
                 "1+" * 30000 + "1", "-" * 50000 + "1", "pi/0", "1e400", "9" * 400,
                 "(" * 300 + "1" + ")" * 300, {"a": {"b": {"c": 1}}}]
TEXT_TOKENS = [".nan", ".inf", "-.inf", "1e400", "9" * 400, "~", "[[[[[[[[[[1]]]]]]]]]]",
               "[" * 500 + "]" * 500, "*undefined", "&a 1", "!!python/object:os.system ls",
               "!!binary 'abc'", "2020-02-30", "'" + "1+" * 30000 + "1'", "0x7fffffffffff",
               "{a: 1, a: 2}", "? [a, b]\n  : 1", "\t", "1e-1", "1.0e12", ".5"]


def laughs(levels: int = 8) -> str:
    out = ["lol0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for k in range(1, levels):
        out.append(f"lol{k}: &l{k} [" + ", ".join([f"*l{k - 1}"] * 10) + "]")
    return "\n".join(out) + "\n"


def _paths(tree, prefix=()):
    yield prefix
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(tree, list):
        for i, v in enumerate(tree):
            yield from _paths(v, (*prefix, i))


def _get(tree, path):
    for p in path:
        tree = tree[p]
    return tree


def _tree_mutation(draw, text: str) -> str:
    tree = parse_yaml(text, "<mutation>")  # bounded: an alias bomb is refused, not expanded
    paths = [p for p in _paths(tree) if p]
    path = draw(st.sampled_from(paths))
    parent, key = _get(tree, path[:-1]), path[-1]
    op = draw(st.sampled_from(["delete", "retype", "deep", "duplicate", "scale"]))
    if op == "delete":
        del parent[key]
    elif op == "retype":
        parent[key] = draw(st.sampled_from(WEIRD_SCALARS))
    elif op == "deep":
        v = parent[key]
        for _ in range(draw(st.integers(20, 400))):
            v = [v]
        parent[key] = v
    elif op == "duplicate":
        if isinstance(parent, list):
            parent.insert(key, parent[key])
        else:  # a key given twice: text level, the dump cannot hold it
            dumped = yaml.safe_dump(tree, sort_keys=False)
            lines = dumped.splitlines()
            i = draw(st.integers(0, len(lines) - 1))
            return "\n".join(lines[:i + 1] + [lines[i]] + lines[i + 1:]) + "\n"
    else:  # scale a number by a huge or tiny factor, or give it another sign
        v = parent[key]
        if isinstance(v, int | float) and not isinstance(v, bool):
            parent[key] = v * draw(st.sampled_from([1e300, -1e300, 1e-300, -1.0, 0.0]))
    return yaml.safe_dump(tree, sort_keys=False, width=10**9)


def _text_mutation(draw, text: str) -> str:
    lines = text.splitlines()
    op = draw(st.sampled_from(["delete_line", "duplicate_line", "token", "laughs", "truncate",
                               "junk"]))
    i = draw(st.integers(0, len(lines) - 1))
    if op == "delete_line":
        del lines[i]
    elif op == "duplicate_line":
        lines.insert(i, lines[i])
    elif op == "token":
        line = lines[i]
        colon = line.find(": ")
        token = draw(st.sampled_from(TEXT_TOKENS))
        lines[i] = (line[:colon + 2] + token) if colon >= 0 else line + " " + token
    elif op == "laughs":
        return laughs() + text
    elif op == "truncate":
        return text[:draw(st.integers(0, len(text)))]
    else:
        lines.insert(i, draw(st.text(max_size=40)))
    return "\n".join(lines) + "\n"


@st.composite
def mutated(draw, texts):
    text = draw(st.sampled_from(texts))
    for _ in range(draw(st.integers(1, 3))):
        try:
            text = (_tree_mutation if draw(st.booleans()) else _text_mutation)(draw, text)
        except (ManipcadError, yaml.YAMLError, ValueError, TypeError, AttributeError,
                KeyError, IndexError, RecursionError):
            text = _text_mutation(draw, text) if text.strip() else text
    return text


# ------------------------------------------------------------------ the contract

class _Budget:
    """Time and memory of one load, checked against TIME_LIMIT and MEMORY_LIMIT."""

    def __enter__(self):
        self.t0 = time.perf_counter()
        self.rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        return self

    def __exit__(self, *exc):
        took = time.perf_counter() - self.t0
        grew = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - self.rss0
        assert took < TIME_LIMIT, f"took {took:.1f} s"
        assert grew < MEMORY_LIMIT, f"peak memory grew by {grew / 2**20:.0f} MB"
        return False


def loads_or_own_error(load, text: str, suffix: str = ".yaml"):
    """Write ``text`` and load it: return the object, or None after the project's own error.

    Any other exception propagates (and fails the test)."""
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"f{suffix}"
        p.write_text(text, encoding="utf-8", errors="surrogatepass")
        with _Budget(), warnings.catch_warnings():
            warnings.simplefilter("ignore", ManipcadWarning)
            try:
                return load(p)
            except ManipcadError as exc:
                assert str(p) in str(exc) or "f.yaml" in str(exc) or str(exc), exc
                return None


def assert_physical(robot) -> None:
    robot.validate()
    for a in (robot.placement_R, robot.placement_p, robot.offset, robot.mass, robot.com,
              robot.inertia, robot.gravity, robot.tool_R, robot.tool_p):
        assert np.isfinite(a).all()
    assert (robot.mass >= 0).all()
    for d in robot.drives:
        if d is not None:
            assert math.isfinite(d.J) and d.J >= 0 and math.isfinite(d.ratio) and d.ratio != 0
            assert math.isnan(d.R) or (math.isfinite(d.R) and d.R > 0)


# ------------------------------------------------------------------ the tests

@FUZZ
@given(mutated([ROBOT_TEXT]))
def test_fuzz_robot_files(text):
    robot = loads_or_own_error(lambda p: load_robot(str(p)), text)
    if robot is not None:
        assert_physical(robot)


@FUZZ
@given(mutated(TRAJ_TEXTS))
def test_fuzz_trajectory_files(text):
    from manipcad.trajectories import load_trajectory

    traj = loads_or_own_error(load_trajectory, text)
    if traj is not None:
        assert math.isfinite(traj.duration) and traj.duration >= 0
        q, qd, qdd = traj.sample(np.linspace(0.0, traj.duration, 7))
        assert np.isfinite(q).all() and np.isfinite(qd).all() and np.isfinite(qdd).all()


@pytest.fixture(scope="module")
def cylindrical():
    return load_robot("cylindrical")


@FUZZ
@given(text=mutated([REG_TEXT]))
def test_fuzz_regulator_files(cylindrical, text):
    from manipcad.control.files import load_regulators

    regs = loads_or_own_error(lambda p: load_regulators(p, cylindrical, dt=1e-4), text)
    if regs is not None:
        assert len(regs) >= 1


CSV_TOKENS = ["nan", "inf", "-inf", "", "abc", "1e400", "9" * 400, "1,2", '"', "0x10",
              "1e-1", " 1.5 ", "\x00", "x" * 100000]


@st.composite
def mutated_csv(draw):
    lines = list(CSV_LINES)
    for _ in range(draw(st.integers(1, 3))):
        if not lines:
            break
        op = draw(st.sampled_from(["delete", "duplicate", "field", "huge", "columns",
                                   "truncate"]))
        i = draw(st.integers(0, len(lines) - 1))
        if op == "delete":
            del lines[i]
        elif op == "duplicate":
            lines.insert(i, lines[i])
        elif op == "field":
            fields = lines[i].split(",")
            fields[draw(st.integers(0, len(fields) - 1))] = draw(st.sampled_from(CSV_TOKENS))
            lines[i] = ",".join(fields)
        elif op == "huge":
            lines[i:i + 1] = [lines[i]] * draw(st.integers(100, 3000))
        elif op == "columns":
            lines[i] = lines[i] + ",1" * draw(st.integers(1, 5000))
        else:
            lines = lines[:i]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return load_robot("puma560")


@FUZZ
@given(text=mutated_csv())
def test_fuzz_torque_csv(puma, text):
    from manipcad.dynamics.identification import load_torque_data

    data = loads_or_own_error(lambda p: load_torque_data(p, puma), text, ".csv")
    if data is not None:
        for a in (data.q, data.qd, data.qdd, data.tau):
            assert a is None or (np.isfinite(a).all() and a.shape[1] == puma.n)
