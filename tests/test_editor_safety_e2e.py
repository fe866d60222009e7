"""End-to-end, in Chromium against a real `nutty serve`: what you see is what the motor gets.

Covers: with the idle program's breathe amplitude at 0.38 the engine's safety net corrects neck_pitch
(among others); the top bar says so, naming the DoFs and by how much; the curve panel's legend counts
the corrections (by the limit enforced) among the delivered frames; a click on the indicator plots
those DoFs; the net's block (here the output: idle has no safety limiter) lists its per-DoF counts;
pause holds the frames while the robot moves on; a draft whose blocks share their ids with the running
program's shows none of the running program's values, sparklines or safety net.
"""

from __future__ import annotations

import json
import re
import time

import pytest
from editor_browser import ARTIFACTS, BROWSER, VALID, editor_page, scratch_robot, wait_until
from server_process import running_server

pytestmark = BROWSER

LEGEND = re.compile(r"net corrected (\d+) \(velocity (\d+), acceleration (\d+), jerk (\d+), position (\d+)\)")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    robot = scratch_robot(tmp_path_factory, keep=("idle",))
    program = robot / "programs" / "idle.json"
    with running_server("--robot", str(robot), "--program", str(program), "--no-previz") as (url, _, client):
        yield {"url": url, "client": client, "robot": robot, "scratch": robot.parent}


@pytest.fixture(scope="module")
def page(server):
    with editor_page(server["url"]) as pg:
        yield pg


def _readable(page) -> None:
    """Zoom to 100 %: blocks show their live rows (zoomed out they are titles and ports). Clicked again
    while a framing of a program just loaded (it may run late on a loaded machine) zooms back out."""

    def full_and_staying() -> bool:
        if page.locator(".block.compact").count():
            page.get_by_label("zoom 100%").click()
            return False
        time.sleep(0.3)
        return page.locator(".block.compact").count() == 0

    wait_until(full_and_staying, timeout=20, what="full blocks")


def _legend(page) -> tuple[int, ...]:
    found = LEGEND.search(page.get_by_test_id("net-legend").inner_text())
    assert found, page.get_by_test_id("net-legend").inner_text()
    return tuple(int(x) for x in found.groups())


def test_the_editor_shows_the_safety_net_correcting(page, server):
    client = server["client"]
    client.tune("breathe", amplitude=0.38)  # more than neck_pitch may do: the net flattens it
    indicator = page.get_by_test_id("safety-indicator")
    wait_until(
        lambda: "neck_pitch" in (indicator.get_attribute("data-dofs") or ""), timeout=20, what="the indicator"
    )
    text = indicator.inner_text()
    assert text.startswith("Safety net correcting: "), text
    assert re.search(r"neck_pitch \d+\.\d°", text), text
    assert client.status()["safety"]["corrections"].get("neck_pitch", 0) > 0  # the server saw the same
    page.screenshot(path=str(ARTIFACTS / "editor-safety-indicator.png"))

    # a click plots the DoFs it names, and the legend counts the corrections among the delivered frames
    dofs = (indicator.get_attribute("data-dofs") or "").split()
    indicator.click()
    plot = page.get_by_test_id("curve-plot")
    wait_until(
        lambda: plot.get_attribute("data-series") == " ".join(f"dof:{d}" for d in dofs), what="the DoFs"
    )
    wait_until(lambda: _legend(page)[0] > 0, timeout=10, what="corrections in the legend")
    corrected, *by_limit = _legend(page)
    assert sum(by_limit) == corrected
    frames = int(page.get_by_test_id("curve-frames").inner_text().split()[0])
    assert 0 < corrected <= frames
    page.get_by_test_id("curve-panel").screenshot(path=str(ARTIFACTS / "editor-safety-curves.png"))

    # the net's block lists its corrections per DoF (idle has no safety limiter: its output stands for it)
    page.get_by_test_id("net-output").wait_for()  # zoomed out: a badge
    _readable(page)
    rows = page.get_by_test_id("net-output")
    rows.wait_for()
    row = page.get_by_test_id("net-output-neck_pitch").inner_text().split()
    assert row[0] == "neck_pitch" and int(row[1]) > 0 and row[2].endswith("°"), row  # ticks, largest lately
    page.get_by_test_id("node-output").click()
    page.keyboard.press("f")  # the output in view, readable
    rows.screenshot(path=str(ARTIFACTS / "editor-safety-node.png"))

    # pause holds the last minute while the robot goes on; the slider scrubs back through it
    panel = page.get_by_test_id("curve-panel")
    wait_until(  # more than the 8 s in view, to scrub back through (frame time: a loaded machine runs late)
        lambda: float(panel.get_attribute("data-span") or 0) > 9.5, timeout=40, what="9.5 s of frames"
    )
    page.get_by_test_id("curve-pause").click()
    held = page.get_by_test_id("curve-legend").inner_text()
    time.sleep(0.5)
    assert page.get_by_test_id("curve-legend").inner_text() == held
    assert float(page.get_by_test_id("curve-scrub").get_attribute("max") or 0) > 1
    page.get_by_test_id("curve-scrub").fill("0")  # the oldest window held
    wait_until(lambda: page.get_by_test_id("curve-legend").inner_text() != held, what="the scrubbed window")
    page.get_by_test_id("curve-panel").screenshot(path=str(ARTIFACTS / "editor-safety-scrubbed.png"))
    page.get_by_test_id("curve-pause").click()  # live again


def test_a_draft_shows_only_its_own_values(page, server):
    # the running program's breathe block has a sparkline and the net's rows show on its output
    _readable(page)
    page.locator("[data-testid=node-breathe] .spark").wait_for()
    page.get_by_test_id("net-output").wait_for()
    draft = json.loads((server["robot"] / "programs" / "idle.json").read_text())
    draft["name"] = "idle draft"  # the same block ids as the running program
    path = server["scratch"] / "idle-draft.json"
    path.write_text(json.dumps(draft))
    page.locator("input[type=file]").set_input_files(str(path))
    page.get_by_test_id("mode").filter(has_text="draft").wait_for()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    _readable(page)
    page.get_by_test_id("live-breathe.out").wait_for()
    time.sleep(1.0)  # a few telemetry messages of the running program
    assert page.get_by_test_id("live-breathe.out").inner_text() == "–"
    assert page.locator("[data-testid=node-breathe] .spark").count() == 0
    assert page.get_by_test_id("net-output").count() == 0
    assert page.get_by_test_id("cook-breathe").count() == 0
    page.screenshot(path=str(ARTIFACTS / "editor-safety-draft.png"))
    page.get_by_role("button", name="Back to running").click()
    page.get_by_test_id("mode").filter(has_text="live").wait_for()
    _readable(page)
    page.locator("[data-testid=node-breathe] .spark").wait_for()
