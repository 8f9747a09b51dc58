"""Page logic of ``manipcad ui`` without a browser: what each page calls, its errors,
and the security checks (token gate, names, uploads). The browser flow is in
tests/test_ui_browser.py."""

from __future__ import annotations

import asyncio
import importlib
import warnings
from pathlib import Path

import numpy as np
import pytest

import manipcad
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.ui import logic
from manipcad.ui.security import TokenGate, is_loopback, token_for

GOOD_URDF = b"""<robot name="one">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1.0"/><origin xyz="0.1 0 0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
</robot>"""

ENTITY_URDF = b"""<?xml version="1.0"?>
<!DOCTYPE robot [<!ENTITY x SYSTEM "file:///etc/passwd">]>
<robot name="&x;"><link name="base"/></robot>"""


@pytest.fixture()
def ws(tmp_path):
    return logic.open_workspace(tmp_path / "ws")


@pytest.fixture(scope="module")
def puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot("puma560")


def _fake_jobs(monkeypatch, cls) -> None:
    """The pages' worker jobs replaced by ``cls`` (made from the spec, as SimulationJob)."""
    monkeypatch.setattr(importlib.import_module("manipcad.ui.pages.common"), "SimulationJob",
                        cls)


def test_robot_choices_and_joint_rows_carry_units(ws, puma):
    assert {"puma560", "cylindrical"} <= set(logic.robot_choices(ws))
    arm, notes = logic.load_robot_ref(ws, "puma560")
    assert arm.n == 6 and notes                      # the catalog's data notes are shown
    rows = logic.joint_rows(manipcad.load_robot("cylindrical"))
    assert [r["unit"] for r in rows] == ["rad", "m", "m"]
    assert rows[0]["motor"] == "maxon_re40_148877" and float(rows[0]["ratio"]) == -100.0
    assert logic.robot_totals(arm)["mass_kg"] == pytest.approx(float(np.sum(arm.mass)))


def test_stick_points_follow_the_kinematics(puma):
    from manipcad.kinematics.forward import frames, stick_points, tool_pose

    q = np.array([0.3, -0.5, 0.7, 0.1, 0.4, -0.2])
    segs = stick_points(puma, q)
    _, p = frames(puma, q[None])
    np.testing.assert_allclose(segs[0, 0], 0.0)
    np.testing.assert_allclose(segs[:-1, 1], p[0])
    np.testing.assert_allclose(segs[-1, 1], tool_pose(puma, q)[:3, 3])
    # a pose changes the figure: the tool moves by the kinematics, not by a redraw rule
    assert not np.allclose(stick_points(puma, np.zeros(6))[-1, 1], segs[-1, 1])


def test_stick_view_is_the_kinematics_seen_from_the_view(puma):
    """The Robots page's 3-D view (an orthographic projection drawn as SVG): the gripper's
    screen point is the forward kinematics' tool point in the viewer's frame, that frame
    built independently with scipy (Rz(azimuth)·Ry(-elevation): x towards the viewer,
    y right, z up); closed forms for the front and top views; equal scale."""
    from scipy.spatial.transform import Rotation

    from manipcad.kinematics.forward import frames, tool_pose
    from manipcad.report.projection import VIEW

    q = np.array([0.3, -0.5, 0.7, 0.1, 0.4, -0.2])
    tool = tool_pose(puma, q)[:3, 3]
    _, p = frames(puma, q[None])
    for az, el in ((0.0, 0.0), (*VIEW,), (1.1, -0.4), (-np.pi / 2, np.pi / 2),
                   (2.8, 1.2)):
        fig = logic.stick_view(puma, q, az, el)
        cam = Rotation.from_euler("ZY", [az, -el]).as_matrix().T     # base -> viewer
        grip = fig["data"][-1]
        assert grip["name"] == "gripper"
        seen = cam @ tool
        assert grip["x"][1] == pytest.approx(seen[1], abs=1e-12)
        assert grip["y"][1] == pytest.approx(seen[2], abs=1e-12)
        (arm,) = [t for t in fig["data"] if t["name"] == "arm"]   # every joint origin too
        ends = np.array([(x, y) for x, y in zip(arm["x"], arm["y"], strict=True)
                         if x is not None])
        np.testing.assert_allclose(ends[1::2], (p[0] @ cam.T)[:, 1:], atol=1e-12)
        assert arm["customdata"][1] == pytest.approx(list(p[0, 0]), abs=1e-15)
    front = logic.stick_view(puma, q, 0.0, 0.0)["data"][-1]        # from +x: (y, z)
    assert (front["x"][1], front["y"][1]) == pytest.approx((tool[1], tool[2]), abs=1e-12)
    top = logic.stick_view(puma, q, -np.pi / 2, np.pi / 2)["data"][-1]   # from +z: (x, y)
    assert (top["x"][1], top["y"][1]) == pytest.approx((tool[0], tool[1]), abs=1e-12)
    layout = logic.stick_view(puma, q)["layout"]
    assert layout["yaxis"]["scaleanchor"] == "x" and layout["yaxis"]["scaleratio"] == 1
    assert "[m]" in layout["xaxis"]["title"]["text"]
    # the pose sliders move it: another pose, another gripper point
    other = logic.stick_view(puma, np.zeros(6))["data"][-1]
    assert abs(other["x"][1] - logic.stick_view(puma, q)["data"][-1]["x"][1]) > 1e-3


def test_upload_adds_a_valid_urdf_and_names_the_file_of_a_bad_one(ws):
    item = logic.add_upload(ws, "one.urdf", GOOD_URDF, kind="robots")
    assert item.ref == "robots/one" and "robots/one" in logic.robot_choices(ws)
    assert logic.load_robot_ref(ws, "robots/one")[0].n == 1
    with pytest.raises(InputError, match=r"^broken\.urdf"):
        logic.add_upload(ws, "broken.urdf", b"<robot name='x'><link", kind="robots")
    with pytest.raises(ManipcadError, match="entit"):
        logic.add_upload(ws, "evil.urdf", ENTITY_URDF, kind="robots")
    with pytest.raises(InputError, match="larger than"):
        logic.add_upload(ws, "big.urdf", b" " * (logic.MAX_UPLOAD + 1), kind="robots")
    with pytest.raises(InputError, match="ends in"):
        logic.add_upload(ws, "x.exe", GOOD_URDF, kind="robots")
    for bad in ("../x", "/etc/passwd", ".hidden", "a/b"):
        with pytest.raises(InputError, match="name"):
            logic.add_upload(ws, "one.urdf", GOOD_URDF, kind="robots", name=bad)
    # the browser's file name is never a path: only its suffix and stem are used
    item = logic.add_upload(ws, "../../etc/two.urdf", GOOD_URDF, kind="robots")
    assert item.name == "two" and (ws.root / "robots" / "two.urdf").is_file()
    assert [i.name for i in ws.list("robots")] == ["one", "two"]   # nothing else added


def _lol(root: str, levels: int = 9) -> str:
    """The 'billion laughs' entity bomb: 10**levels copies of 'lol' from a few lines."""
    decl = '<!ENTITY l0 "lol">' + "".join(
        f'<!ENTITY l{k} "{f"&l{k - 1};" * 10}">' for k in range(1, levels + 1))
    return f'<?xml version="1.0"?>\n<!DOCTYPE {root} [{decl}]>\n'


MJCF = """<mujoco model="m"><worldbody><body name="b">
  <joint name="%s" type="hinge" axis="0 0 1"/>
  <inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/></body></worldbody></mujoco>"""


def test_xml_entities_are_never_expanded(ws, tmp_path):
    """URDF: ElementTree (expat) would expand an internal entity, and a billion-laughs bomb
    up to expat's amplification limit: any entity declaration is refused before it parses,
    through the loader (the CLI's path) and the upload. MJCF: MuJoCo's parser expands none
    (the text stays as written); an uploaded MJCF declaring one is refused too."""
    internal = GOOD_URDF.replace(b'name="one"', b'name="&x;"').replace(
        b"<robot", b'<!DOCTYPE robot [<!ENTITY x "expanded">]>\n<robot', 1)
    bomb = _lol("robot").encode() + GOOD_URDF.replace(b'name="one"', b'name="&l9;"')
    for name, text in (("internal.urdf", internal), ("lol.urdf", bomb),
                       ("evil.urdf", ENTITY_URDF)):
        with pytest.raises(InputError, match=rf"^{name}: declares the XML entity "):
            logic.add_upload(ws, name, text, kind="robots")
        path = tmp_path / name
        path.write_bytes(text)
        with pytest.raises(InputError, match="entity declarations are refused"):
            manipcad.load_robot(str(path))
        with pytest.raises(InputError, match="entity declarations are refused"):
            manipcad.load_robot(text)                        # URDF text
    assert logic.add_upload(ws, "plain.urdf", b"<!DOCTYPE robot>" + GOOD_URDF,
                            kind="robots").ref == "robots/plain"   # a bare DOCTYPE is fine
    # MJCF through MuJoCo (the CLI's path): the entity is not expanded
    mj = '<?xml version="1.0"?>\n<!DOCTYPE mujoco [<!ENTITY x "expanded">]>\n' + MJCF % "&x;"
    (tmp_path / "m.xml").write_text(mj)
    assert manipcad.load_robot(str(tmp_path / "m.xml")).joint_names == ("&x;",)
    for name, text in (("m.xml", mj), ("lol.mjcf", _lol("mujoco") + MJCF % "&l9;")):
        with pytest.raises(InputError, match=rf"^{name}: declares the XML entity "):
            logic.add_upload(ws, name, text.encode(), kind="robots")
    assert [i.name for i in ws.list("robots")] == ["plain"]


def test_uploaded_robot_files_must_stand_alone(ws, tmp_path):
    """An upload naming other files (a URDF, a motor or gear file by path, an MJCF
    include or mesh) would read them from outside the workspace: refused, naming the
    field; nothing added, nothing of the outside file stored."""
    secret = tmp_path / "outside"
    secret.mkdir()
    (secret / "arm.urdf").write_bytes(GOOD_URDF.replace(b"one", b"SECRET"))
    (secret / "motor.yaml").write_text("source: x\nJ: 1.234e-5\nR: 9.87\nL: 1e-4\n"
                                       "k_m: 0.05\nk_w: 0.05\n")
    dh = ("name: arm\njoints:\n  - name: j1\n    type: revolute\n"
          "    dh: {a: 0, alpha: 0, d: 0, theta: 0}\n"
          "    link: {mass: 1.0, com: [0.1, 0, 0], inertia: {ixx: 0.01, iyy: 0.01, izz: 0.01}}\n"
          "    drive: {motor: %s, ratio: 10}\n")
    cases = {
        "a.yaml": (f"name: a\nurdf: {secret}/arm.urdf\ndrives: {{}}\n", "urdf"),
        "b.yaml": ("name: b\nurdf: ../../outside/arm.urdf\ndrives: {}\n", "urdf"),
        "c.yaml": (dh % f"{secret}/motor.yaml", r"joints\[0\]\.drive\.motor"),
        "d.xml": (MJCF.replace("<worldbody>", f'<include file="{secret}/x.xml"/><worldbody>')
                  % "j", "include"),
        "e.mjcf": (MJCF.replace("<worldbody>", f'<asset><mesh name="m" file="{secret}/m.stl"/>'
                                "</asset><worldbody>") % "j", r"mesh\.file"),
    }
    for name, (text, field) in cases.items():
        with pytest.raises(InputError, match=rf"^{name}: {field}: names the file .*must "
                                             "stand alone"):
            logic.add_upload(ws, name, text.encode(), kind="robots")
    # a motor named as a catalog name that is a path is no catalog name (it read
    # outside/motor.yaml before)
    with pytest.raises(InputError, match=r"unknown motor '.*outside/motor'"):
        logic.add_upload(ws, "f.yaml", (dh % f"{secret}/motor").encode(), kind="robots")
    assert ws.list("robots") == []
    ok = logic.add_upload(ws, "g.yaml", (dh % "maxon_re40_148877").encode(), kind="robots")
    assert logic.load_robot_ref(ws, ok.ref)[0].drives[0].R == pytest.approx(
        manipcad.load_robot("cylindrical").drives[0].R)


def test_links_out_of_the_workspace_are_refused(ws, tmp_path):
    """An item whose file was replaced by a link leading outside is refused by every read
    the pages make (the robot, its file route's resolve)."""
    import os

    item = logic.add_upload(ws, "one.urdf", GOOD_URDF, kind="robots")
    outside = tmp_path / "outside.urdf"
    outside.write_bytes(GOOD_URDF.replace(b"one", b"other"))
    path = ws.path(item)
    path.unlink()
    os.symlink(outside, path)
    with pytest.raises(InputError, match="outside the workspace"):
        logic.load_robot_ref(ws, "robots/one")
    with pytest.raises(InputError, match="outside the workspace"):
        ws.resolve("robots", "one")
    # a study's report route lists and serves no link, even one to a report file
    study = tmp_path / "s"
    study.mkdir()
    (study / "report.html").write_text("<html>ok</html>")
    ws.add(study, kind="studies", name="s")
    os.symlink(outside, ws.path(ws.get("studies/s")) / "leak.html")
    assert logic.study_files(ws, "s") == ["report.html"]
    with pytest.raises(InputError, match="no such report"):
        logic.study_file(ws, "s", "leak.html")


def test_robot_refs_outside_the_workspace_are_refused(ws):
    for ref in ("robots/../../etc/passwd", "/etc/passwd", "trajectories/x", "robots/.x"):
        with pytest.raises(InputError):
            logic.load_robot_ref(ws, ref)


def test_trajectory_form_errors_name_the_field_then_save(ws, puma):
    with pytest.raises(InputError, match=r"trajectory form.*duration"):
        logic.make_trajectory({"type": "quintic", "q_start": [0.0] * 6, "q_end": [0.1] * 6,
                               "duration": "long"}, puma)
    with pytest.raises(InputError, match=r"trajectory form.*3 joints"):
        logic.make_trajectory({"type": "quintic", "q_start": [0.0] * 3, "q_end": [0.1] * 3,
                               "duration": 1.0}, puma)
    traj = logic.make_trajectory({"type": "cosine", "amplitude": [0.2] * 6,
                                  "omega": [3.0] * 6, "duration": 1.0}, puma)
    pv = logic.trajectory_preview(traj, puma, samples=11)
    q, _, _ = traj.sample(pv["t"])
    np.testing.assert_array_equal(pv["q"], q)
    assert pv["speed"].shape == (11,) and pv["speed"][5] > 0
    item = logic.save_trajectory_to(ws, traj, "move")
    back = logic.load_trajectory_ref(ws, item.name, puma)
    np.testing.assert_allclose(back.sample(pv["t"])[0], q, rtol=1e-12)
    with pytest.raises(InputError, match="taken|exists"):
        logic.save_trajectory_to(ws, traj, "move")
    with pytest.raises(InputError):
        logic.save_trajectory_to(ws, traj, "../move")


def test_recommendation_and_synthesis_are_the_apis(ws, puma):
    form = {"accuracy": 1e-3, "overshoot_allowed": False, "fast_action": True,
            "gripper_speed": "", "inductance": "negligible", "coupling": None,
            "parameter_variation": "slow",
            "transmission": {"backlash": False, "elasticity": False}}
    recs = logic.recommend_for(form, puma, None)
    direct = manipcad.recommend({k: v for k, v in form.items() if v not in (None, "")},
                                puma)
    assert recs.methods == direct.methods and recs.best.method == "asvs"
    assert recs.rule_texts                             # the rules that fired, in words
    with pytest.raises(InputError, match=r"requirements form.*accuracy"):
        logic.recommend_for({**form, "accuracy": -1.0}, puma)
    regs, item = logic.synthesize_to(ws, puma, "pid", spec={"bandwidth": 50.0}, name="pid")
    assert len(regs) == 6 and item.ref == "regulators/pid"
    ref = manipcad.synthesize(puma, "all", "pid", spec={"bandwidth": 50.0})
    np.testing.assert_array_equal(regs[0].params, ref[0].params)
    loaded = manipcad.load_regulators(ws.resolve("regulators", "pid"), puma)
    np.testing.assert_array_equal(loaded[3].params, ref[3].params)
    with pytest.raises(ManipcadError, match="unknown synthesis method"):
        logic.synthesize_to(ws, puma, "magic", name="m")


def test_token_rules():
    assert is_loopback("127.0.0.1") and is_loopback("::1") and not is_loopback("0.0.0.0")
    assert token_for("127.0.0.1", None) is None
    assert token_for("0.0.0.0", None) != token_for("0.0.0.0", None)   # generated each start
    assert token_for("0.0.0.0", "t") == "t"


def _call(gate, path: str, query: str = "", headers=()):
    sent = []

    async def send(msg):
        sent.append(msg)

    async def receive():
        return {"type": "http.request", "body": b""}

    scope = {"type": "http", "path": path, "query_string": query.encode(),
             "headers": list(headers)}
    asyncio.run(gate(scope, receive, send))
    return sent


def test_token_gate_refuses_requests_without_the_token():
    async def inner(scope, receive, send):
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": b"ok"})

    gate = TokenGate(inner, "tok")
    assert _call(gate, "/")[0]["status"] == 401
    assert _call(gate, "/", "token=bad")[0]["status"] == 401
    ok = _call(gate, "/", "token=tok")
    assert ok[0]["status"] == 200
    assert (b"set-cookie", b"manipcad_token=tok; Path=/; HttpOnly; SameSite=Strict") \
        in ok[0]["headers"]
    assert _call(gate, "/x", headers=[(b"cookie", b"a=b; manipcad_token=tok")])[0]["status"] \
        == 200
    assert _call(gate, "/x", headers=[(b"x-manipcad-token", b"tok")])[0]["status"] == 200
    assert _call(gate, "/x", headers=[(b"cookie", b"manipcad_token=nope")])[0]["status"] == 401

    closed = []

    async def send(msg):
        closed.append(msg)

    asyncio.run(gate({"type": "websocket", "path": "/_nicegui_ws", "query_string": b"",
                      "headers": []}, None, send))
    assert closed == [{"type": "websocket.close", "code": 1008}]


def _body_call(gate, chunks, headers=()):
    """Send a request with ``chunks`` as its body through ``gate``; (status, bytes read)."""
    sent, got = [], []
    queue = [{"type": "http.request", "body": c, "more_body": k < len(chunks) - 1}
             for k, c in enumerate(chunks)]

    async def inner(scope, receive, send):
        while True:
            msg = await receive()
            got.append(len(msg.get("body", b"")))
            if not msg.get("more_body"):
                break
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": b"ok"})

    async def receive():
        return queue.pop(0)

    async def send(msg):
        sent.append(msg)

    scope = {"type": "http", "method": "POST", "path": "/_nicegui/client/c/upload/1",
             "headers": list(headers)}
    asyncio.run(gate(inner)(scope, receive, send))
    return sent[0]["status"], sum(got)


def test_body_cap_refuses_large_uploads_before_reading_them():
    """The upload field's size limit is the browser's; the server's is BodyCap: a declared
    Content-Length above the cap gets 413 with nothing read, a body streamed without one is
    cut off once it passes the cap; a body within it passes whole."""
    from manipcad.ui.security import MULTIPART_SLACK, BodyCap

    def gate(app):
        return BodyCap(app, limit=1000)

    assert _body_call(gate, [b"x" * 600, b"x" * 400],
                      [(b"content-length", b"1000")]) == (200, 1000)
    assert _body_call(gate, [b"x" * 1001], [(b"content-length", b"1001")]) == (413, 0)
    assert _body_call(gate, [b"x"], [(b"content-length", b"nonsense")]) == (413, 0)
    status, read = _body_call(gate, [b"x" * 600] * 5)        # chunked: no Content-Length
    assert status == 413 and read == 600       # the chunk passing the cap never reaches it
    # serve() installs it with room for the largest upload and its multipart headers
    assert logic.MAX_UPLOAD < logic.MAX_UPLOAD + MULTIPART_SLACK <= 1.1 * logic.MAX_UPLOAD


def test_cli_ui_options_reach_the_server(monkeypatch, tmp_path):
    """``manipcad ui`` [--ws --port --host --open --token]: 127.0.0.1, port 8080, no
    browser and no token by default; each option reaches serve()."""
    from typer.testing import CliRunner

    import manipcad.ui
    from manipcad.cli.app import app

    calls = []
    monkeypatch.setattr(manipcad.ui, "serve", lambda ws, **kw: calls.append((ws, kw)))
    runner = CliRunner()
    assert runner.invoke(app, ["ui", "--ws", str(tmp_path / "a")]).exit_code == 0
    assert calls[-1] == (tmp_path / "a", {"host": "127.0.0.1", "port": 8080, "show": False,
                                          "token": None})
    res = runner.invoke(app, ["ui", "--ws", str(tmp_path / "b"), "--port", "9001", "--host",
                              "0.0.0.0", "--open", "--token", "t0k"])
    assert res.exit_code == 0, res.output
    assert calls[-1] == (tmp_path / "b", {"host": "0.0.0.0", "port": 9001, "show": True,
                                          "token": "t0k"})


def test_host_check_refuses_other_names_on_loopback():
    """On 127.0.0.1 without a token, a request naming another host (a page of another
    site whose name was pointed at 127.0.0.1: DNS rebinding) gets 403 and its websocket
    is closed; the loopback names pass, on any port (an SSH tunnel's)."""
    from manipcad.ui.security import HostCheck

    async def inner(scope, receive, send):
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": b"ok"})

    gate = HostCheck(inner)
    for host in (b"127.0.0.1:8080", b"localhost:9000", b"[::1]:8080", b"LOCALHOST",
                 b"127.0.0.2:80"):
        assert _call(gate, "/", headers=[(b"host", host)])[0]["status"] == 200, host
    for host in (b"evil.example:8080", b"evil.example", b"localhost.evil.example:8080",
                 b"0.0.0.0:8080", b"192.168.1.5:8080", b""):
        assert _call(gate, "/", headers=[(b"host", host)])[0]["status"] == 403, host
    assert _call(gate, "/")[0]["status"] == 403                  # no Host at all
    closed = []

    async def send(msg):
        closed.append(msg)

    asyncio.run(gate({"type": "websocket", "path": "/_nicegui_ws", "query_string": b"",
                      "headers": [(b"host", b"evil.example:8080")]}, None, send))
    assert closed == [{"type": "websocket.close", "code": 1008}]


def test_worker_runs_stores_and_cancels(ws):
    """The worker's run equals manipcad.simulate's; its voltage and power series give the
    run's own energy metric; one worker runs job after job, a cancel stops only the job
    it names and stores nothing. (The worker's body runs in this process here; the
    browser flow runs it in the worker process.)"""
    import queue

    from manipcad.store.results import load_result
    from manipcad.ui.worker import SimSpec, _work, run_spec

    arm = manipcad.load_robot("cylindrical")
    traj = logic.make_trajectory({"type": "quintic", "q_start": [0.0, 0.1, 0.1],
                                  "q_end": [0.3, 0.2, 0.2], "duration": 0.1}, arm)
    logic.save_trajectory_to(ws, traj, "move")
    regs, _ = logic.synthesize_to(ws, arm, "pid", name="pid")
    seen = []
    spec = SimSpec(str(ws.root), "cylindrical", "move", ["pid"], t_end=0.1, dt=1e-4,
                   name="r1")
    name, metrics = run_spec(spec, progress=seen.append)
    assert name == "r1" and seen and seen[-1] == pytest.approx(1.0)
    direct = manipcad.simulate(arm, t_end=0.1, dt=1e-4, trajectory=traj, regulators=regs)
    assert metrics["max_error"] == pytest.approx(
        max(m["max_error"] for m in direct.metrics.values()), rel=1e-12)

    folder = ws.path(ws.get("results/r1"))
    res, doc = load_result(folder)
    # the run is checked against every rating, as `manipcad simulate` checks it
    from manipcad.sim.checks import run_checks
    rows, verdict = logic.check_rows(ws, "r1")
    assert res.checks == run_checks(direct, arm).to_dict()
    assert {r["check"] for r in rows} >= {"saturation", "chattering", "current_rms"}
    assert verdict.split(":")[0] in ("PASS", "FAIL", "UNKNOWN")
    row = next(r for r in logic.result_rows(ws) if r["name"] == "r1")
    assert row["checks"].split(" ")[0] == verdict.split(":")[0].lower()
    ua = logic.result_series(res, "voltage", folder)
    k_u = np.array([d.k_u for d in arm.drives])
    u_max = np.array([d.u_max for d in arm.drives])
    np.testing.assert_array_equal(ua, np.clip(k_u * res.u, -u_max, u_max))
    p = logic.result_series(res, "power", folder)
    for j, jn in enumerate(res.joint_names):      # ∫ u_a·i dt is the run's energy metric
        assert np.trapezoid(p[:, j], res.t) == pytest.approx(doc["metrics"][jn]["energy"],
                                                             rel=1e-9, abs=1e-12)
    with pytest.raises(InputError, match="inputs/robot.yaml"):
        logic.result_series(res, "voltage", None)

    class Inbox:                                    # the pipe the jobs come through
        def __init__(self, *jobs):
            self.jobs = list(jobs)

        def recv(self):
            return self.jobs.pop(0)

    class Shared:                                   # multiprocessing.Value's interface
        value = 0

    def spec(name):
        return SimSpec(str(ws.root), "cylindrical", "move", ["pid"], t_end=0.1, dt=1e-4,
                       name=name)

    # one worker serves job after job until None; a cancel stops only the job it names
    out, cancel, done = queue.Queue(), Shared(), Shared()
    cancel.value = 7                                # job 7 cancelled before its first report
    _work(Inbox((7, spec("r2")), (8, spec("r3")), None), out, cancel, done)
    said = [out.get_nowait() for _ in range(out.qsize())]
    assert said[0][:2] == (7, "progress") and (7, "cancelled", "") in said
    assert said[-1][:3] == (8, "done", "r3") and done.value == 8
    assert [m[1] for m in said if m[0] == 7] == ["progress", "cancelled"]
    assert [i.name for i in ws.list("results")] == ["r1", "r3"]

    with pytest.raises(InputError, match="may not contain"):
        run_spec(SimSpec(str(ws.root), "cylindrical", "../move", ["pid"]))


def test_a_diverged_run_says_where_and_keeps_its_part_only_if_asked(ws):
    """A run that blows up (no regulator, a 2 ms step: the drives' electrical dynamics are
    unstable under RK4) reports the time and the drive whose step is too large; nothing
    is stored unless the page's "keep a diverged run's partial result" is ticked, then it
    is stored marked diverged, up to that time."""
    from manipcad.store.results import load_result
    from manipcad.ui.worker import SimSpec, run_spec

    arm = manipcad.load_robot("cylindrical")
    traj = logic.make_trajectory({"type": "quintic", "q_start": [0.0, 0.1, 0.1],
                                  "q_end": [0.3, 0.2, 0.2], "duration": 0.1}, arm)
    logic.save_trajectory_to(ws, traj, "move")
    spec = SimSpec(str(ws.root), "cylindrical", "move", [], t_end=0.1, dt=2e-3, name="blow")
    with pytest.raises(ManipcadError, match=r"diverged at t = ([0-9.]+) s: joint 'turn''s "
                       r"drive: the step dt = 0.002 s is too large .*; nothing was stored") \
            as err:
        run_spec(spec)
    d = arm.drives[0]                       # RK4 is stable for dt < 2.785·L/R
    assert 2e-3 > 2.785 * d.L / d.R
    assert ws.list("results") == []
    t_div = float(str(err.value).split("t = ")[1].split(" s")[0])
    spec.save_diverged = True
    with pytest.raises(ManipcadError, match="the partial result is blow"):
        run_spec(spec)
    (item,) = ws.list("results")
    assert item.name == "blow" and item.status == "diverged"
    res, doc = load_result(ws.path(item))
    assert res.t[-1] == pytest.approx(t_div, abs=2e-3) and res.t[-1] < 0.1


def test_regulators_of_several_methods_run_together(ws, tmp_path, monkeypatch):
    """Regulators synthesized per joint with different methods run in one simulation
    (the Simulation page's second regulator field): the run equals simulate() with both;
    two for one joint are refused; a result name taken is refused before the run."""
    from nicegui import ui

    from manipcad.ui.worker import SimSpec, run_spec

    arm = manipcad.load_robot("cylindrical")
    traj = logic.make_trajectory({"type": "quintic", "q_start": [0.0, 0.1, 0.1],
                                  "q_end": [0.3, 0.2, 0.2], "duration": 0.05}, arm)
    logic.save_trajectory_to(ws, traj, "move")
    a, _ = logic.synthesize_to(ws, arm, "pid", joints=["turn"], period=5e-4, name="a")
    b, _ = logic.synthesize_to(ws, arm, "lqr", joints=["lift", "reach"], period=1e-3, name="b")
    name, metrics = run_spec(SimSpec(str(ws.root), "cylindrical", "move", ["a", "b"],
                                     t_end=0.05, name="ab"))
    direct = manipcad.simulate(arm, t_end=0.05, dt=1e-4, trajectory=traj,
                               regulators=manipcad.load_regulators(ws.resolve(
                                   "regulators", "a"), arm) + manipcad.load_regulators(
                                   ws.resolve("regulators", "b"), arm), every=5)
    assert metrics["max_error"] == pytest.approx(
        max(m["max_error"] for m in direct.metrics.values()), rel=1e-12)
    logic.synthesize_to(ws, arm, "pid", joints=["lift"], name="c")
    with pytest.raises(ManipcadError, match=r"joint 'lift' already has a regulator in .*b\.yaml"):
        run_spec(SimSpec(str(ws.root), "cylindrical", "move", ["b", "c"], t_end=0.05))
    with pytest.raises(InputError, match="results/ab: name taken"):
        run_spec(SimSpec(str(ws.root), "cylindrical", "move", ["a"], t_end=0.05, name="ab"))
    # the page's stored run is the CLI's: `manipcad simulate --ws` of the same names
    from typer.testing import CliRunner

    from manipcad.cli.app import app
    from manipcad.store.results import SERIES, load_result

    cli = CliRunner().invoke(app, ["simulate", "cylindrical", "--trajectory", "move",
                                   "--regulator", "a", "--regulator", "b", "--t-end", "0.05",
                                   "--ws", str(ws.root), "--out", "cli"])
    assert cli.exit_code == 0, cli.output
    page, page_doc = load_result(ws.path(ws.get("results/ab")))
    ref, ref_doc = load_result(ws.path(ws.get("results/cli")))
    assert len(page.t) == 101                   # a sample per 0.5 ms regulator period
    for key in ("t", *SERIES):
        np.testing.assert_array_equal(getattr(page, key), getattr(ref, key), err_msg=key)
    assert page_doc["metrics"] == ref_doc["metrics"]

    started = []                       # the page hands both to the worker, each once

    class Job:                         # no worker process: the spec is all this checks
        fraction, finished = 0.0, False

        def __init__(self, spec):
            self.spec = spec
            started.append(spec)

        def poll(self):
            return "starting"

    _fake_jobs(monkeypatch, Job)

    async def script(user):
        await _open(user, "/simulation")
        _field(user, ui.select, "Regulator").value = "a"
        _field(user, ui.select, "and regulators").value = ["b", "a"]
        user.find("Simulate").click()
        await user.should_see("starting the worker")

    _simulate_user(ws.root, script)
    assert [s.regulators for s in started] == [["a", "b"]]


# ----------------------------------------------------------------- NiceGUI's simulated user
def _simulate_user(ws_dir, script) -> list[str]:
    """Run ``script(user)`` against the pages in NiceGUI's user simulation (no browser);
    returns the pages that asked for a worker process (none is started here: the
    browser flow starts them)."""
    from nicegui import ui
    from nicegui.testing.user_simulation import user_simulation

    from manipcad.ui import pages, worker

    asked: list[str] = []

    def prestart() -> None:
        asked.append(str(ui.context.client.page.path))

    async def main():
        pages.SERVER["ws"] = str(ws_dir)
        async with user_simulation(root=lambda: None) as user:
            pages.register()
            await script(user)

    # not asyncio.run: after a failing script, a task of the simulation does not end when
    # cancelled and asyncio.run waited for it for ever (the failure showed as a hang)
    loop = asyncio.new_event_loop()
    real, worker.prestart = worker.prestart, prestart
    try:
        loop.run_until_complete(main())
    finally:
        worker.prestart = real
        pending = asyncio.all_tasks(loop)
        for task in pending:
            task.cancel()
        if pending:
            loop.run_until_complete(asyncio.wait(pending, timeout=10))
        loop.close()
    return asked


async def _open(user, path: str) -> None:
    """Open a page and wait until it is built (pages build once their tab is connected)."""
    await user.open(path)
    await user.should_see(marker="page-title")


def _field(user, kind, label: str):
    """The one form field of ``kind`` whose label is ``label`` or starts with it."""
    (el,) = [e for e in user.find(kind=kind).elements
             if e.props.get("label") == label or (" " in label and str(
                 e.props.get("label", "")).startswith(label))]
    return el


async def _error(user) -> str:
    """The page's error line (once visible), as the designer reads it."""
    await user.should_see(marker="error")
    (lab,) = user.find(marker="error").elements
    assert lab.visible
    return lab.text


@pytest.mark.slow
def test_simulation_page_shows_why_a_run_failed(tmp_path, monkeypatch):
    """The worker's failure message (diverged at t, joint) is the page's error line."""
    from nicegui import ui


    ws = logic.open_workspace(tmp_path / "ws")
    arm = manipcad.load_robot("puma560")
    logic.save_trajectory_to(ws, logic.make_trajectory(
        {"type": "quintic", "q_start": [0.0] * 6, "q_end": [0.1] * 6, "duration": 0.1}, arm),
        "move")
    why = "simulation diverged at t = 0.012 s: speed above 1e4 rad/s (m/s) at joint 'elbow'; " \
          "nothing was stored"

    class Failed:                      # what SimulationJob reports after such a run
        fraction, finished, message = 0.4, True, why

        def __init__(self, spec):
            self.spec = spec

        def poll(self):
            return "error"

    _fake_jobs(monkeypatch, Failed)

    async def script(user):
        await _open(user, "/simulation")
        user.find(kind=ui.input, content="dt").clear().type("abc")
        user.find("Simulate").click()
        assert (await _error(user)).startswith("simulation form: dt: expected numbers")
        user.find(kind=ui.input, content="dt").clear().type("1e-4")
        user.find("Simulate").click()
        await user.should_see(why, retries=50)         # the page polls its job 4 times a s
        (lab,) = user.find(marker="error").elements
        assert lab.text == why and lab.visible

    _simulate_user(tmp_path / "ws", script)


def test_simulation_page_cancel_reaches_the_running_job(tmp_path, monkeypatch):
    """The page's Cancel asks the running job to stop and shows it stopped (the worker's
    own cancel, nothing stored, is test_worker_runs_stores_and_cancels)."""


    ws = logic.open_workspace(tmp_path / "ws")
    arm = manipcad.load_robot("puma560")
    logic.save_trajectory_to(ws, logic.make_trajectory(
        {"type": "quintic", "q_start": [0.0] * 6, "q_end": [0.1] * 6, "duration": 0.1}, arm),
        "move")
    made = []

    class Running:                     # a SimulationJob that runs until it is cancelled
        message, wall = "", 0.0

        def __init__(self, spec):
            self.spec, self.fraction, self.finished, self.asked = spec, 0.3, False, 0
            made.append(self)

        def cancel(self):
            self.asked += 1

        def poll(self):
            if self.asked:
                self.finished = True
                return "cancelled"
            return "running"

    _fake_jobs(monkeypatch, Running)

    async def script(user):
        await _open(user, "/simulation")
        user.find("Simulate").click()
        await user.should_see("running: 30 %", retries=50)
        user.find("Cancel").click()
        await user.should_see("cancelled", retries=50)
        assert len(made) == 1 and made[0].asked == 1 and made[0].spec.trajectory == "move"

    _simulate_user(tmp_path / "ws", script)


@pytest.mark.slow
def test_pages_in_the_simulated_user(tmp_path):
    """Each page's errors name form, field and reason; the Trajectories page makes and saves
    laws (2), via points, a gripper line and a gripper circle."""
    from nicegui import ui

    from manipcad.ui import pages

    async def script(user):
        await _open(user, "/")
        await user.should_see("Requirements → method")
        await _open(user, "/trajectories")
        user.find(kind=ui.input, content="duration").clear().type("abc")
        user.find("Preview").click()
        assert (await _error(user)).startswith("trajectory form: duration")   # field and reason
        user.find(kind=ui.input, content="duration").clear().type("1.0")
        user.find("Save to workspace").click()
        await user.should_see("saved trajectories/move")
        await _open(user, "/requirements")
        user.find("Recommend").click()
        await user.should_see("Recommended, best first: asvs")
        await user.should_see("Rules that fired")
        await _open(user, "/synthesis")
        user.find(kind=ui.input, content="spec").type("bandwidth=-3")
        user.find("Synthesize and save").click()
        # ASVS preselected: its spec has no bandwidth
        assert (await _error(user)).startswith("unknown spec keys ['bandwidth']")
        await _open(user, "/results")
        user.find(kind=ui.input, content="filter").type("max_errr<1")
        user.find("Filter").click()
        assert "unknown metric 'max_errr'" in await _error(user)

        # via points, a gripper line and a gripper circle (schema + inverse kinematics)
        await _open(user, "/trajectories")
        law = _field(user, ui.select, "Law")
        forms = {"quin": ("quintic", {"start per joint": "0", "end per joint": "0.2",
                                      "duration": "1"}),
                 "trap": ("trapezoidal", {"start per joint": "0",
                                          "end per joint": "0.5, 0.4, 0.3, 0.2, 0.1, 0",
                                          "max speed": "1", "max acceleration": "4"}),
                 "via": ("spline", {"times of the via": "0, 0.5, 1",
                                    "one row per time": "0; 0.2; 0.1"}),
                 "line": ("line", {"start pose": "0, -0.5, 0.5, 0, 0.5, 0",
                                   "displacement": "0.05, 0, 0"}),
                 "circle": ("circle", {"start pose": "0, -0.5, 0.5, 0, 0.5, 0",
                                       "centre from": "0, 0.05, 0", "radius": "0.05",
                                       "normal": "1, 0, 0", "angle": "3.14159",
                                       "duration": "1"})}
        for name, (kind, fields) in forms.items():
            law.value = kind
            for label, text in {**fields, "Name": name}.items():
                user.find(kind=ui.input, content=label).clear().type(text)
            user.find("Save to workspace").click()
            await user.should_see(f"saved trajectories/{name}")
        with user:
            assert pages.state()["trajectory"] == "circle"      # this tab's current one

    asked = _simulate_user(tmp_path / "ws", script)
    # the pages that run jobs (and only those) have a worker process started when opened
    assert sorted(set(asked)) == ["/requirements", "/results"], asked
    # the line's tool path is straight and moves by the displacement; the circle's tool
    # stays on its circle
    ws = logic.open_workspace(tmp_path / "ws")
    arm = manipcad.load_robot("puma560")
    quin = logic.load_trajectory_ref(ws, "quin", arm)           # the laws of the form
    np.testing.assert_allclose(quin.sample(np.array([0.0, 1.0]))[0], [[0.0] * 6, [0.2] * 6],
                               atol=1e-12)
    trap = logic.load_trajectory_ref(ws, "trap", arm)
    q, qd, qdd = trap.sample(np.linspace(0.0, trap.duration, 2001))
    np.testing.assert_allclose(q[-1], [0.5, 0.4, 0.3, 0.2, 0.1, 0.0], atol=1e-12)
    assert np.abs(qd).max() <= 1.0 + 1e-9 and np.abs(qdd).max() <= 4.0 + 1e-9
    assert np.abs(qd[:, 0]).max() == pytest.approx(1.0)         # the longest move cruises
    via = logic.load_trajectory_ref(ws, "via", arm)
    np.testing.assert_allclose(via.sample(np.array([0.5]))[0][0], [0.2] * 6, atol=1e-12)
    line = logic.load_trajectory_ref(ws, "line", arm)
    q0 = [0, -0.5, 0.5, 0, 0.5, 0]
    q, _, _ = line.sample(np.linspace(0.0, 1.0, 11))
    p = np.array([logic.tool_position(arm, qk) for qk in q])
    np.testing.assert_allclose(p[0], logic.tool_position(arm, q0), atol=1e-6)
    np.testing.assert_allclose(p[-1] - p[0], [0.05, 0, 0], atol=1e-6)
    # the circle: every tool point at 0.05 m from the centre, in the plane x = x0
    circ = logic.load_trajectory_ref(ws, "circle", arm)
    q, _, _ = circ.sample(np.linspace(0.0, 1.0, 11))
    p = np.array([logic.tool_position(arm, qk) for qk in q])
    centre = logic.tool_position(arm, q0) + [0, 0.05, 0]
    np.testing.assert_allclose(np.linalg.norm(p - centre, axis=1), 0.05, atol=1e-6)
    np.testing.assert_allclose(p[:, 0], centre[0], atol=1e-6)
    np.testing.assert_allclose(p[-1], 2 * centre - p[0], atol=1e-4)     # half a turn


@pytest.mark.slow
def test_drives_and_identification_are_the_apis(puma):
    from pathlib import Path

    from manipcad.dynamics.identification import load_torque_data

    traj = logic.make_trajectory({"type": "cosine", "amplitude": [0.2] * 6,
                                  "omega": [3.0] * 6, "duration": 1.0}, puma)
    req = manipcad.required_drive(puma, traj)
    rows = logic.drive_rows(req)
    assert [r["joint"] for r in rows] == list(puma.joint_names)
    assert float(rows[1]["peak_torque"]) == pytest.approx(req.peak_torque[1], rel=1e-3)
    assert logic.torque_speed_png(req)[:8] == b"\x89PNG\r\n\x1a\n"

    csv = Path(__file__).resolve().parents[1] / "examples" / "identify_puma.csv"
    est = logic.identify_upload(puma, "measured.csv", csv.read_bytes(), com=[0, 0, 0.08])
    d = load_torque_data(csv, puma)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        ref = manipcad.identify_payload(puma, d.q, d.qd, d.qdd, t=d.t, tau=d.tau,
                                        com=[0, 0, 0.08])
    assert est.mass == ref.mass and est.std == ref.std
    with pytest.raises(InputError, match=r"^bad\.csv"):
        logic.identify_upload(puma, "bad.csv", b"t,q1\n0,0\n", com=None)
    with pytest.raises(InputError, match="csv"):
        logic.identify_upload(puma, "x.txt", csv.read_bytes())


def test_trajectory_upload_is_validated(ws, puma):
    good = b"type: quintic\nq_start: [0, 0, 0, 0, 0, 0]\nq_end: [0.1, 0.1, 0.1, 0, 0, 0]\n" \
           b"duration: 1.0\n"
    item = logic.add_upload(ws, "move.yaml", good, kind="trajectories", robot=puma)
    assert logic.load_trajectory_ref(ws, item.name, puma).duration == 1.0
    with pytest.raises(InputError, match=r"^bad\.yaml.*duration"):
        logic.add_upload(ws, "bad.yaml", good.replace(b"1.0", b"-1.0"), kind="trajectories",
                         robot=puma)


def test_study_reports_are_served_only_from_the_study(ws, tmp_path):
    study = tmp_path / "fig3"
    study.mkdir()
    (study / "fig3.html").write_text("<html>report</html>")
    (study / "fig3.png").write_bytes(b"\x89PNG")
    (study / "notes.sh").write_text("echo")
    (study / "sub").mkdir()
    (study / "sub" / "x.html").write_text("x")
    ws.add(study, kind="studies", name="fig3")
    assert logic.study_files(ws, "fig3") == ["fig3.html", "fig3.png"]
    assert logic.study_file(ws, "fig3", "fig3.html").read_text() == "<html>report</html>"
    for name, file in (("fig3", "notes.sh"), ("fig3", "sub/x.html"), ("fig3", "../fig3.png"),
                       ("../results", "fig3.html"), ("nothing", "fig3.html")):
        with pytest.raises(InputError):
            logic.study_file(ws, name, file)


def test_verify_by_simulation_from_names(ws, puma):
    """The page's "verify by simulation" (a VerifySpec run in the worker process, by names)
    equals recommend(..., verify=True); a bad name is the API's error. (Run in this process
    here; the browser flow runs it in the worker.)"""
    from manipcad.ui.worker import VerifySpec

    form = {"accuracy": 1e-3, "overshoot_allowed": False, "fast_action": True,
            "inductance": "negligible", "parameter_variation": "slow",
            "transmission": {"backlash": False, "elasticity": False}}
    traj = logic.make_trajectory({"type": "quintic", "q_start": [0.0] * 6,
                                  "q_end": [0.1] * 6, "duration": 0.05}, puma)
    logic.save_trajectory_to(ws, traj, "short")
    name, doc = VerifySpec(str(ws.root), "puma560", "short", form).run()
    direct = manipcad.recommend(form, puma, traj, verify=True)
    assert name == "verified" and doc["verified"]
    assert [r["method"] for r in doc["recommendations"]] == direct.methods
    assert doc["recommendations"][0]["max_error"] == direct[0].max_error
    with pytest.raises(InputError, match="may not contain"):
        VerifySpec(str(ws.root), "puma560", "../short", form).run()


# ----------------------------------------------------------------- drives, libraries, studies
def test_motor_and_gear_libraries_and_attach(ws):
    """Own motors and gears are validated by the motor/gear file loader; attaching a catalog
    motor + gear composes the drive as a robot file naming them does."""
    from manipcad.model.yaml_robot import load_motor

    rows = {r["ref"]: r for r in logic.library_rows(ws, "motors")}
    re40 = load_motor("maxon_re40_148877")
    assert rows["maxon_re40_148877"]["origin"] == "catalog"
    assert float(rows["maxon_re40_148877"]["R"]) == pytest.approx(re40.R, rel=1e-3)
    good = {"J": 1e-5, "R": 1.2, "L": 2e-4, "k_m": 0.05, "k_w": 0.05, "M_f": [0.01, 0.02],
            "rated_torque": 0.2, "rated_voltage": 24.0}
    with pytest.raises(InputError, match=r"^motors/bad: J: must be >= 0"):
        logic.add_part(ws, "motors", "bad", {**good, "J": -1.0}, source="sheet")
    with pytest.raises(InputError, match=r"^motors/bad: k_m: required field is missing"):
        logic.add_part(ws, "motors", "bad", {k: v for k, v in good.items() if k != "k_m"},
                       source="sheet")
    with pytest.raises(InputError, match=r"^gears/g: type: unknown value 'worm'"):
        logic.add_part(ws, "gears", "g", {"type": "worm", "ratio": 10.0}, source="sheet")
    assert ws.list("motors") == [] and ws.list("gears") == []          # nothing half-saved
    logic.add_part(ws, "motors", "mine", good, source="sheet")
    logic.add_part(ws, "gears", "g10", {"type": "planetary", "ratio": 10.0, "J": 1e-6,
                                        "efficiency": 0.9}, source="sheet")
    mine = [r for r in logic.library_rows(ws, "motors") if r["ref"] == "motors/mine"]
    assert mine and mine[0]["origin"] == "workspace" and mine[0]["M_f"] == "0.01, 0.02"

    cyl = manipcad.load_robot("cylindrical")          # turn: RE 40 + CSF-17-100 in its file
    arm, item = logic.attach_drive(ws, cyl.replace(drives=(None, *cyl.drives[1:])), "turn",
                                   "maxon_re40_148877", ["harmonic_csf17_100"], name="cyl")
    d, ref = arm.drives[0], cyl.drives[0]
    for key in ("J", "ratio", "R", "L", "k_m", "k_w", "k_v", "M_f", "u_max", "efficiency",
                "gear_rated_torque", "gear_peak_torque", "rated_torque", "max_speed"):
        assert getattr(d, key) == pytest.approx(getattr(ref, key), rel=1e-12), key
    back = logic.load_robot_ref(ws, item.ref)[0].drives[0]
    assert back.J == d.J and back.name == "maxon_re40_148877"
    own, _ = logic.attach_drive(ws, arm, 1, "motors/mine", ["gears/g10"], name="cyl2")
    assert own.drives[1].ratio == 10.0 and own.drives[1].J == pytest.approx(1e-5 + 1e-6)
    assert own.drives[1].efficiency == 0.9 and own.drives[0] == d
    for bad in (("nope", []), ("maxon_re40_148877", ["gears/../x"]), ("motors/none", [])):
        with pytest.raises(InputError):
            logic.attach_drive(ws, arm, 0, *bad, name="x")
    with pytest.raises(InputError, match="joint"):
        logic.attach_drive(ws, arm, "elbow", "maxon_re40_148877", [], name="x")
    assert sorted(i.name for i in ws.list("robots")) == ["cyl", "cyl2"]


def test_drive_series_ratio_sweep_and_gain_table(puma):
    """The Drives figures plot required_drive's series against the motors' limits; the
    sweep is ratio_sweep on the form's grid; the LQR-GS plot is the regulator's table."""
    from manipcad.sizing import ratio_sweep
    from manipcad.sizing.limits import voltage_limit

    traj = logic.make_trajectory({"type": "cosine", "amplitude": [0.2] * 6,
                                  "omega": [3.0] * 6, "duration": 0.5}, puma)
    req = manipcad.required_drive(puma, traj)
    figs = logic.required_series_figures(req)
    cur = [tr for tr in figs["current"].data if tr.name == "shoulder"][0]
    np.testing.assert_array_equal(cur.y, req.current[:, 1])
    vlim = [tr for tr in figs["voltage"].data if tr.name.startswith("shoulder voltage limit")]
    assert vlim and vlim[0].y[0] == voltage_limit(puma.drives[1])
    pw = [tr for tr in figs["power"].data if tr.name == "elbow"][0]
    np.testing.assert_array_equal(pw.y, req.elec_power[:, 2])

    sw = logic.ratio_sweep_for(puma, traj, "shoulder", 10.0, 1000.0, 50)
    ref = ratio_sweep(puma, traj, 1, np.geomspace(10.0, 1000.0, 50))
    assert sw.intervals == ref.intervals and sw.best_ratio == ref.best_ratio
    assert logic.ratio_sweep_png(sw)[:4] == b"\x89PNG"
    with pytest.raises(InputError, match="sweep form: ratios"):
        logic.ratio_sweep_for(puma, traj, "shoulder", 100.0, 10.0, 50)

    cyl = manipcad.load_robot("cylindrical")
    reg = manipcad.synthesize(cyl, "turn", "lqr_gs", grid=(4, 2), h_range=(-1.0, 1.0))
    table = reg.design["table"]
    fig = logic.gain_table_figure(reg)
    assert len(fig.data) == 3 * 2                       # 3 gains × 2 h_i lines
    np.testing.assert_array_equal(fig.data[0].x, table.H)
    np.testing.assert_array_equal(fig.data[5].y, table.gains[:, 1, 2])   # D_i at h_1
    assert logic.gain_table_figure(manipcad.synthesize(cyl, "turn", "pid")) is None


def test_study_runs_through_the_study_functions(ws):
    """A study from the page: run_fig3 into studies/NAME with the page's progress; bad
    names and methods are refused with the study functions' own messages."""
    from manipcad.ui.worker import StudySpec

    seen = []
    name, info = StudySpec(str(ws.root), "fig3", "f3", t_end=0.02, methods="none").run(
        seen.append)
    assert name == "f3" and "report.html" in info["files"] and seen[-1] == 1.0
    assert "report.html" in logic.study_files(ws, "f3")
    with pytest.raises(InputError, match="may not contain"):
        StudySpec(str(ws.root), "fig3", "../f3").run()
    with pytest.raises(InputError, match="unknown study method"):
        StudySpec(str(ws.root), "fig3", "g", methods="magic").run()
    with pytest.raises(InputError, match="studies/f3: name taken"):
        StudySpec(str(ws.root), "fig3", "f3").run()
    with pytest.raises(InputError, match="study form: study"):
        StudySpec(str(ws.root), "robustness", "r").run()
    assert [i.name for i in ws.list("studies")] == ["f3"]
    # the claims maps report through run_tasks, which takes the same progress callable
    from manipcad.parallel import run_tasks

    frac = []
    assert list(run_tasks(pow, [{"base": 2, "exp": 3}, {"base": 3, "exp": 2}], workers=1,
                          progress=frac.append)) == [8, 9]
    assert frac == [0.5, 1.0]


@pytest.mark.slow
def test_drives_page_and_two_tabs_in_the_simulated_user(tmp_path):
    """The Drives page adds a motor (bad value: its error), attaches it, computes the
    requirement figures and the sweep; Synthesis draws an LQR-GS table; a second tab keeps
    its own robot and trajectory."""
    from nicegui import ui
    from nicegui.testing.user import User

    from manipcad.ui import pages

    async def script(user):
        await _open(user, "/trajectories")
        user.find(kind=ui.input, content="duration").clear().type("0.5")
        user.find("Save to workspace").click()
        await user.should_see("saved trajectories/move")
        await _open(user, "/drives")
        user.find("Add your own motor").click()
        for key, text in {"motor name": "m1", "rotor inertia": "-1e-5",
                          "armature resistance": "1.2", "armature inductance": "2e-4",
                          "torque constant": "0.3", "back-EMF constant": "0.3",
                          "rated (continuous)": "2", "rated voltage": "48",
                          "max speed": "400"}.items():
            _field(user, ui.input, key).value = text
        user.find("Save the motor").click()
        assert (await _error(user)).startswith("motors/m1: J: must be >= 0")
        _field(user, ui.input, "rotor inertia").value = "1e-5"
        user.find("Save the motor").click()
        await user.should_see("added motors/m1")
        _field(user, ui.select, "joint").value = "elbow"
        _field(user, ui.select, "motor").value = "motors/m1"
        user.find(kind=ui.button, content="Attach").click()
        await user.should_see("saved robots/puma560-drives")
        with user:
            assert pages.state()["robot"] == "robots/puma560-drives"
        user.find("Compute the drive requirements").click()
        await user.should_see(marker="page-title")
        assert len(user.find(kind=ui.plotly).elements) == 3      # current, voltage, power
        _field(user, ui.input, "joint (name").value = "elbow"
        user.find("Sweep the ratio").click()
        await user.should_see("feasible |i_r|")
        await _open(user, "/synthesis")
        _field(user, ui.select, "Method").value = "lqr_gs"
        _field(user, ui.input, "joints (names").value = "1"
        user.find("Synthesize and save").click()
        await user.should_see("saved regulators/lqr_gs-puma560-drives", retries=100)
        assert user.find(kind=ui.plotly).elements                   # the gain table

        other = User(user.http_client)                            # a second tab
        await _open(other, "/drives")
        with other:
            assert pages.state()["robot"] == "puma560" and pages.state()["trajectory"] is None
        other.find("Compute the drive requirements").click()
        assert "pick or make a trajectory" in await _error(other)
        with user:
            assert pages.state()["robot"] == "robots/puma560-drives"

    _simulate_user(tmp_path / "ws", script)
    arm = logic.load_robot_ref(logic.open_workspace(tmp_path / "ws"),
                               "robots/puma560-drives")[0]
    assert arm.drives[2].name == "motors/m1" and arm.drives[2].k_m == 0.3


def test_a_page_whose_browser_never_connects_ends_quietly(tmp_path):
    """A plain GET (or a tab left while loading) never connects its websocket; NiceGUI
    deletes its client after a while, and the page being built must then end cancelled,
    not read the deleted tab's state (a RuntimeError traceback in the server log)."""
    from nicegui import Client, ui
    from starlette.requests import Request

    from manipcad.ui.pages import common

    async def script(user):
        get = Request({"type": "http", "method": "GET", "path": "/", "headers": [],
                       "query_string": b""})
        client = Client(ui.page("/never-connected"), request=get)

        async def build():
            with client:
                return await common.connected()

        task = asyncio.create_task(build())
        await asyncio.sleep(0.05)
        assert not task.done()                     # waiting for the browser
        client.delete()                            # what NiceGUI's pruning does
        with pytest.raises(asyncio.CancelledError):
            await task

    _simulate_user(tmp_path / "ws", script)


def _stored_puma_result(ws, name: str, mass: float, com) -> None:
    """A stored result of the PUMA carrying ``mass`` kg at ``com`` (last link's frame):
    a smooth motion with no reversal (each joint speeding up) sampled every 0.5 ms, the
    joint torques its inverse dynamics needs (drive terms included)."""
    from manipcad.sim import SimulationResult

    arm = manipcad.load_robot("puma560")
    t = np.linspace(0.0, 2.0, 4001)
    a, b = 0.1 * np.arange(1, 7), 0.2 + 0.05 * np.arange(1, 7)
    q, qd = np.outer(t**2, a) + np.outer(t, b) - 0.5, 2 * np.outer(t, a) + b
    tau = manipcad.inverse_dynamics(arm.with_payload(mass, com), q, qd,
                                    np.tile(2 * a, (t.size, 1)))
    z = np.zeros_like(q)
    ws.store_result(SimulationResult(t, q, qd, q, qd, z, z + np.nan, tau, arm.joint_names,
                                     robot=arm.name, joint_types=arm.joint_types),
                    name=name, plot=False)


def test_identification_page_takes_a_stored_result(tmp_path):
    """The Identification page identifies the payload from a stored simulation result (its
    recorded q, q̇ and torques): 1.5 kg back from torques made with 1.5 kg; a result of
    other joints is refused naming them."""
    from nicegui import ui

    ws = logic.open_workspace(tmp_path / "ws")
    _stored_puma_result(ws, "loaded", 1.5, [0.0, 0.0, 0.08])

    async def script(user):
        await _open(user, "/identification")
        user.find(kind=ui.input, content="centre of mass").clear().type("0, 0, 0.08")
        assert _field(user, ui.select, "or a stored simulation result").value == "loaded"
        user.find("Identify from the result").click()
        await user.should_see("payload mass m_r", retries=100)
        (lab,) = user.find(kind=ui.label, content="payload mass m_r").elements
        mass = float(lab.text.split("=")[1].split("±")[0])
        assert mass == pytest.approx(1.5, rel=1e-3), lab.text
        with user:
            from manipcad.ui import pages
            pages.state()["robot"] = "cylindrical"
        user.find("Identify from the result").click()
        assert "are not the robot's" in await _error(user)

    _simulate_user(tmp_path / "ws", script)


def test_robots_page_pose_is_within_the_limits_and_notes_show_no_paths(ws, tmp_path):
    """The Robots page opens each robot at a pose within its joint limits (0 where 0 is
    within them, else the middle: the Stanford arm's reach 0.3..1.27 m); its notes and error
    lines name workspace files by their item path and package files as manipcad/...,
    never an absolute path."""
    from manipcad.model import catalog_names
    from manipcad.ui.pages import SERVER
    from manipcad.ui.pages.common import error_text

    for name in catalog_names():
        arm = logic.load_robot_ref(ws, name)[0]
        q = logic.start_pose(arm)
        lo, hi = arm.limits.T
        assert np.all((lo <= q) & (q <= hi)), name
        assert np.all(q[(lo <= 0) & (hi >= 0)] == 0), name
    stanford = logic.load_robot_ref(ws, "stanford")[0]
    assert logic.start_pose(stanford)[2] == pytest.approx(np.mean(stanford.limits[2]))
    mimic = GOOD_URDF.replace(b"</robot>", b"""<link name="tip"><inertial><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="j2" type="revolute"><parent link="arm"/><child link="tip"/>
      <axis xyz="0 0 1"/><limit lower="0.5" upper="2" effort="10" velocity="1"/>
      <mimic joint="j1"/></joint></robot>""")
    logic.add_upload(ws, "mim.urdf", mimic, kind="robots")
    arm, notes = logic.load_robot_ref(ws, "robots/mim")
    assert logic.start_pose(arm).tolist() == [0.0, 1.25]
    assert notes and notes[0].startswith("robots/mim.urdf: joint 'j2' mimics 'j1'"), notes
    assert not any(str(ws.root.resolve()) in n or str(tmp_path) in n for n in notes)
    package = Path(manipcad.__file__).resolve().parent
    SERVER["ws"] = str(ws.root)
    err = InputError(str(package / "model" / "catalog" / "x.yaml"), "joints[0].mass", "bad")
    assert error_text(err) == "manipcad/model/catalog/x.yaml: joints[0].mass: bad"
    err = InputError(str(ws.root / "trajectories" / "m.yaml"), "type", "bad")
    assert error_text(err) == "trajectories/m.yaml: type: bad"


def test_a_jobs_warnings_reach_its_page(monkeypatch):
    """The worker passes a run's ManipcadWarnings to the job as notes (each once; they
    used to reach only the server's log, with an install path), the job keeps them, and
    the pages show them as "note: ..." lines."""
    import queue as queues
    import types

    from manipcad.ui import worker

    class Spec:
        def run(self, progress):
            for _ in range(3):
                warnings.warn("joint 'lift' beyond its limits by 1.7e-05 m", ManipcadWarning,
                              stacklevel=1)
            return "s1", {"files": []}

    class Inbox:
        def __init__(self):
            self.msgs = [(7, Spec()), None]

        def recv(self):
            return self.msgs.pop(0)

    out = queues.Queue()
    monkeypatch.setattr(worker, "_warm", lambda: None)
    worker._work(Inbox(), out, types.SimpleNamespace(value=0), types.SimpleNamespace(value=0))
    said = [out.get_nowait() for _ in range(out.qsize())]
    assert said == [(7, "note", "joint 'lift' beyond its limits by 1.7e-05 m"),
                    (7, "done", "s1", {"files": []})]
    job = worker.SimulationJob.__new__(worker.SimulationJob)     # its bookkeeping alone
    job.number, job.state, job.notes = 7, "running", []
    job._worker = types.SimpleNamespace(read=lambda number: [m[1:] for m in said])
    job._take_messages()
    assert job.state == "done" and job.notes == [said[0][2]]


def test_a_studys_notes_are_shown_on_its_page(tmp_path, monkeypatch):
    """A finished study's notes (its run's warnings) are caption lines on the page."""
    from nicegui import ui


    class Done:                        # what SimulationJob reports after such a study
        fraction, finished, result, wall = 1.0, True, "fig3", 1.0
        metrics = {"files": []}
        notes = ["cylindrical arm: joint 'lift' beyond its limits by up to 1.68e-05 m"]

        def __init__(self, spec):
            self.spec = spec

        def poll(self):
            return "done"

    _fake_jobs(monkeypatch, Done)

    async def script(user):
        await _open(user, "/results")
        user.find("Run the study").click()
        await user.should_see("note: cylindrical arm: joint 'lift' beyond its limits",
                              retries=50)
        assert [e.text for e in user.find(kind=ui.label, content="note:").elements] == \
            [f"note: {Done.notes[0]}"]

    _simulate_user(tmp_path / "ws", script)


def test_a_request_cut_short_by_the_browser_ends_quietly():
    """A page left while its files load: the file response sees the browser's disconnect
    and sends nothing, and starlette's middlewares raise "No response returned." (one
    traceback in the server's log per cut request). QuietDisconnect ends exactly that
    case quietly; the same error for a client still there, or any other error, goes on."""
    from manipcad.ui.security import NO_RESPONSE, QuietDisconnect

    def app(error, disconnect: bool):
        async def inner(scope, receive, send):
            await receive()
            raise error
        messages = [{"type": "http.disconnect" if disconnect else "http.request",
                     "body": b""}]

        async def receive():
            return messages[0]

        async def send(message):
            raise AssertionError("nothing is sent")

        return QuietDisconnect(inner)({"type": "http"}, receive, send)

    assert asyncio.run(app(RuntimeError(NO_RESPONSE), disconnect=True)) is None
    with pytest.raises(RuntimeError, match=NO_RESPONSE):
        asyncio.run(app(RuntimeError(NO_RESPONSE), disconnect=False))
    with pytest.raises(ValueError):
        asyncio.run(app(ValueError("bad"), disconnect=True))
