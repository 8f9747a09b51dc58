"""study robustness: perturbed arms, serial and 2-worker runs identical, the cache, the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import manipcad
from manipcad.cli import app
from manipcad.errors import InputError
from manipcad.study.robustness import perturbed_arm, run_robustness

#: a short, small study: two methods, two samples, 0.05 s runs
SMALL = {"samples": 2, "methods": "none_sce,lqr", "t_end": 0.05, "dt": 2e-4, "progress": False}


@pytest.fixture(scope="module")
def arm():
    return manipcad.load_robot("cylindrical")


def test_perturbed_arm_factors(arm):
    nominal, f0 = perturbed_arm(arm, 0.5, 0.2, seed=3, sample=-1)
    assert f0["payload"] == 1.0 and f0["mass"] == [1.0] * arm.n
    new, f = perturbed_arm(arm, 0.5, 0.2, seed=3, sample=7)
    again, _ = perturbed_arm(arm, 0.5, 0.2, seed=3, sample=7)
    other, _ = perturbed_arm(arm, 0.5, 0.2, seed=3, sample=8)
    k = arm.joint_index("reach")
    for j in range(arm.n):
        assert 0.8 <= f["mass"][j] <= 1.2 and 0.8 <= f["motor"][j] <= 1.2
        if j != k:  # the payload changes the reach link's inertia
            np.testing.assert_allclose(new.inertia[j], arm.inertia[j] * f["mass"][j],
                                       rtol=1e-15)
        assert new.drives[j].k_m == arm.drives[j].k_m * f["motor"][j]
        assert new.drives[j].k_w == arm.drives[j].k_w * f["motor"][j]
    # the payload is a point mass on the reach link: its mass adds to the scaled link's
    assert new.mass[k] == pytest.approx(arm.mass[k] * f["mass"][k] + 0.5 * f["payload"])
    assert nominal.mass[k] == pytest.approx(arm.mass[k] + 0.5)
    assert np.array_equal(new.mass, again.mass) and not np.array_equal(new.mass, other.mass)


@pytest.mark.slow
def test_serial_equals_two_workers_and_cache(tmp_path, arm, dask_scheduler):
    """The same numbers serially and on 2 worker processes (the session's shared cluster);
    a rerun computes nothing, more samples only the new. Slow (2-20 s) only when it is the
    first test to use the shared cluster: its workers then import manipcad."""
    serial = run_robustness(tmp_path / "s", arm=arm, workers=1, **SMALL)
    dist = run_robustness(tmp_path / "d", arm=arm, scheduler=dask_scheduler, **SMALL)
    assert serial["max_error"] == dist["max_error"] and serial["nominal"] == dist["nominal"]
    assert all(v is not None and v > 0 for m in ("none_sce", "lqr")
               for v in serial["max_error"][m])
    on_disk = json.loads((tmp_path / "s" / "robustness.json").read_text())
    assert on_disk["max_error"] == serial["max_error"]
    assert (tmp_path / "s" / "robustness.png").stat().st_size > 1000
    more = run_robustness(tmp_path / "s", arm=arm, workers=1, **{**SMALL, "samples": 3})
    assert more["settings"]["samples_computed"] == 1
    assert more["max_error"]["lqr"][:2] == serial["max_error"]["lqr"]


def test_bad_arguments(tmp_path, arm):
    with pytest.raises(InputError, match="--uncertainty"):
        run_robustness(tmp_path / "x", arm=arm, uncertainty=1.5, progress=False)
    with pytest.raises(InputError, match="--methods"):
        run_robustness(tmp_path / "x", arm=arm, methods="lqr,nope", progress=False)
    runner = CliRunner()
    for args, word in ((["--samples", "0"], "--samples"), (["--uncertainty", "-5"],
                                                          "--uncertainty"),
                       (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "scheduler"),
                       (["--arm", str(tmp_path / "none.yaml")], "none.yaml")):
        r = runner.invoke(app, ["study", "robustness", "--out", str(tmp_path / "y"), *args])
        assert r.exit_code == 2 and word in r.output and "Traceback" not in r.output, args
    assert not (tmp_path / "y").exists()
