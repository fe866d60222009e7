"""End-to-end: the editor in headless Chromium against a real `nutty serve`.

Covers: the running program shown live; New opening a draft that reaches the robot only on Go live; σ slider of the motion filter changing the running program
without a rebuild; a mixer's `<layer>_weight` port (a port the backend derives from the parameters)
wired by dragging and then running on the server; adding a sine from the palette and wiring it to the
output; an invalid connection refused with a reason and an invalid parameter shown on its node;
undo/redo; save and reopen.
Screenshots go to test-artifacts/.
"""

from __future__ import annotations

import pytest
from editor_browser import ARTIFACTS, BROWSER, VALID, drag, editor_page, handle, scratch_robot, wait_until
from server_process import running_server

pytestmark = BROWSER


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    robot = scratch_robot(tmp_path_factory, keep=())  # saves go to a scratch copy of the robot
    with running_server("--robot", str(robot), "--no-previz") as (url, _, client):
        yield {"url": url, "client": client}


@pytest.fixture(scope="module")
def page(server):
    with editor_page(server["url"]) as pg:
        yield pg


def test_running_program_is_shown_live(page):
    page.get_by_test_id("node-mix").wait_for()
    # the 28-block program opens zoomed out, blocks collapsed to their titles: frame the mixer (F) to
    # see values and layer toggles
    page.get_by_test_id("node-mix").click()
    page.keyboard.press("f")
    live = page.get_by_test_id("live-breathe.out")
    first = live.inner_text()
    wait_until(lambda: live.inner_text() != first, what="live values to move")
    page.screenshot(path=str(ARTIFACTS / "editor-live.png"))


def test_layer_toggle_fades_the_layer(page, server):
    toggle = page.get_by_test_id("layer-mix-idle")
    toggle.wait_for()
    toggle.click()  # controlled by telemetry: the box follows the engine, not the click
    wait_until(lambda: not _layer(server, "idle")["active"], what="the idle layer to turn off")
    wait_until(lambda: _layer(server, "idle")["fade"] == 0.0, what="the idle layer to fade out")
    toggle.click()
    wait_until(lambda: _layer(server, "idle")["active"], what="the idle layer to turn on")


def _layer(server, name):
    import json as _json

    import websockets.sync.client as wsc

    url = server["url"].replace("http", "ws") + "/ws/telemetry"
    with wsc.connect(url) as ws:
        ws.send(_json.dumps({"type": "subscribe", "signals": [], "frames": False, "rate": 30}))
        while True:
            msg = _json.loads(ws.recv())
            if msg.get("type") == "telemetry" and "layers" in msg:
                return next(l for l in msg["layers"]["mix"] if l["name"] == name)


def test_sigma_slider_changes_the_running_program(page, server):
    page.get_by_test_id("node-nmf").click()
    slider = page.get_by_test_id("param-sigma")
    slider.wait_for()
    apu_swaps = server["client"].status()["swaps"]
    slider.fill("0.3")

    def sigma():
        prog = server["client"].program()["program"]
        return next(n for n in prog["nodes"] if n["id"] == "nmf")["params"].get("sigma")

    wait_until(lambda: sigma() == 0.3, what="the running program's σ to change")
    assert server["client"].status()["swaps"] == apu_swaps  # a parameter drag rebuilds nothing


# An LFO that could swell the idle layer: wired to the mixer's idle_weight port in the browser.
WEIGHTED_LAYER = {
    "format": "nutty-program/1",
    "name": "weighted layer",
    "max_level": 3,
    "inputs": [],
    "ui": {},
    "nodes": [
        {"id": "rest", "type": "rest_pose", "params": {}, "ui": {"x": 0, "y": 0}},
        {
            "id": "wave",
            "type": "sine",
            "params": {"dofs": ["head_*"], "amplitude": 0.1},
            "ui": {"x": 0, "y": 170},
        },
        {
            "id": "swell",
            "type": "lfo",
            "params": {"frequency": 0.5, "amplitude": 0.5, "offset": 0.5},
            "ui": {"x": 0, "y": 400},
        },
        {
            "id": "mix",
            "type": "layer_mixer",
            "ui": {"x": 380, "y": 80},
            "params": {"layers": [{"name": "base"}, {"name": "idle", "mode": "additive"}]},
        },
        {"id": "output", "type": "output", "params": {}, "ui": {"x": 720, "y": 80}},
    ],
    "edges": [
        {"from": {"node": "rest", "port": "out"}, "to": {"node": "mix", "port": "base"}},
        {"from": {"node": "wave", "port": "out"}, "to": {"node": "mix", "port": "idle"}},
        {"from": {"node": "mix", "port": "out"}, "to": {"node": "output", "port": "in"}},
    ],
}


def test_mixer_weight_port_is_wired_in_the_browser(page, server):
    server["client"].load_program(WEIGHTED_LAYER)

    def leave(dialog):  # the σ edit left the editor with unsaved changes: it asks before reloading
        if dialog.type == "beforeunload":
            dialog.accept()

    page.on("dialog", leave)
    page.reload()
    page.remove_listener("dialog", leave)
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    weight = handle(page, "mix", "idle_weight", "target")
    weight.wait_for()
    drag(page, handle(page, "swell", "value", "source"), weight)
    wire = {"from": {"node": "swell", "port": "value"}, "to": {"node": "mix", "port": "idle_weight"}}
    wait_until(
        lambda: wire in server["client"].program()["program"]["edges"], what="the weight edge on the server"
    )
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    assert server["client"].program()["report"]["valid"]
    page.screenshot(path=str(ARTIFACTS / "editor-weight-wired.png"))
    seen = set()

    def swelling():  # the LFO now scales the idle layer on the robot
        seen.add(round(_layer(server, "idle")["effective"], 3))
        return len(seen) >= 3

    wait_until(swelling, what="the idle layer's weight to follow the LFO")
    # the weight wire round-trips through the robot's library: saved, and drawn again when reopened
    page.get_by_role("button", name="Save as").click()
    page.get_by_test_id("save-as-name").fill("weighted")
    page.keyboard.press("Enter")
    wait_until(lambda: "weighted" in server["client"]._call("GET", "/api/programs"), what="the saved program")
    assert wire in server["client"]._call("GET", "/api/programs/weighted")["edges"]
    page.get_by_role("button", name="New").click()
    wait_until(lambda: page.get_by_test_id("node-swell").count() == 0, what="a blank draft")
    page.get_by_label("open program").select_option("weighted")
    page.locator("[data-testid='rf__edge-swell.value->mix.idle_weight']").wait_for()
    page.get_by_role("button", name="Back to running").click()
    page.get_by_test_id("mode").filter(has_text="live").wait_for()


def test_add_sine_connect_errors_undo_redo_and_save(page, server):
    page.on("dialog", lambda d: d.accept("e2e_program") if d.type == "prompt" else d.accept())
    page.get_by_role("button", name="New").click()
    page.get_by_test_id("node-rest").wait_for()
    wait_until(lambda: page.get_by_test_id("node-breathe").count() == 0, what="the new program")
    # remove the rest pose: the output now misses its input -> an error on the output node
    page.get_by_test_id("node-rest").click()
    page.keyboard.press("Delete")
    page.get_by_test_id("error-output").wait_for()
    page.get_by_test_id("status").filter(has_text="error").wait_for()
    # drag a sine from the palette onto the graph, left of the output, and wire it to the output
    out_box = page.get_by_test_id("node-output").bounding_box()
    pane = page.locator(".react-flow__pane")
    pane_box = pane.bounding_box()
    page.get_by_test_id("palette-sine").drag_to(
        pane,
        target_position={
            "x": max(20, out_box["x"] - pane_box["x"] - 380),
            "y": out_box["y"] - pane_box["y"] + 10,
        },
    )
    page.get_by_test_id("node-sine").wait_for()
    drag(
        page,
        page.locator("[data-testid=node-sine] .react-flow__handle.source").first,
        page.locator("[data-testid=node-output] .react-flow__handle.target").first,
    )
    page.screenshot(path=str(ARTIFACTS / "editor-after-drag.png"))
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    # New opened a draft: the robot runs its program until Go live
    assert page.get_by_test_id("mode").inner_text().startswith("draft")
    assert not any(n["id"] == "sine" for n in server["client"].program()["program"]["nodes"])
    page.get_by_test_id("go-live").click()
    page.get_by_test_id("mode").filter(has_text="live").wait_for()
    wait_until(
        lambda: any(n["id"] == "sine" for n in server["client"].program()["program"]["nodes"]),
        what="the program to go live",
    )
    live = page.get_by_test_id("live-sine.out")
    first = live.inner_text()
    page.screenshot(path=str(ARTIFACTS / "editor-wired.png"))
    wait_until(lambda: live.inner_text() != first, what="the new sine's live value to move")
    # an invalid connection is refused with a visible reason
    sine_box = page.get_by_test_id("node-sine").bounding_box()
    page.get_by_test_id("palette-sine").drag_to(
        pane,
        target_position={
            "x": max(20, sine_box["x"] - pane_box["x"]),
            "y": min(pane_box["height"] - 150, sine_box["y"] - pane_box["y"] + sine_box["height"] + 60),
        },
    )
    page.get_by_test_id("node-sine_2").wait_for()
    drag(
        page,
        page.locator("[data-testid=node-sine_2] .react-flow__handle.source").first,
        page.locator("[data-testid=node-sine] .react-flow__handle.target").first,
    )
    page.get_by_test_id("toast").filter(has_text="cannot connect frame output").wait_for()
    # an invalid parameter: a DoF the robot does not have -> red badge on that node
    page.get_by_test_id("node-sine").click()
    box = page.get_by_placeholder("DoF, glob or stationary:*")
    box.fill("tail_wag")
    box.press("Enter")
    page.get_by_test_id("error-sine").wait_for()
    assert "tail_wag" in page.get_by_test_id("node-sine").inner_text()
    page.screenshot(path=str(ARTIFACTS / "editor-error.png"))
    # undo removes the bad DoF, redo brings it back
    page.get_by_test_id("undo").click()
    wait_until(lambda: page.get_by_test_id("error-sine").count() == 0, what="undo to clear the error")
    page.get_by_test_id("redo").click()
    page.get_by_test_id("error-sine").wait_for()
    page.get_by_test_id("undo").click()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    # save to the library and reopen
    page.get_by_test_id("save").click()  # never saved: the Save-as dialog asks for a name
    page.get_by_test_id("save-as-name").fill("e2e_program")
    page.keyboard.press("Enter")
    wait_until(
        lambda: "e2e_program" in server["client"]._call("GET", "/api/programs"), what="the saved program"
    )
    page.get_by_role("button", name="New").click()
    wait_until(lambda: page.get_by_test_id("node-sine").count() == 0, what="a blank program")
    page.get_by_label("open program").select_option("e2e_program")
    page.get_by_test_id("node-sine").wait_for()
    assert page.get_by_test_id("node-sine_2").count() == 1
