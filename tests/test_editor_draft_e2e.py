"""End-to-end, in Chromium against a real `nutty serve`: experimenting without moving the robot.

Covers: a program opened from a file is a draft the robot does not run (its frames keep coming from
the running program) until Go live; the swap Go live makes stays within every DoF's velocity,
acceleration and jerk limits in the frames the server's recorder wrote and in the curve panel;
unsaved edits ask before New throws them away; a slider drag reaches the engine as throttled PATCHes
only (no program PUT, no rebuild); Save as names the program after its file; with `--token`, the
editor given `?token=` edits the robot and one without it cannot.
"""

from __future__ import annotations

import json
import time

import pytest
from editor_browser import ARTIFACTS, BROWSER, VALID, editor_page, scratch_robot, wait_until
from server_process import running_server
from test_safe_swaps import assert_smooth, recorded_frames, recorded_positions

pytestmark = BROWSER

# The head and body far from where the interactive program holds them: a swap to it has a big jump
# to blend out.
FAR_POSE = {
    "format": "nutty-program/1",
    "name": "far pose",
    "max_level": 3,
    "inputs": [],
    "ui": {},
    "nodes": [
        {
            "id": "far",
            "type": "pose",
            "params": {"values": {"body_yaw": 1.2, "head_pitch": -0.35}},
            "ui": {"x": 0, "y": 0},
        },
        {"id": "output", "type": "output", "params": {}, "ui": {"x": 320, "y": 0}},
    ],
    "edges": [{"from": {"node": "far", "port": "out"}, "to": {"node": "output", "port": "in"}}],
}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    robot = scratch_robot(tmp_path_factory, keep=("interactive",))
    record = robot.parent / "frames.jsonl"
    with running_server("--robot", str(robot), "--no-previz", "--record", str(record)) as (url, _, client):
        yield {"url": url, "client": client, "record": record, "robot": robot, "scratch": robot.parent}


@pytest.fixture(scope="module")
def page(server):
    with editor_page(server["url"]) as pg:
        yield pg


def _running(server) -> dict:
    return server["client"].program()["program"]


def _recorded(server) -> list[dict]:
    return recorded_frames(server["record"])


def test_a_draft_does_not_move_the_robot_until_go_live(page, server):
    from backend.engine.embodiment import load_embodiment

    desk = load_embodiment("nutty_desk")
    assert page.get_by_test_id("mode").inner_text().startswith("●")  # the running program, live
    swaps = server["client"].status()["swaps"]
    far = server["scratch"] / "far.json"
    far.write_text(json.dumps(FAR_POSE))
    page.locator("input[type=file]").set_input_files(str(far))
    page.get_by_test_id("node-far").wait_for()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    assert "draft" in page.get_by_test_id("mode").inner_text()
    assert "interactive" in page.get_by_test_id("mode").inner_text()  # what the robot runs
    # nothing of the running program shows on the draft's blocks (its own 'output' is not running)
    time.sleep(1.5)  # cook times arrive about once a second
    assert page.get_by_test_id("cook-output").count() == 0
    # edits of the draft are validated, never sent to the robot
    page.get_by_test_id("node-far").click()
    page.keyboard.press("Delete")
    page.get_by_test_id("status").filter(has_text="error").wait_for()
    page.keyboard.press("Control+z")
    page.keyboard.press("Control+z")  # (a second one is harmless: the draft's history starts at the import)
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    before = len(_recorded(server))
    wait_until(lambda: len(_recorded(server)) > before + 50, what="frames of the running program")
    assert _running(server)["name"] == "interactive" and server["client"].status()["swaps"] == swaps
    yaw = [r["dofs"]["body_yaw"]["position"] for r in _recorded(server)[before:]]
    assert max(abs(y) for y in yaw) < 1.0  # not on its way to the draft's 1.2 rad
    page.screenshot(path=str(ARTIFACTS / "editor-draft.png"))

    # Go live: the robot swaps to the draft, smoothly
    page.get_by_label("DoF to plot").select_option("body_yaw")
    start = len(_recorded(server))
    page.get_by_test_id("go-live").click()
    page.get_by_test_id("mode").filter(has_text="live").wait_for()
    wait_until(lambda: _running(server)["name"] == "far pose", what="the draft to go live")
    assert server["client"].status()["swaps"] == swaps + 1
    page.get_by_test_id("cook-far").wait_for()  # live: the blocks show their cook times

    def arrived():
        rows = _recorded(server)[start:]
        return rows and abs(rows[-1]["dofs"]["body_yaw"]["position"] - 1.2) < 1e-6

    wait_until(arrived, timeout=20, what="the robot to reach the new program's pose")
    rows = _recorded(server)[
        start - 5 :
    ]  # every frame of the swap (recorded_positions checks none is missing)
    assert_smooth(
        desk, recorded_positions(desk, rows), 100.0
    )  # no sample over a velocity, acceleration or jerk limit
    # the curve panel shows the same: every sample of body_yaw in its window is within the limits
    panel = page.get_by_test_id("curve-panel")
    wait_until(lambda: "ok" in panel.inner_text(), what="the curve panel")
    text = panel.inner_text()
    for limit in ("velocity", "acceleration", "jerk"):
        assert f"{limit} 0" in text, text
    page.screenshot(path=str(ARTIFACTS / "editor-went-live.png"))


def test_unsaved_edits_ask_before_new(page, server):
    page.get_by_test_id("node-far").click()
    page.keyboard.press("Delete")
    wait_until(lambda: page.get_by_test_id("node-far").count() == 0, what="the delete")
    asked = []

    def refuse(dialog):
        asked.append(dialog.message)
        dialog.dismiss()

    page.once("dialog", refuse)
    page.get_by_role("button", name="New").click()
    wait_until(lambda: asked, what="the confirmation")
    assert "unsaved" in asked[0].lower()
    assert page.get_by_test_id("node-rest").count() == 0  # nothing replaced
    page.keyboard.press("Control+z")
    page.get_by_test_id("node-far").wait_for()
    # live since Go live: the delete and its undo reached the robot; let the undo's swap land
    wait_until(
        lambda: any(n["id"] == "far" for n in _running(server)["nodes"]), what="the undo on the server"
    )
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()


def test_a_slider_drag_is_throttled_patches_only(page, server):
    server["client"].load_program(json.loads((server["robot"] / "programs" / "interactive.json").read_text()))
    leave = lambda d: d.accept()
    page.on("dialog", leave)
    page.reload()
    page.remove_listener("dialog", leave)
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    page.get_by_test_id("node-nmf").click()
    slider = page.get_by_test_id("param-sigma")
    slider.wait_for()
    swaps = server["client"].status()["swaps"]
    sent: list[tuple[str, str]] = []
    page.on("request", lambda r: sent.append((r.method, r.url)) if "/api/program" in r.url else None)
    box = slider.bounding_box()
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + 4, y)
    page.mouse.down()
    t0 = time.monotonic()
    for k in range(40):  # a 40-step drag across the slider
        page.mouse.move(box["x"] + 4 + (box["width"] - 8) * k / 39, y)
        page.wait_for_timeout(10)
    page.mouse.up()
    elapsed = time.monotonic() - t0
    page.wait_for_timeout(600)
    methods = [m for m, _ in sent]
    assert "PUT" not in methods, sent
    patches = [u for m, u in sent if m == "PATCH"]
    assert patches and all(u.endswith("/nodes/nmf/params") for u in patches)
    # throttled: at most one per PATCH_INTERVAL_MS (50 ms) plus the last, not one per step
    assert len(patches) <= elapsed / 0.05 + 2, (len(patches), elapsed)
    print(f"{len(patches)} PATCHes for a 40-step drag over {elapsed:.2f} s")
    final = float(slider.input_value())
    wait_until(
        lambda: (
            next(n for n in _running(server)["nodes"] if n["id"] == "nmf")["params"].get("sigma") == final
        ),
        what="the last value of the drag on the server",
    )
    assert server["client"].status()["swaps"] == swaps  # nothing rebuilt


def test_save_as_names_the_program(page, server):
    page.get_by_role("button", name="Save as").click()
    page.get_by_test_id("save-as-name").fill("calm_idle")
    page.keyboard.press("Enter")
    path = server["robot"] / "programs" / "calm_idle.json"
    wait_until(
        lambda: path.exists() and json.loads(path.read_text())["name"] == "calm_idle",
        what=f"the saved file, named calm_idle ({path.read_text()[:80] if path.exists() else 'absent'})",
    )
    # the file is on disk before the server's answer reaches the page, which then renames the program
    wait_until(
        lambda: page.get_by_label("program name").input_value() == "calm_idle", what="the program's new name"
    )


def test_the_editor_sends_the_servers_token(page):
    browser = page.context.browser  # the module's browser (one Playwright per process)
    with running_server("--no-previz", "--token", "s3cret-token") as (url, _, client):
        # without the token: it asks, and without an answer it can only watch
        pg = browser.new_page(viewport={"width": 1600, "height": 1000})
        asked = []
        pg.on("dialog", lambda d: (asked.append(d.message), d.dismiss()))
        pg.goto(url + "/")
        pg.get_by_test_id("node-nmf").wait_for()
        wait_until(lambda: asked, what="the token prompt")
        assert "token" in asked[0]
        pg.close()
        # with ?token=: its edits reach the robot, and the token leaves the address bar
        pg = browser.new_page(viewport={"width": 1600, "height": 1000})
        pg.goto(url + "/?token=s3cret-token")
        pg.get_by_test_id("status").filter(has_text=VALID).wait_for()
        assert "token" not in pg.url
        pg.get_by_test_id("node-nmf").click()
        pg.get_by_test_id("param-sigma").fill("0.25")
        wait_until(
            lambda: (
                next(n for n in client.program()["program"]["nodes"] if n["id"] == "nmf")["params"].get(
                    "sigma"
                )
                == 0.25
            ),
            what="the token-carrying PATCH",
        )
        pg.close()
