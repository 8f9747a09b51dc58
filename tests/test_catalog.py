"""The parts library (docs/catalog.md): every imported number against its source row (the
source files parsed here independently, with pandas and yaml, not the library's reader),
the compatibility tables and the adapter rule, the --where filter, workspace parts, the
commands, and the stated strain-wave efficiency through ``size`` and ``size --strict``."""

from __future__ import annotations

import fnmatch
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from typer.testing import CliRunner

import manipcad
from manipcad import catalog
from manipcad.catalog.library import MGDB_COMMIT, tables
from manipcad.cli import app
from manipcad.errors import InputError
from manipcad.model.robot import Drive

DATA = Path(catalog.__file__).parent / "data"
RPM = 2 * math.pi / 60
MOTOR_FILES = ["maxon_motors.csv", "faulhaber_motors.csv", "allied_motion_motors.csv",
               "Tmotor_AK_motors.csv", "Tmotor_G_motors.csv"]
GEAR_FILES = ["maxon_gearboxes.csv", "faulhaber_gearboxes.csv", "Tmotor_AK_gearboxes.csv"]
runner = CliRunner()


def _csv(name: str) -> pd.DataFrame:
    df = pd.read_csv(DATA / "mgdb" / name, dtype={"key": str, "ID": str})
    for c in df.columns:
        if c not in ("key", "manufacturer", "ID", "type"):
            df[c] = pd.to_numeric(df[c], errors="coerce")     # "0.85-3" -> nan
    return df.set_index("key")


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return bool(np.array_equal(a, b, equal_nan=True) or np.allclose(a, b, rtol=1e-15,
                                                                     atol=0, equal_nan=True))


def _finite(x: pd.Series) -> np.ndarray:
    """A rating column as the library keeps it: inf (no limit printed) -> nan."""
    v = x.to_numpy(float).copy()
    v[np.isinf(v)] = np.nan
    return v


@pytest.mark.parametrize("file", MOTOR_FILES)
def test_every_mgdb_motor_number_matches_its_row(file):
    src = _csv(file)
    lib = tables().motors
    lib = lib[lib["origin"] == "mgdb"].loc[src.index]           # every row, each once
    assert len(lib) == len(src) and lib.index.is_unique
    for col, mine in (("inertia", "J"), ("R", "R"), ("L", "L"), ("k_t", "k_m"),
                      ("V", "rated_voltage"), ("mass", "mass"), ("I_nl", "no_load_current"),
                      ("Rth1", "Rth1"), ("Rth2", "Rth2")):
        assert _same(lib[mine], src[col]), col
    for col, mine in (("I_nom", "rated_current"), ("max_int_speed", "max_speed"),
                      ("omega_nl", "no_load_speed"), ("max_cont_speed", "max_cont_speed"),
                      ("max_cont_power", "max_cont_power")):
        assert _same(lib[mine], _finite(src[col])), col
    k_e = src["k_e"] if "k_e" in src else src["k_t"]
    assert _same(lib["k_w"], k_e)
    # derived values, by the documented formulas
    assert _same(lib["rated_torque"], src["k_t"] * _finite(src["I_nom"]))
    stall = src["k_t"] * src["V"] / src["R"]
    assert _same(lib["peak_torque"], np.where(np.isfinite(src["max_int_torque"]),
                                              src["max_int_torque"], stall))
    friction = np.where(src["coulomb_friction"].notna(), src["coulomb_friction"],
                        src["k_t"] * src["I_nl"])
    assert _same(lib["M_f"], np.nan_to_num(friction, nan=0.0))
    assert _same(lib["k_v"], src["viscous_friction"].fillna(0.0))
    for key, row in lib.iterrows():
        assert f"MGDB@{MGDB_COMMIT}" in row["source"] and f"key {key}" in row["source"]
        assert row["maker"] == src.loc[key, "manufacturer"] and row["model"] == src.loc[key, "ID"]
        # every value not printed as it stands says why
        if math.isnan(src.loc[key, "coulomb_friction"]):
            assert "M_f" in row["derived"] or "M_f" in row["assumed"]
        if not np.isfinite(src.loc[key, "max_int_torque"]) and np.isfinite(stall[key]):
            assert "stall torque" in row["derived"]["peak_torque"]


@pytest.mark.parametrize("file", GEAR_FILES)
def test_every_mgdb_gearbox_number_matches_its_row(file):
    src = _csv(file)
    lib = catalog.gears()
    lib = lib[lib["origin"] == "mgdb"].loc[src.index]
    assert len(lib) == len(src)
    for col, mine in (("ratio", "ratio"), ("direction", "direction"), ("stages", "stages"),
                      ("inertia", "J"), ("efficiency", "efficiency"), ("mass", "mass")):
        assert _same(lib[mine], src[col]), col
    assert _same(lib["max_continuous_torque"], _finite(src["max_cont_torque"]))
    assert _same(lib["max_intermittent_torque"], _finite(src["max_int_torque"]))
    printed = src["efficiency"].notna()
    assert (lib.loc[printed, "efficiency_basis"] == "printed maximum").all()
    assert (lib.loc[~printed, "efficiency_basis"] == "unknown").all()


def test_counts_per_maker():
    m, g = tables().motors, tables().gears
    mg = m[m.origin == "mgdb"]["maker"].value_counts().to_dict()
    assert mg == {"Maxon": 640, "Faulhaber": 237, "Allied_Motion": 148, "Tmotor": 11}
    gg = g[g.origin == "mgdb"]["maker"].value_counts().to_dict()
    assert gg == {"Maxon": 1897, "Faulhaber": 644, "Tmotor": 2}


def test_compatibility_tables_match_the_files():
    """Every (motor, gear) line of the three compatibility files, with Faulhaber's
    ``PREFIX*`` patterns expanded over its gearbox keys, and nothing else."""
    want = set()
    for maker in ("maxon", "faulhaber", "Tmotor_AK"):
        keys = list(_csv(f"{maker}_gearboxes.csv").index)
        for line in (DATA / "mgdb" / f"{maker}_compatibility.csv").read_text().splitlines():
            motor, *gears = [x for x in line.split(",") if x]
            for g in gears:
                want |= {(motor, k) for k in (fnmatch.filter(keys, g) if "*" in g else [g])}
    p = tables().pairs
    assert set(zip(p.motor, p.gear, strict=True)) == want
    assert len(p) == len(want)


def test_adapter_rule_by_brute_force():
    """The pairs of gears without a table: a motor whose peak torque (else stall torque)
    times ratio and efficiency exceeds the gear's momentary (else repeated) peak is out,
    every other pair is in; checked pair by pair on a subset."""
    m = catalog.motors(makers=["maxon"]).iloc[::37]
    g = catalog.gears(types=["harmonic"])
    got = catalog.compatible_pairs(m, g)
    got = set(zip(got.motor, got.gear, strict=True))
    want = set()
    for mn, mr in m.iterrows():
        peak = mr.peak_torque
        if math.isnan(peak):
            peak = mr.k_m * mr.rated_voltage / mr.R
        for gn, gr in g.iterrows():
            lim = gr.max_momentary_torque
            lim = gr.max_intermittent_torque if math.isnan(lim) else lim
            eta = 1.0 if math.isnan(gr.efficiency) else gr.efficiency
            if not peak * gr.ratio * eta > lim:
                want.add((mn, gn))
    assert got == want and 0 < len(got) < len(m) * len(g)


def test_harmonic_rows_of_the_data_file():
    """gears.yaml's CSG/CSF rows, units converted here; the momentary peak the earlier
    transcription footnoted (395 / 382 N·m) takes the lower value."""
    doc = yaml.safe_load((DATA / "gears.yaml").read_text(encoding="utf-8"))
    g = catalog.gears()
    n = 0
    for e in doc["parts"]:
        if "cross-check" in e["id"]:
            continue
        row = g.loc[e["id"].split(" ")[0]]
        n += 1
        assert row.ratio == e["ratio"]

        def val(k, scale=1.0, e=e):
            v = e.get(k)
            return math.nan if not isinstance(v, dict) or v["value"] is None \
                else v["value"] * scale
        assert _same(row.max_continuous_torque, val("rated_torque"))
        assert _same(row.max_intermittent_torque, val("repeated_peak_torque"))
        assert _same(row.max_average_torque, val("average_torque_limit"))
        assert _same(row.max_input_speed, val("max_input_speed", RPM))
        assert _same(row.max_average_input_speed, val("average_input_speed_limit", RPM))
        assert _same(row.J, val("input_inertia"))
        assert _same(row.mass, val("mass"))
        if '(382)' in str(e.get("footnote_in_earlier_commit", {}).get("quote", "")):
            assert row.max_momentary_torque == 382.0 and "lower" in row.derived[
                "max_momentary_torque"]
        else:
            assert _same(row.max_momentary_torque, val("momentary_peak_torque"))
        if e["id"].startswith("HFUC"):
            assert row.efficiency == 0.78 and row.efficiency_basis == "printed"
        else:
            assert row.efficiency_basis == "assumed"
        assert e["source"] in row.source
    assert n == 28


def test_motor_rows_of_the_data_file():
    """motors.yaml's entries (a winding each where an entry lists two), units converted
    here; R, L and k_w stay unknown where the sheet prints none (Yaskawa)."""
    doc = yaml.safe_load((DATA / "motors.yaml").read_text(encoding="utf-8"))
    m = tables().motors
    sheet = m[m.origin == "sheet"]
    assert len(sheet) == 13
    scale = {"g*cm^2": 1e-7, "kg*cm^2": 1e-4, "mH": 1e-3, "rpm": RPM, "V/krpm": 60 / 2000 / math.pi}
    for e in doc["motors"]:
        rows = sheet[sheet.key == e["id"]]
        recs = list(e["windings"].values()) if "windings" in e else [{}]
        assert len(rows) == len(recs)
        for (_, row), w in zip(rows.iterrows(), recs, strict=True):
            f = {**e, **w}
            for k, col in (("rotor_inertia", "J"), ("winding_resistance", "R"),
                           ("winding_inductance", "L"), ("torque_constant_kt", "k_m"),
                           ("rated_torque", "rated_torque"), ("max_speed", "max_speed"),
                           ("rated_current", "rated_current"), ("mass", "mass")):
                v = f.get(k)
                want = math.nan if not isinstance(v, dict) or v["value"] is None \
                    else v["value"] * scale.get(v["unit"], 1.0)
                assert _same(row[col], want), (e["id"], k)
    yas = m.loc["yaskawa_sgm7j_04a"]
    assert math.isnan(yas.R) and math.isnan(yas.L) and math.isnan(yas.k_w)


def test_library_parts_build_drives_and_load_in_robot_files(tmp_path):
    f = catalog.drive_fields("MM_597974", "harmonic_csg20_100")
    d = Drive(**f)
    assert d.k_m == 0.136 and d.ratio == -100.0 and d.u_max == 30.0
    assert d.J == pytest.approx(0.00051 + 0.193e-4, rel=1e-12)
    assert dict(d.assumed)["efficiency"].startswith("assumed η = 0.78·0.93")
    doc = {"name": "one", "joints": [{
        "name": "j1", "type": "revolute", "link": {"mass": 1.0, "com": [0.1, 0, 0]},
        "drive": {"motor": "FH_3274G024BP4", "gear": "FH_32A_R3.7:1"}}]}
    if "FH_32A_R3.7:1" not in catalog.gears().index:
        doc["joints"][0]["drive"]["gear"] = catalog.compatible_pairs(
            catalog.motors().loc[["FH_3274G024BP4"]], catalog.gears(makers=["faulhaber"])
        ).gear.iloc[0]
    p = tmp_path / "one.yaml"
    p.write_text(yaml.safe_dump(doc), encoding="utf-8")
    arm = manipcad.load_robot(p)
    g = catalog.part(doc["joints"][0]["drive"]["gear"])
    assert arm.drives[0].ratio == g.direction * g.ratio
    assert arm.drives[0].efficiency == g.efficiency
    saved = manipcad.save_robot(arm, tmp_path / "saved.yaml")  # the written robot keeps it all
    assert manipcad.load_robot(saved).drives[0] == arm.drives[0]
    with pytest.raises(InputError, match="unknown motor"):
        doc["joints"][0]["drive"]["motor"] = "MM_0"
        p.write_text(yaml.safe_dump(doc), encoding="utf-8")
        manipcad.load_robot(p)


def test_an_explicit_efficiency_replaces_the_assumption(tmp_path):
    doc = {"name": "one", "joints": [{
        "name": "j1", "type": "revolute", "link": {"mass": 1.0, "com": [0.1, 0, 0]},
        "drive": {"motor": "maxon_ec45flat_411812", "gear": "harmonic_csg14_100",
                  "efficiency": 0.7}}]}
    p = tmp_path / "one.yaml"
    p.write_text(yaml.safe_dump(doc), encoding="utf-8")
    d = manipcad.load_robot(p).drives[0]
    assert d.efficiency == 0.7 and "efficiency" not in dict(d.assumed)


def test_where_filter():
    m = catalog.motors(where="k_t > 0.1 and mass < 1")
    assert len(m) and (m.k_m > 0.1).all() and (m.mass < 1).all()
    assert len(catalog.gears(where="type == 'harmonic'")) == len(catalog.gears(types=["harmonic"]))
    for bad in ("k_t >", "__import__('os')", "nope > 1", "k_t.real > 0", "[1] == 1"):
        with pytest.raises(InputError):
            catalog.motors(where=bad)


def test_workspace_parts_extend_the_library(tmp_path):
    ws = tmp_path / "ws"
    assert runner.invoke(app, ["ws", "init", str(ws)]).exit_code == 0
    src = DATA / "parts" / "gears" / "harmonic_csg20_100.yaml"
    res = runner.invoke(app, ["ws", "add", str(src), "--ws", str(ws), "--name", "my_gear"])
    assert res.exit_code == 0, res.output
    g = catalog.gears(ws=ws)
    assert g.loc["my_gear", "origin"] == "workspace" and g.loc["my_gear", "ratio"] == 100.0
    assert "my_gear" not in catalog.gears().index
    assert catalog.part("my_gear", ws=ws).max_continuous_torque == 52.0
    res = runner.invoke(app, ["catalog", "list", "--kind", "gear", "--ws", str(ws), "--json",
                              "--where", "ratio == 100 and type == 'harmonic'"])
    assert res.exit_code == 0, res.output
    names = {r["name"] for r in json.loads(res.output)["gears"]}
    assert "my_gear" in names and "CSG-20-100-2UH" in names


def test_cli_list_and_show():
    res = runner.invoke(app, ["catalog", "show", "MM_597974", "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    f = {x["field"]: x for x in doc["fields"]}
    assert f["k_m"]["value"] == 0.136 and f["k_m"]["unit"] == "N·m/A"
    assert f["rated_torque"]["note"].startswith("derived")
    assert "MM_597974" in doc["source"] and MGDB_COMMIT in doc["source"]
    res = runner.invoke(app, ["catalog", "show", "harmonic_csg20_100"], env={"COLUMNS": "200"})
    assert res.exit_code == 0 and "assumed" in res.output and "HFUC-20-80" in res.output
    res = runner.invoke(app, ["catalog", "list", "--kind", "motor", "--makers", "tmotor",
                              "--json"])
    assert res.exit_code == 0 and len(json.loads(res.output)["motors"]) == 11
    for args in (["show", "nope"], ["list", "--kind", "belt"], ["list", "--where", "k_t >"]):
        res = runner.invoke(app, ["catalog", *args])
        assert res.exit_code == 2 and "Traceback" not in res.output


def _one_arm(tmp_path, gear: str, **drive) -> tuple[Path, Path]:
    from manipcad.trajectories import cosine, save_trajectory

    doc = {"name": "one", "joints": [{
        "name": "j1", "type": "revolute", "dh": {"a": 0, "alpha": "pi/2", "d": 0, "theta": 0},
        "link": {"mass": 1.0, "com": [0.1, 0, 0],
                 "inertia": {"ixx": 0.01, "iyy": 0.01, "izz": 0.01}},
        "drive": {"motor": "beckhoff_am8122_0fh1", "gear": gear, **drive}}]}
    robot = tmp_path / "one.yaml"
    robot.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    traj = tmp_path / "t.yaml"
    save_trajectory(cosine([0.5], [2.0], 2.0), traj)
    return robot, traj


def test_size_passes_with_an_assumed_efficiency_and_strict_says_unknown(tmp_path):
    robot, traj = _one_arm(tmp_path, "harmonic_csg20_100")
    res = runner.invoke(app, ["size", str(robot), "-t", str(traj)], env={"COLUMNS": "300"})
    assert res.exit_code == 0, res.output
    assert "passed with an assumed efficiency" in res.output and "HFUC-20-80" in res.output
    res = runner.invoke(app, ["size", str(robot), "-t", str(traj), "--json"])
    doc = json.loads(res.output)
    assert {p["check"] for p in doc["passed_on_assumed_values"]} == {"continuous", "peak",
                                                                      "voltage"}
    res = runner.invoke(app, ["size", str(robot), "-t", str(traj), "--strict", "--json"])
    assert res.exit_code == 1
    doc = json.loads(res.output)
    assert [j["status"] for j in doc["joints"]] == ["unknown"]
    assert doc["passed_on_assumed_values"] == []
    # a printed efficiency: nothing assumed, nothing to say
    robot, traj = _one_arm(tmp_path, "maxon_gp42c_43")
    res = runner.invoke(app, ["size", str(robot), "-t", str(traj), "--strict", "--json"])
    assert json.loads(res.output)["passed_on_assumed_values"] == []


def test_package_data_covers_the_data_files():
    """Every data file is under a package-data pattern of pyproject.toml, so a wheel
    carries the library (manipcad installs and runs without the source tree)."""
    import tomllib

    root = Path(__file__).resolve().parents[1]
    pats = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["manipcad"]
    pkg = root / "src" / "manipcad"
    for p in (pkg / "catalog" / "data").rglob("*"):
        if p.is_file():
            rel = p.relative_to(pkg).as_posix()
            assert any(fnmatch.fnmatch(rel, pat) for pat in pats), rel


def test_a_gear_file_may_say_its_efficiency_is_unknown(tmp_path):
    """``efficiency: unknown`` in a harmonic gear file: no assumption, nan in the drive,
    None in the listings (robots list, the library table)."""
    base = yaml.safe_load((DATA / "parts" / "gears" / "harmonic_csg14_100.yaml").read_text(
        encoding="utf-8"))
    ws = tmp_path / "ws"
    assert runner.invoke(app, ["ws", "init", str(ws)]).exit_code == 0
    p = tmp_path / "g.yaml"
    p.write_text(yaml.safe_dump(dict(base, efficiency="unknown")), encoding="utf-8")
    assert runner.invoke(app, ["ws", "add", str(p), "--ws", str(ws), "--name", "g"]).exit_code == 0
    res = runner.invoke(app, ["robots", "list", "--ws", str(ws), "--json"])
    assert res.exit_code == 0, res.output
    row = next(g for g in json.loads(res.output)["gears"] if g["name"] == "g")
    assert row["efficiency"] is None
    g = catalog.gears(ws=ws).loc["g"]
    assert math.isnan(g.efficiency) and g.efficiency_basis == "unknown"
    assert math.isnan(Drive(**catalog.drive_fields("MM_597974", catalog.part("g", ws=ws)))
                      .efficiency)
