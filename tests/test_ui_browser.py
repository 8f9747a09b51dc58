"""``manipcad ui`` end to end in a real headless Chromium (Debian's ``chromium``,
driven by Playwright from PyPI; never a browser Playwright downloads).

The designer's flow: open the app, pick the PUMA 560 (its 3-D stick view moved by a
pose slider and turned), make a trajectory, get a recommendation and verify it by
simulation, synthesize the recommended method and a PID, simulate both, see both in
the results overlay; a bad URDF upload shows its error in the page; a second tab keeps
its own robot and trajectory; a traversal name gets 400; an upload over the cap
gets 413; with a token, a request without it gets 401. A tour of every page leaves no
traceback in the server's log (every test reads it).
Screenshots of every page go to docs/ui/.

A missing browser or Playwright FAILS these tests (``.ci/run`` installs chromium);
they are never skipped.
"""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
SHOTS = ROOT / "docs" / "ui"
CHROMIUM = os.environ.get("MANIPCAD_CHROMIUM", "/usr/bin/chromium")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(ws: Path, *extra: str):
    port = _free_port()
    # NiceGUI takes a PYTEST_CURRENT_TEST in its environment for its own test mode
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")
    log = Path(ws).parent / f"server-{port}.log"      # the server's output, read at the end
    with open(log, "w") as out:
        proc = subprocess.Popen([sys.executable, "-m", "manipcad", "ui", "--ws", str(ws),
                                 "--port", str(port), *extra], env=env,
                                stdout=out, stderr=subprocess.STDOUT, text=True)
    proc.log = log
    base = f"http://127.0.0.1:{port}"
    deadline = time.time() + 60
    while time.time() < deadline:
        try:
            urllib.request.urlopen(base + "/api/items/robots/none", timeout=2)
        except urllib.error.HTTPError:
            return proc, base           # the server answers (404 or 401)
        except OSError:
            if proc.poll() is not None:
                raise AssertionError(f"manipcad ui exited: {log.read_text()}") from None
            time.sleep(0.2)
    proc.kill()
    raise AssertionError("manipcad ui did not answer within 60 s")


def _stop(proc) -> str:
    """Stop the server; its log, which must hold no traceback (a page's or a handler's
    exception that NiceGUI logged)."""
    proc.terminate()
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
    text = proc.log.read_text()
    assert "Traceback" not in text, text
    return text


@pytest.fixture(scope="module")
def browser():
    assert Path(CHROMIUM).is_file(), (
        f"{CHROMIUM} missing: install Debian's chromium (apt-get install -y chromium); "
        ".ci/run does it")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
        yield b
        b.close()


@pytest.fixture()
def server(tmp_path):
    proc, base = _start(tmp_path / "ws")
    yield base
    _stop(proc)


def _pick(page, testid: str, option: str) -> None:
    """Choose ``option`` in the q-select marked ``testid``."""
    from playwright.sync_api import expect

    sel = page.get_by_test_id(testid)
    sel.click()
    item = page.locator(".q-menu .q-item", has_text=option).first
    item.wait_for()
    item.click()
    page.locator(".q-menu").wait_for(state="detached")
    expect(sel).to_contain_text(option)


def _open(page, url: str) -> None:
    """Go to a page and wait until it is built: pages build once their tab's websocket is
    up (the tab's own state), so the title is the sign the page is live."""
    resp = page.goto(url)
    assert resp.status == 200, (url, resp.status)
    page.wait_for_function("() => window.socket && window.socket.connected")
    page.get_by_test_id("page-title").wait_for()


def _see(page, locator, timeout: float = 30_000) -> None:
    """Wait for ``locator``; on a timeout, say what the page's error line shows."""
    from playwright.sync_api import TimeoutError as Timeout

    try:
        locator.wait_for(timeout=timeout)
    except Timeout:
        err = page.get_by_test_id("error")
        shown = err.inner_text() if err.count() and err.is_visible() else "(no error shown)"
        raise AssertionError(f"{locator} did not appear; the page's error: {shown}") from None


def _fill(page, testid: str, value: str) -> None:
    # ui.input puts the test id on the <input> itself
    page.locator(f"input[data-testid={testid}], [data-testid={testid}] input").first.fill(value)


def _shot(page, name: str) -> None:
    """A screenshot of the page into docs/ui/; the page shows no install path."""
    text = page.inner_text("body")
    assert str(ROOT / "src") not in text and "Traceback" not in text, (name, text)
    SHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(SHOTS / f"{name}.png"), full_page=True, timeout=90_000)


def _simulate(page, regulator: str, name: str, meanwhile=None) -> None:
    """Run a simulation from the page; ``meanwhile()`` is done while it runs."""
    _pick(page, "sim-reg", regulator)
    _fill(page, "sim-tend", "0.3")
    _fill(page, "sim-dt", "1e-4")
    _fill(page, "sim-name", name)
    page.get_by_test_id("sim-run").click()
    if meanwhile is not None:
        meanwhile()
    status = page.get_by_test_id("sim-status")
    deadline = time.time() + 240   # the worker's first run may load compiled kernels
    while time.time() < deadline:
        text = status.inner_text()
        if f"results/{name}" in text or text.startswith(("error", "cancelled")):
            break
        time.sleep(0.25)
    assert text.startswith("done"), (text, page.get_by_test_id("error").inner_text())
    assert f"results/{name}" in text
    # the run's checks against every rating and their one-line verdict (docs/checks.md)
    page.get_by_test_id("sim-checks").wait_for()
    assert page.get_by_test_id("sim-verdict").inner_text().startswith(
        ("PASS", "FAIL", "UNKNOWN"))


def _selected(page, robot: str, trajectory: str) -> None:
    """The page's header shows this tab's robot and trajectory."""
    from playwright.sync_api import expect

    expect(page.get_by_test_id("selection")).to_have_text(re.compile(
        rf".* · robot\s*{re.escape(robot)}\s*· trajectory\s*{re.escape(trajectory)}\s*"))


def _slide(page, testid: str, fraction: float) -> None:
    """Click the slider marked ``testid`` at ``fraction`` of its length."""
    box = page.get_by_test_id(testid).bounding_box()
    page.get_by_test_id(testid).click(position={"x": fraction * box["width"],
                                               "y": box["height"] / 2})


def test_designer_flow(browser, server):
    from playwright.sync_api import expect

    context = browser.new_context(viewport={"width": 1400, "height": 900})   # one browser
    page = context.new_page()                                  # whose tabs are pages
    _open(page, server + "/")
    page.get_by_text("Requirements → method").first.wait_for()
    _shot(page, "main-menu")

    # robots: pick the PUMA 560; its joints table and the stick view
    _open(page, server + "/robots")
    _pick(page, "robot-select", "cylindrical")
    page.get_by_text("3 joints, 3 driven").wait_for()
    _pick(page, "robot-select", "puma560")
    page.get_by_text("6 joints, 6 driven").wait_for()
    table = page.get_by_test_id("joints-table")
    for joint in ("waist", "shoulder", "elbow", "flange"):
        assert joint in table.inner_text()
    # the 3-D stick view (projected, in SVG): the pose sliders move it, the view turns
    view = page.get_by_test_id("stick-view")
    view.locator(".scatterlayer .trace").nth(5).wait_for()          # floor ... gripper
    title = view.locator(".gtitle")
    assert "q = [0.00, 0.00, 0.00, 0.00, 0.00, 0.00]" in title.text_content()
    _slide(page, "pose-1", 0.9)
    expect(title).not_to_contain_text("q = [0.00, 0.00,")
    page.get_by_role("button", name="top").click()
    expect(title).to_contain_text("view azimuth -90°, elevation 90°")
    page.get_by_role("button", name="three-quarter").click()
    expect(title).to_contain_text("view azimuth -60°, elevation 25°")
    _shot(page, "robots")

    # a bad URDF upload: its error (file, reason) in the page, nothing added
    page.get_by_test_id("robot-upload").locator("input[type=file]").set_input_files(
        files=[{"name": "broken.urdf", "mimeType": "application/xml",
                "buffer": b"<robot name='x'><link name='a'/><joint name='j' type='revolute'>"}])
    err = page.get_by_test_id("error")
    err.wait_for(state="visible")
    assert "broken.urdf" in err.inner_text()
    _shot(page, "robots-bad-upload")

    # trajectory: laws (2) for every joint, preview, save
    _open(page, server + "/trajectories")
    _fill(page, "traj-amplitude", "0.2")
    _fill(page, "traj-omega", "3")
    _fill(page, "traj-duration", "0.3")               # short: verify simulates it all
    page.get_by_test_id("traj-preview").click()
    page.locator(".js-plotly-plot").first.wait_for()
    _fill(page, "traj-name", "move")
    page.get_by_test_id("traj-save").click()
    _see(page, page.get_by_text("saved trajectories/move"))
    _shot(page, "trajectories")


    # requirements -> recommended method with the rules that fired
    _open(page, server + "/requirements")
    page.get_by_test_id("req-run").click()
    methods = page.get_by_test_id("rec-methods")
    _see(page, methods)
    best = methods.inner_text().split(":", 1)[1].split(",")[0].strip()
    assert best == "asvs", methods.inner_text()
    _selected(page, "puma560", "move")
    page.get_by_text("Rules that fired").wait_for()
    # verify by simulation along the trajectory, in the (pre-started) worker process
    page.get_by_test_id("req-verify").click()
    verified = page.get_by_test_id("req-verified")
    _see(page, verified, 120_000)
    assert "asvs" in verified.inner_text() and "max error" in verified.inner_text()
    page.get_by_text("verified by simulation along move").wait_for()
    _shot(page, "requirements")

    # synthesis: the recommended method (preselected) and a PID
    _open(page, server + "/synthesis")
    _fill(page, "syn-name", "best")
    page.get_by_test_id("syn-run").click()
    _see(page, page.get_by_test_id("syn-saved"))
    assert "U_k" in page.locator(".font-mono").first.inner_text()   # the law with numbers
    _shot(page, "synthesis")
    _pick(page, "syn-method", "pid")
    _fill(page, "syn-name", "pid")
    page.get_by_test_id("syn-run").click()
    page.get_by_test_id("syn-saved").get_by_text("saved regulators/pid").wait_for()
    _pick(page, "syn-method", "lqr_gs")                  # its gain table as a plot
    _fill(page, "syn-joints", "1")
    _fill(page, "syn-name", "gs")
    page.get_by_test_id("syn-run").click()
    _see(page, page.get_by_test_id("syn-gain-table").locator(".main-svg").first, 60_000)
    _shot(page, "synthesis-lqr-gs")

    # drives: the libraries; what the trajectory needs against the motors' limits (torque-
    # speed, current, voltage, power); the gear-ratio sweep
    _open(page, server + "/drives")
    assert "maxon_ec45flat_411812" in page.get_by_test_id("motors-table").inner_text()
    page.get_by_test_id("drives-run").click()
    _see(page, page.get_by_test_id("drives-table"))
    assert "shoulder" in page.get_by_test_id("drives-table").inner_text()
    page.get_by_test_id("torque-speed").wait_for()
    for key in ("current", "voltage", "power"):
        page.get_by_test_id(f"drives-{key}").locator(".main-svg").first.wait_for()
    page.get_by_test_id("sweep-run").click()
    _see(page, page.get_by_test_id("sweep-result"))
    assert "feasible |i_r|" in page.get_by_test_id("sweep-result").inner_text()
    _shot(page, "drives")

    # identification: the example's measured torques give the payload mass
    _open(page, server + "/identification")
    page.locator("input").first.fill("0, 0, 0.08")
    page.get_by_test_id("ident-upload").locator("input[type=file]").set_input_files(
        str(ROOT / "examples" / "identify_puma.csv"))
    _see(page, page.get_by_test_id("ident-mass"))
    assert "payload mass m_r = " in page.get_by_test_id("ident-mass").inner_text()
    _shot(page, "identification")

    def second_tab() -> None:
        """Per-tab state: a second tab of the same browser has its own robot and
        trajectory (done while the first tab's run goes: the server answers it)."""
        other = page.context.new_page()
        _open(other, server + "/robots")
        _selected(other, "puma560", "-")
        _pick(other, "robot-select", "cylindrical")
        _selected(other, "cylindrical", "-")
        other.close()

    # simulate both, in the worker process
    _open(page, server + "/simulation")
    _simulate(page, "best", "run-best", meanwhile=second_tab)
    page.locator(".js-plotly-plot").first.wait_for()
    _shot(page, "simulation")
    _simulate(page, "pid", "run-pid")

    # results: both listed and overlaid
    _open(page, server + "/results")
    _selected(page, "puma560", "move")                  # this tab's, unchanged by the other
    table = page.get_by_test_id("res-table")
    table.get_by_text("run-best").wait_for()
    assert "run-pid" in table.inner_text()
    page.get_by_test_id("res-overlay-run").click()
    overlay = page.get_by_test_id("res-overlay")
    overlay.locator(".legend").first.wait_for()
    legend = overlay.locator(".legend").first.text_content()
    assert "run-best" in legend and "run-pid" in legend
    _shot(page, "results")
    _fill(page, "res-where", "max_error<0")
    page.get_by_test_id("res-filter").click()
    table.get_by_text("No data available").wait_for()

    # a study from the page (a short Fig. 3 run in the worker): progress, then its report
    _fill(page, "study-tend", "0.02")
    _fill(page, "study-methods", "none")
    with page.context.expect_page(timeout=120_000) as opened:
        page.get_by_test_id("study-run").click()
    report = opened.value                               # the report opens in a new tab
    report.wait_for_load_state()
    assert "/api/studies/fig3/report.html" in report.url
    assert "Fig. 3" in report.content()
    report.close()
    assert "done: stored studies/fig3" in page.get_by_test_id("study-status").inner_text()
    page.get_by_test_id("study-fig3").get_by_text("report.html").wait_for()
    _shot(page, "studies")
    _open(page, server + "/design")
    page.get_by_test_id("page-title").wait_for()
    assert str(ROOT / "src") not in page.inner_text("body")

    # a traversal name gets 400, an unknown item 404
    assert page.goto(server + "/api/items/robots/..%2F..%2Fetc%2Fpasswd").status == 400
    assert page.goto(server + "/api/items/robots/%2Fetc%2Fpasswd").status == 400
    got = page.request.get(server + "/api/items/trajectories/move")
    assert got.status == 200 and b"cosine" in got.body()
    assert page.request.get(server + "/api/items/trajectories/nothing").status == 404
    assert page.request.get(server + "/api/items/secrets/move").status == 400
    assert page.request.get(server + "/api/studies/..%2Fresults/x.html").status == 400
    assert page.request.get(server + "/api/studies/fig3/..%2F..%2Findex.sqlite").status == 400
    assert page.request.get(server + "/api/studies/fig3/fig3.html").status == 404
    # the server caps uploads, not only the browser's upload field: 413 before reading
    from manipcad.ui.logic import MAX_UPLOAD

    big = page.request.post(server + "/_nicegui/client/x/upload/1",
                            multipart={"file": {"name": "big.urdf", "mimeType": "text/xml",
                                                "buffer": b" " * (MAX_UPLOAD + 100_000)}})
    assert big.status == 413, big.status
    context.close()


def _pose_shown(page) -> tuple[list[float], list[float]]:
    """The pose the Robots page's figure caption names, and the pose its sliders show."""
    title = page.get_by_test_id("stick-view").locator(".gtitle").text_content()
    caption = [float(x) for x in title.split("q = [", 1)[1].split("]", 1)[0].split(",")]
    sliders = [float(page.get_by_test_id(f"pose-{j}").get_attribute("aria-valuenow"))
               for j in range(len(caption))]
    return caption, sliders


def test_robots_and_identification_without_a_traceback(browser, tmp_path):
    """Plain GETs of every page (no websocket ever opened), pages left while loading and
    the pages used leave no traceback in the server's log (the designer flow tours every
    page and reads its log too, and its screenshots check that no page shows an install
    path); the Robots page draws the pose its sliders show, within the joint limits, and
    its caption follows them; an upload over the size cap says so; a stored result gives
    the Identification page its data."""
    from playwright.sync_api import expect
    from test_ui import _stored_puma_result

    from manipcad.ui import logic
    from manipcad.ui.pages.common import MENU

    _stored_puma_result(logic.open_workspace(tmp_path / "ws"), "loaded", 1.5, [0, 0, 0.08])
    proc, base = _start(tmp_path / "ws")
    try:
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        for path, _ in MENU:                                # no browser: never connected
            assert page.request.get(base + path).status == 200
        for _ in range(2):                   # pages left while their files still load
            _open(page, base + "/robots")
            page.goto(base + "/drives")
            page.goto(base + "/")
        _open(page, base + "/robots")
        _pick(page, "robot-select", "stanford")
        title = page.get_by_test_id("stick-view").locator(".gtitle")
        expect(title).to_contain_text("Stanford arm at q")
        caption, sliders = _pose_shown(page)              # the reach: 0.3..1.27 m
        assert caption == pytest.approx(sliders, abs=0.005), (caption, sliders)
        assert caption[2] == pytest.approx(0.79, abs=0.005)
        _slide(page, "pose-2", 0.9)
        expect(title).not_to_contain_text(", 0.79,")
        caption, sliders = _pose_shown(page)
        assert caption == pytest.approx(sliders, abs=0.005) and caption[2] > 1.0
        page.get_by_test_id("robot-upload").locator("input[type=file]").set_input_files(
            files=[{"name": "big.urdf", "mimeType": "application/xml",
                    "buffer": b" " * (logic.MAX_UPLOAD + 1)}])
        expect(page.get_by_test_id("error")).to_contain_text("refused: larger than")
        _pick(page, "robot-select", "puma560")          # the robot of the stored result
        _open(page, base + "/identification")
        page.locator("input").first.fill("0, 0, 0.08")       # the payload's centre
        page.get_by_test_id("ident-result-run").click()
        _see(page, page.get_by_test_id("ident-mass"))
        shown = page.get_by_test_id("ident-mass").inner_text()     # made with 1.5 kg
        assert float(shown.split("=")[1].split("±")[0]) == pytest.approx(1.5, rel=1e-3)
        page.close()
    finally:
        _stop(proc)


def test_token_required_off_loopback(browser, tmp_path):
    proc, base = _start(tmp_path / "ws", "--token", "s3cret-token")
    try:
        page = browser.new_page()
        assert page.goto(base + "/").status == 401
        assert page.goto(base + "/api/items/robots/x").status == 401
        assert page.goto(base + "/?token=wrong").status == 401
        assert page.goto(base + "/?token=s3cret-token").status == 200
        # the page's own requests carry the cookie: the page comes alive over its websocket
        page.get_by_text("Requirements → method").first.wait_for()
        assert page.goto(base + "/robots").status == 200
        page.get_by_text("6 joints, 6 driven").wait_for()
        page.close()
    finally:
        _stop(proc)
