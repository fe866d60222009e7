"""End-to-end: the editor's live views in headless Chromium against a real `nutty serve`, as a user
works with them.

Covers: hovering a wire shows its live value; pinned probes plot it (several, unpinned with ×); every
node shows its cook time (the nodes of GET /api/profile) and the heat can be hidden; a warning shows
on its node and the warning count frames it; a parameter driven by a wire says so (slider disabled,
jump to the source); the layer stack mutes, solos, re-weights and reorders layers on the server; the Pre-Viz
pane enlarges and shrinks; the console follows new lines and resizes; the
curve axis shows minus signs; an input slider does not jump when pressed on its thumb.
Screenshots go to test-artifacts/.
"""

from __future__ import annotations

import json
import re
import time

import pytest
from editor_browser import ARTIFACTS, BROWSER, editor_page, scratch_robot, wait_until
from playwright.sync_api import TimeoutError as PlaywrightTimeout
from server_process import running_server

COOK = re.compile(r"^\d+(\.\d)? (µs|ms)$")
MINUS = "\u2212"

pytestmark = BROWSER


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    robot = scratch_robot(tmp_path_factory)
    # without viser: its page (same origin, so the editor's renderer thread) rendering in software GL
    # would starve this page's frames; its embedded form is tested in tests/test_previz.py
    with running_server("--robot", str(robot), "--no-previz") as (url, _, client):
        yield {"url": url, "client": client}


@pytest.fixture(scope="module")
def page(server):
    with editor_page(server["url"], timeout_ms=20000) as pg:
        pg.get_by_test_id("node-mix").wait_for()
        yield pg


def wire_point(page, edge_id, frac=0.5):
    """A point on a wire, in page coordinates."""
    return page.evaluate(
        """([id, frac]) => {
      const path = document.querySelector(`.react-flow__edge[data-id="${id}"] path.react-flow__edge-path`);
      const p = path.getPointAtLength(path.getTotalLength() * frac);
      const m = path.getScreenCTM();
      return {x: p.x * m.a + p.y * m.c + m.e, y: p.x * m.b + p.y * m.d + m.f};
    }""",
        [edge_id, frac],
    )


def wire_spot(page, edge_id):
    """A point of a wire where the wire itself is under the pointer (not a node or another wire)."""
    for frac in (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8, 0.15, 0.85, 0.1, 0.9, 0.25, 0.75, 0.35, 0.65, 0.45, 0.55):
        pt = wire_point(page, edge_id, frac)
        # clear of every block by a margin (a block's edge under the pointer would take the hover)
        clear = page.evaluate(
            """([x, y, m]) => [...document.querySelectorAll('.react-flow__node')].every((n) => {
            const r = n.getBoundingClientRect();
            return x < r.left - m || x > r.right + m || y < r.top - m || y > r.bottom + m; })""",
            [pt["x"], pt["y"], 8],
        )
        hit = page.evaluate(
            "([x, y]) => document.elementFromPoint(x, y)?.closest('.react-flow__edge')?.dataset.id",
            [pt["x"], pt["y"]],
        )
        if hit == edge_id and clear:
            return pt
    raise AssertionError(f"no free point on wire {edge_id}")


def telemetry_layers(server, mixer="mix"):
    import websockets.sync.client as wsc

    with wsc.connect(server["url"].replace("http", "ws") + "/ws/telemetry") as ws:
        ws.send(json.dumps({"type": "subscribe", "signals": [], "frames": False, "rate": 30}))
        while True:
            msg = json.loads(ws.recv())
            if msg.get("type") == "telemetry" and "layers" in msg:
                return {layer["name"]: layer for layer in msg["layers"][mixer]}


def running_node(server, node):
    return next(n for n in server["client"].program()["program"]["nodes"] if n["id"] == node)


def select(page, node):
    """Click a block's title so the parameter panel shows it. Fit animates the view: the title is
    clicked once it stands still, and again if a busy machine let the click land before it did."""
    page.get_by_role("button", name="Fit").click()  # the whole program in view
    header = page.get_by_test_id(f"node-{node}").locator(".block-header")
    shown = page.get_by_test_id("param-panel").locator("h3").filter(has_text=node)
    for attempt in range(3):
        box = None
        for _ in range(50):  # until the title has not moved for 0.1 s (at most 5 s)
            now = header.bounding_box()
            if now is not None and now == box:
                break
            box = now
            time.sleep(0.1)
        if page.evaluate(
            "(el) => el.getBoundingClientRect().top < document.querySelector('.react-flow').getBoundingClientRect().top",
            header.element_handle(),
        ):
            header.dispatch_event(
                "click"
            )  # a tall block framed from its middle: its title is above the canvas
        else:
            header.click()
        try:
            shown.wait_for(timeout=5000 if attempt < 2 else 20000)
            return
        except PlaywrightTimeout:
            if attempt == 2:
                raise


BREATH = "breathe.out->mix.idle"


def test_hovering_a_wire_shows_its_live_value_and_pins_probes(page):
    pt = wire_spot(page, BREATH)
    page.mouse.move(pt["x"], pt["y"])
    tip = page.get_by_test_id("wire-tooltip")
    tip.wait_for()
    assert "breathe.out → mix.idle" in tip.inner_text()
    value = page.get_by_test_id("wire-value")
    first = value.inner_text()
    assert re.match(r"^4 DoFs · neck_pitch [+−]?\d", first), (
        first
    )  # a frame wire: DoF count, first DoFs, signs
    wait_until(lambda: value.inner_text() != first, what="the hovered wire's value to change")
    pin = page.get_by_test_id("wire-pin").bounding_box()
    x, y = pin["x"] + pin["width"] / 2, pin["y"] + pin["height"] / 2
    page.mouse.move(x, y)  # from the wire to the tooltip's pin button: the tooltip stays
    assert page.evaluate("([x, y]) => document.elementFromPoint(x, y).dataset.testid", [x, y]) == "wire-pin"
    page.mouse.click(x, y)  # (the live tooltip re-renders at 30 Hz: never "stable" for locator.click)
    probe = page.get_by_test_id(f"probe-{BREATH}")
    probe.wait_for()
    wait_until(lambda: int(probe.get_attribute("data-points") or 0) >= 5, what="the probe to collect points")
    last = probe.get_attribute("data-last")
    wait_until(lambda: probe.get_attribute("data-last") != last, what="the probe's value to move")
    stats = probe.get_by_test_id("probe-stats").inner_text()
    assert re.search(r"min [−+]?\d\.\d+ · max [−+]?\d\.\d+ · [−+]?\d\.\d+", stats), stats
    assert probe.locator("polyline").count() == 1
    # a second probe from another wire's context menu; both stay anchored as the view pans
    mood = "mood.out->mix.mood"
    page.mouse.move(760, 60)
    pt = wire_spot(page, mood)
    page.mouse.click(pt["x"], pt["y"], button="right")
    page.get_by_test_id("context-menu").get_by_role("menuitem", name="Add a probe").click()
    second = page.get_by_test_id(f"probe-{mood}")
    second.wait_for()
    before = probe.bounding_box()
    pane = page.locator(".react-flow__pane").bounding_box()
    page.mouse.move(pane["x"] + pane["width"] - 260, pane["y"] + 30)
    page.mouse.down(button="middle")  # middle-drag pans (a left drag on the canvas box-selects)
    page.mouse.move(pane["x"] + pane["width"] - 200, pane["y"] + 70, steps=5)
    page.mouse.up(button="middle")
    after = probe.bounding_box()
    assert abs((after["x"] - before["x"]) - 60) < 6 and abs((after["y"] - before["y"]) - 40) < 6, (
        before,
        after,
    )
    page.screenshot(path=str(ARTIFACTS / "editor-live-probes.png"))
    second.get_by_test_id("probe-close").click()
    wait_until(lambda: second.count() == 0, what="the second probe to be unpinned")
    assert probe.count() == 1
    probe.get_by_test_id("probe-close").click()
    page.get_by_role("button", name="Fit").click()


def test_every_node_shows_its_cook_time(page, server):
    profile = server["client"]._call("GET", "/api/profile")
    ids = [n["node"] for n in profile["nodes"]]
    assert ids and "mix" in ids
    page.get_by_test_id("cook-mix").wait_for()
    for node in ids:
        text = page.get_by_test_id(f"cook-{node}").inner_text()
        assert COOK.match(text), (node, text)
    heats = [float(page.get_by_test_id(f"cook-{n}").get_attribute("data-heat")) for n in ids]
    assert max(heats) == 1.0 and min(heats) < 1.0  # the most expensive node is the hottest
    assert page.locator(".heat-strip").count() == len(ids)
    page.get_by_test_id("heat-toggle").uncheck()
    wait_until(lambda: page.locator(".heat-strip").count() == 0, what="the heat to hide")
    page.get_by_test_id("heat-toggle").check()
    wait_until(lambda: page.locator(".heat-strip").count() == len(ids), what="the heat to come back")


def test_a_parameter_driven_by_a_wire_says_so(page):
    select(page, "breathe")
    driven = page.get_by_test_id("driven-amplitude")
    driven.wait_for()
    assert "driven by breath_amplitude.value" in driven.inner_text()
    assert re.match(r"^[+−]?\d\.\d{3}$", page.get_by_test_id("driven-value-amplitude").inner_text())
    assert page.get_by_test_id("param-amplitude").is_disabled()  # the wire overrides the slider
    assert (
        page.get_by_test_id("driven-frequency").count() == 0
        and page.get_by_test_id("param-frequency").is_enabled()
    )
    page.screenshot(path=str(ARTIFACTS / "editor-live-driven.png"))
    page.get_by_test_id("driven-jump-amplitude").click()
    page.get_by_test_id("param-panel").locator("h3").filter(has_text="breath_amplitude").wait_for()
    assert "selected" in page.get_by_test_id("node-breath_amplitude").get_attribute("class")


def test_layer_stack_mutes_solos_and_weights_layers_on_the_server(page, server):
    select(page, "mix")
    stack = page.get_by_test_id("layer-stack-mix")
    stack.wait_for()
    assert page.get_by_test_id("param-panel").locator("textarea").count() == 0  # no raw JSON for the layers
    # mute: the server fades the layer out; unmute brings it back
    page.get_by_test_id("ls-mute-idle").click()
    wait_until(lambda: not telemetry_layers(server)["idle"]["active"], what="the idle layer to be muted")
    written = lambda: next(l for l in running_node(server, "mix")["params"]["layers"] if l["name"] == "idle")
    wait_until(lambda: written().get("active") is False, what="the mute saved in the running program")
    wait_until(
        lambda: page.get_by_test_id("ls-idle").get_attribute("data-active") == "0", what="the row to show it"
    )
    page.get_by_test_id("ls-mute-idle").click()
    wait_until(lambda: telemetry_layers(server)["idle"]["active"], what="the idle layer to be back")
    # solo: only that layer active; un-solo restores the others
    before = {k: v["active"] for k, v in telemetry_layers(server).items()}
    page.get_by_test_id("ls-solo-wander").click()
    wait_until(
        lambda: [k for k, v in telemetry_layers(server).items() if v["active"]] == ["wander"],
        what="only the soloed layer active",
    )
    page.screenshot(path=str(ARTIFACTS / "editor-live-layer-solo.png"))
    page.get_by_test_id("ls-solo-wander").click()
    wait_until(
        lambda: {k: v["active"] for k, v in telemetry_layers(server).items()} == before,
        what="the layers before the solo",
    )
    # a weight: the running program has it, and the live bar follows
    page.get_by_test_id("ls-weight-wander").fill("0.4")
    layer = lambda: next(l for l in running_node(server, "mix")["params"]["layers"] if l["name"] == "wander")
    wait_until(lambda: layer().get("weight") == 0.4, what="the wander layer's weight on the server")
    live = page.get_by_test_id("ls-live-wander")
    wait_until(
        lambda: abs(float(live.get_attribute("data-effective") or 0) - 0.4) < 0.02, what="the live weight bar"
    )
    # a mask: typed as DoF globs, the running program's layer has it
    mask = page.get_by_test_id("ls-mask-wander")
    mask.fill("head_*, neck_pitch")
    mask.press("Enter")
    wait_until(
        lambda: layer().get("mask") == ["head_*", "neck_pitch"], what="the wander layer's mask on the server"
    )
    # adding a layer gives the mixer its input; removing it takes the input away again
    page.get_by_test_id("ls-new-name").fill("extra")
    page.get_by_test_id("ls-add").click()
    page.locator("[data-testid=node-mix] .react-flow__handle.target[data-handleid='extra']").wait_for(
        state="attached"
    )
    wait_until(
        lambda: "extra" in [l["name"] for l in running_node(server, "mix")["params"]["layers"]],
        what="the new layer on the server",
    )
    page.get_by_test_id("ls-remove-extra").click()
    wait_until(
        lambda: "extra" not in [l["name"] for l in running_node(server, "mix")["params"]["layers"]],
        what="the layer removed on the server",
    )
    # reorder: shift one up (a program edit: the server runs the new order), then back
    order = lambda: [l["name"] for l in running_node(server, "mix")["params"]["layers"]]
    names = order()
    i = names.index("shift")
    page.get_by_test_id("ls-up-shift").click()
    wait_until(
        lambda: order() == [*names[: i - 1], "shift", names[i - 1], *names[i + 1 :]],
        what="shift moved up on the server",
    )
    page.get_by_test_id("ls-down-shift").click()
    wait_until(lambda: order() == names, what="the original order back")


def test_a_warning_shows_on_its_node_and_the_count_frames_it(page, server):
    select(page, "mix")
    assert page.get_by_test_id("warning-mix").count() == 0
    page.get_by_test_id("ls-weight-shift").fill("0")  # a layer of weight 0 has no effect: a warning
    badge = page.get_by_test_id("warning-mix")
    badge.wait_for()
    assert "weight 0" in badge.get_attribute("title")
    assert "weight 0" in page.get_by_test_id("node-mix").inner_text()  # the warning's line under the node
    assert page.get_by_test_id("node-mix").get_attribute("class").count("has-error") == 0
    count = page.get_by_test_id("warning-count")
    assert "1 warning" in count.inner_text()
    select(page, "breathe")
    page.get_by_role("button", name="Fit").click()
    count.click()  # selects and frames the node concerned
    page.get_by_test_id("param-panel").locator("h3").filter(has_text="mix").wait_for()
    box, graph = page.get_by_test_id("node-mix").bounding_box(), page.locator(".react-flow").bounding_box()
    assert graph["x"] <= box["x"] and box["x"] + box["width"] <= graph["x"] + graph["width"] + 1
    page.screenshot(path=str(ARTIFACTS / "editor-live-warning.png"))
    page.get_by_test_id("ls-weight-shift").fill("1")
    wait_until(lambda: page.get_by_test_id("warning-mix").count() == 0, what="the warning to go")


def test_previz_pane_enlarges_and_shrinks(page):
    box = page.get_by_test_id("previz-box")
    small = box.bounding_box()
    page.get_by_test_id("previz-enlarge").click()
    wait_until(
        lambda: (
            box.bounding_box()["width"] > small["width"] * 1.4
            and box.bounding_box()["height"] > small["height"] * 1.4
        ),
        what="the Pre-Viz to enlarge",
    )
    assert page.get_by_test_id("previz-enlarge").get_attribute("aria-pressed") == "true"
    page.screenshot(path=str(ARTIFACTS / "editor-live-previz-big.png"))
    page.get_by_test_id("previz-enlarge").click()
    wait_until(
        lambda: abs(box.bounding_box()["width"] - small["width"]) < 2, what="the Pre-Viz back in its corner"
    )
    assert page.get_by_test_id("previz-popout").is_disabled()  # this server runs without a Pre-Viz


def test_console_follows_new_lines_and_resizes(page):
    console = page.get_by_test_id("console")
    assert console.bounding_box()["height"] >= 90  # several lines, not the 38 px strip it was
    for _ in range(25):
        page.get_by_role("button", name="say hello").click()
    at_bottom = "el => el.scrollHeight - el.scrollTop - el.clientHeight <= 6"
    wait_until(
        lambda: console.evaluate("el => el.scrollHeight > el.clientHeight") and console.evaluate(at_bottom),
        what="the console to follow new lines",
    )
    console.evaluate(
        "el => { el.scrollTop = 0; el.dispatchEvent(new Event('scroll')); }"
    )  # the user scrolls up
    page.get_by_role("button", name="say hello").click()
    time.sleep(0.5)
    assert console.evaluate("el => el.scrollTop") == 0  # reading: not pulled down
    split = page.get_by_test_id("console-splitter").bounding_box()
    h0 = console.bounding_box()["height"]
    page.mouse.move(split["x"] + 50, split["y"] + 3)
    page.mouse.down()
    page.mouse.move(split["x"] + 50, split["y"] - 80, steps=6)
    page.mouse.up()
    wait_until(lambda: console.bounding_box()["height"] > h0 + 60, what="the console to grow")
    page.screenshot(path=str(ARTIFACTS / "editor-live-console.png"))


def test_curve_axis_shows_minus_signs(page, server):
    # the head yaw swings either side of zero as the gaze moves left and right
    page.get_by_label("DoF to plot").select_option("head_yaw")
    server["client"]._call("PUT", "/api/inputs/gaze_target", json={"value": [0.8, 0.5, 0.35]})
    time.sleep(1.0)
    server["client"]._call("PUT", "/api/inputs/gaze_target", json={"value": [0.8, -0.5, 0.35]})
    plot = page.get_by_test_id("curve-panel").locator(".plot")
    wait_until(
        lambda: MINUS in (plot.get_attribute("data-y-ticks") or ""), timeout=15, what="a negative tick"
    )
    labels = (plot.get_attribute("data-y-ticks") or "").split()
    assert any(l.startswith(MINUS) for l in labels) and not any(l.startswith("-") for l in labels), labels
    page.get_by_test_id("curve-panel").screenshot(path=str(ARTIFACTS / "editor-live-curve-axis.png"))


def test_input_slider_does_not_jump_when_pressed_on_its_thumb(page, server):
    slider = page.get_by_label("input arousal")
    slider.fill("0.5")
    wait_until(
        lambda: server["client"]._call("GET", "/api/inputs")["values"]["arousal"] == 0.5, what="arousal set"
    )
    box = slider.bounding_box()
    # the thumb's centre: the range's own geometry (no padding), thumb width from the browser's default
    thumb = page.evaluate("""() => { const e = document.querySelector('[aria-label="input arousal"]');
                                     return parseFloat(getComputedStyle(e).paddingLeft) || 0; }""")
    assert thumb == 0
    x = box["x"] + 8 + (0.5 + 1) / 2 * (box["width"] - 16)
    page.mouse.move(x, box["y"] + box["height"] / 2)
    page.mouse.down()
    time.sleep(0.3)
    assert abs(float(slider.input_value()) - 0.5) < 0.03
    page.mouse.move(x + 20, box["y"] + box["height"] / 2, steps=4)
    page.mouse.up()
    moved = float(slider.input_value())
    assert moved > 0.55
    wait_until(
        lambda: abs(server["client"]._call("GET", "/api/inputs")["values"]["arousal"] - moved) < 1e-9,
        what="the dragged value on the server",
    )
