"""End-to-end: room to work in the editor at 1600×1000 (issue #29, points 3–6).

The bundled interactive program opens whole inside the canvas with every block's name ≥ 11 px on screen;
blocks are titled by name, F2 renames one in place (wires follow); the top bar stays one line with a long
error; side and bottom panels fold away and the page remembers it; a palette block and a paste land in
view, clear of the minimap and the canvas's buttons; a wire dropped on a block's body connects to its
first input that fits, and ports that cannot take a dragged wire fade. Screenshots go to test-artifacts/.
"""

from __future__ import annotations

import json
import time

import pytest
from editor_browser import (
    ARTIFACTS,
    BROWSER,
    VALID,
    centre,
    drag,
    edges,
    editor_page,
    editor_server,
    handle,
    running_program,
    show_program,
    wait_until,
    zoom,
)

READABLE_PX = 11.0

pytestmark = BROWSER

CHAIN = {
    "format": "nutty-program/1",
    "name": "room chain",
    "max_level": 3,
    "inputs": [],
    "ui": {},
    "nodes": [
        {"id": "rest", "type": "rest_pose", "params": {}, "ui": {"x": 0, "y": 0}},
        {
            "id": "wave",
            "type": "sine",
            "params": {"dofs": ["head_*"], "amplitude": 0.1},
            "ui": {"x": 0, "y": 220},
        },
        {"id": "smooth", "type": "motion_filter", "params": {}, "ui": {"x": 330, "y": 220}},
        {
            "id": "mix",
            "type": "layer_mixer",
            "ui": {"x": 660, "y": 40},
            "params": {"layers": [{"name": "base"}, {"name": "idle", "mode": "additive"}]},
        },
        {"id": "output", "type": "output", "params": {}, "ui": {"x": 990, "y": 40}},
    ],
    "edges": [
        {"from": {"node": "rest", "port": "out"}, "to": {"node": "mix", "port": "base"}},
        {"from": {"node": "wave", "port": "out"}, "to": {"node": "smooth", "port": "in"}},
        {"from": {"node": "mix", "port": "out"}, "to": {"node": "output", "port": "in"}},
    ],
}


# A library subgraph (robots/<robot>/subgraphs/sway.json) for the palette's drag.
SWAY = {
    "description": "a smoothed head sway",
    "nodes": [
        {
            "id": "wave",
            "type": "sine",
            "params": {"dofs": ["head_*"], "amplitude": 0.05},
            "ui": {"x": 0, "y": 0},
        },
        {"id": "smooth", "type": "motion_filter", "params": {}, "ui": {"x": 320, "y": 0}},
    ],
    "edges": [{"from": {"node": "wave", "port": "out"}, "to": {"node": "smooth", "port": "in"}}],
    "inputs": [{"name": "amount", "node": "wave", "port": "amplitude"}],
    "outputs": [{"name": "out", "node": "smooth", "port": "out"}],
}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with editor_server(tmp_path_factory, {"subgraphs/sway.json": SWAY}) as s:
        yield s


@pytest.fixture(scope="module")
def page(server):
    with editor_page(server["url"], on_dialog=lambda d: d.accept()) as pg:
        yield pg


def node_ids(server):
    return {n["id"] for n in running_program(server)["nodes"]}


def settled(page):
    """Wait until the viewport stops moving (the opening frame, a Fit's animation)."""
    last = [None]

    def still():
        now = page.evaluate(
            "() => getComputedStyle(document.querySelector('.react-flow__viewport')).transform"
        )
        same, last[0] = now == last[0], now
        return same

    wait_until(still, what="the viewport to settle")


def inside(box, outer, slack=0.5):
    return (
        outer["x"] - slack <= box["x"]
        and outer["y"] - slack <= box["y"]
        and box["x"] + box["width"] <= outer["x"] + outer["width"] + slack
        and box["y"] + box["height"] <= outer["y"] + outer["height"] + slack
    )


def overlaps(a, b):
    return (
        a["x"] < b["x"] + b["width"]
        and b["x"] < a["x"] + a["width"]
        and a["y"] < b["y"] + b["height"]
        and b["y"] < a["y"] + a["height"]
    )


def test_opens_whole_and_readable(page, server):
    """Every block of the 28-block program is inside the canvas at opening, its name ≥ 11 px on screen."""
    ids = node_ids(server)
    assert len(ids) >= 20
    page.get_by_test_id("node-output").wait_for()
    settled(page)
    page.screenshot(path=str(ARTIFACTS / "room-open.png"))
    pane = page.locator(".react-flow__pane").bounding_box()
    z = zoom(page)
    for node_id in ids:
        box = page.get_by_test_id(f"node-{node_id}").bounding_box()
        assert box and inside(box, pane), f"{node_id} is outside the canvas: {box} vs {pane}"
        title = page.get_by_test_id(f"title-{node_id}")
        assert title.inner_text() == node_id, "a block is titled by its name"
        font = float(title.evaluate("e => parseFloat(getComputedStyle(e).fontSize)"))
        assert font * z >= READABLE_PX, f"{node_id}'s name is {font * z:.1f} px on screen"
    # Fit frames all of it too, names still readable
    page.get_by_role("button", name="fit view").click()
    settled(page)
    z = zoom(page)
    font = float(
        page.get_by_test_id("title-wander_filter").evaluate("e => parseFloat(getComputedStyle(e).fontSize)")
    )
    assert font * z >= READABLE_PX
    for node_id in ids:
        assert inside(page.get_by_test_id(f"node-{node_id}").bounding_box(), pane), node_id
    # Auto-layout frames all of it as well
    page.get_by_test_id("auto-layout").click()
    settled(page)
    time.sleep(0.5)  # the layout's frame, then its second pass once the blocks are measured
    settled(page)
    for node_id in ids:
        assert inside(page.get_by_test_id(f"node-{node_id}").bounding_box(), pane), (
            f"{node_id} after auto-layout"
        )
    page.screenshot(path=str(ARTIFACTS / "room-auto-layout.png"))
    page.keyboard.press("Control+z")


def test_top_bar_stays_one_line_with_an_error(page, server):
    """A long error status is cut with an ellipsis: the top bar keeps its height and every button."""
    show_program(page, server, CHAIN, settle=settled)
    bar = page.locator(".topbar").bounding_box()
    page.get_by_test_id("node-output").click()
    page.keyboard.press("Delete")
    status = page.get_by_test_id("status")
    status.filter(has_text="error").wait_for()
    page.screenshot(path=str(ARTIFACTS / "room-topbar-error.png"))
    assert page.locator(".topbar").bounding_box()["height"] == bar["height"]
    one_line = status.evaluate("e => parseFloat(getComputedStyle(e).lineHeight) || 16")
    assert status.bounding_box()["height"] < 2 * one_line + 4, "the status is one line"
    for button in ("undo", "redo"):
        assert inside(page.get_by_test_id(button).bounding_box(), bar), f"{button} stays in the top bar"
    page.get_by_test_id("undo").click()
    status.filter(has_text=VALID).wait_for()


def test_panels_fold_and_are_remembered(page, server):
    """The side bars and the bottom panels fold away (the canvas grows) and stay folded on reload."""
    before = page.locator(".react-flow__pane").bounding_box()
    for side in ("left", "right", "bottom"):
        page.get_by_test_id(f"toggle-{side}").click()
    wait_until(
        lambda: page.locator(".react-flow__pane").bounding_box()["height"] > before["height"] + 200,
        what="the canvas to grow",
    )
    grown = page.locator(".react-flow__pane").bounding_box()
    assert grown["width"] > before["width"] + 400
    page.screenshot(path=str(ARTIFACTS / "room-folded.png"))
    page.reload()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    wait_until(
        lambda: page.locator(".react-flow__pane").bounding_box()["width"] > before["width"] + 400,
        what="the folded panels to be remembered",
    )
    for side in ("left", "right", "bottom"):
        page.get_by_test_id(f"toggle-{side}").click()
    wait_until(
        lambda: abs(page.locator(".react-flow__pane").bounding_box()["width"] - before["width"]) < 2,
        what="the panels back",
    )
    # dragging the left bar's edge resizes it, and the size is remembered too
    left = page.locator("aside.left").bounding_box()
    grip = page.get_by_test_id("resize-left").bounding_box()
    gx, gy = centre(grip)
    page.mouse.move(gx, gy)
    page.mouse.down()
    page.mouse.move(gx + 60, gy, steps=5)
    page.mouse.up()
    wait_until(
        lambda: page.locator("aside.left").bounding_box()["width"] > left["width"] + 50,
        what="a wider left bar",
    )
    page.reload()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    wait_until(
        lambda: page.locator("aside.left").bounding_box()["width"] > left["width"] + 50,
        what="the width remembered",
    )
    page.evaluate("() => localStorage.clear()")
    page.reload()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()


def _overlays(page):
    return [
        page.locator(sel).first.bounding_box()
        for sel in (".react-flow__minimap", "[data-testid=canvas-controls]")
    ]


def _placed_well(page, node_id):
    pane = page.locator(".react-flow__pane").bounding_box()
    box = page.get_by_test_id(f"node-{node_id}").bounding_box()
    assert inside(box, pane), f"{node_id} in view"
    for o in _overlays(page):
        assert not overlaps(box, o), f"{node_id} under an overlay {o}"
    return box


def test_new_and_pasted_blocks_land_in_view(page, server):
    """A palette block lands in view; a paste lands at the pointer, or clear of the minimap near it."""
    show_program(page, server, CHAIN, settle=settled)
    page.get_by_test_id("palette-breathe").dblclick()
    wait_until(lambda: "breathe" in node_ids(server), what="breathe on the server")
    _placed_well(page, "breathe")
    # copy a block, paste it with the pointer over the canvas: there
    page.get_by_test_id("node-wave").click()
    page.keyboard.press("Control+c")
    pane = page.locator(".react-flow__pane").bounding_box()
    x, y = pane["x"] + pane["width"] * 0.35, pane["y"] + pane["height"] * 0.8
    page.mouse.move(x, y)
    page.keyboard.press("Control+v")
    wait_until(lambda: "wave_2" in node_ids(server), what="the paste on the server")
    box = _placed_well(page, "wave_2")
    assert (
        box["x"] - 40 <= x <= box["x"] + box["width"] + 40
        and box["y"] - 40 <= y <= box["y"] + box["height"] + 40
    )
    # with the pointer on the minimap's corner: still in view, and off the minimap
    mini = page.locator(".react-flow__minimap").bounding_box()
    page.mouse.move(mini["x"] + 10, mini["y"] + 10)
    page.keyboard.press("Control+v")
    wait_until(lambda: "wave_3" in node_ids(server), what="the second paste on the server")
    _placed_well(page, "wave_3")
    page.screenshot(path=str(ARTIFACTS / "room-paste.png"))


def test_rename_in_place(page, server):
    """F2 renames the selected block: its wires follow; a taken or invalid name is refused; one undo step."""
    show_program(page, server, CHAIN, settle=settled)
    page.get_by_test_id("node-rest").click()
    page.keyboard.press("F2")
    field = page.get_by_test_id("rename-rest")
    field.wait_for()
    field.fill("9 bad")
    field.press("Enter")
    toast = page.get_by_test_id("toast").filter(has_text="not a valid name")
    toast.wait_for()
    # a toast covers no control: not the canvas's buttons, not the subgraph bar's
    for control in page.locator("[data-testid=canvas-controls], .subgraph-bar button").all():
        assert not overlaps(toast.bounding_box(), control.bounding_box())
    page.get_by_test_id("node-rest").click()
    page.keyboard.press("F2")
    field.fill("mix")
    field.press("Enter")
    page.get_by_test_id("toast").filter(has_text="taken").wait_for()
    page.get_by_test_id("node-rest").click()
    page.keyboard.press("F2")
    field.fill("still")
    page.screenshot(path=str(ARTIFACTS / "room-rename.png"))
    field.press("Enter")
    wait_until(lambda: ("still", "out", "mix", "base") in edges(server), what="the renamed block's wire")
    assert "rest" not in node_ids(server)
    assert page.get_by_test_id("title-still").inner_text() == "still"
    page.keyboard.press("Control+z")
    wait_until(
        lambda: ("rest", "out", "mix", "base") in edges(server), what="one undo to bring the name back"
    )


def test_wire_on_a_body_connects_and_refusing_ports_dim(page, server):
    """A wire dropped on a block's body goes to its first free input that fits; while it is dragged,
    ports that cannot take it are dimmed and those that can are not."""
    show_program(page, server, CHAIN, settle=settled)
    src = handle(page, "smooth", "out", "source")
    sx, sy = centre(src.bounding_box())
    body = page.get_by_test_id("node-mix").bounding_box()
    bx, by = body["x"] + body["width"] / 2, body["y"] + body["height"] * 0.6
    page.mouse.move(sx, sy)
    page.mouse.down()
    page.mouse.move(sx + 20, sy + 5)
    page.mouse.move(bx, by, steps=8)

    def dimmed(node, port, kind):
        return "dimmed" in (handle(page, node, port, kind).get_attribute("class") or "")

    wait_until(lambda: dimmed("mix", "out", "source"), what="outputs to dim while an output is dragged")
    assert not dimmed("mix", "idle", "target"), "a frame input that takes the wire stays lit"
    assert not dimmed("mix", "base", "target"), "an occupied frame input could take it too"
    assert dimmed("mix", "idle_weight", "target"), "a float input cannot take a frame"
    page.screenshot(path=str(ARTIFACTS / "room-dim.png"))
    page.mouse.up()
    # the first free input that fits, not the occupied `base`
    wait_until(lambda: ("smooth", "out", "mix", "idle") in edges(server), what="the wire dropped on the body")
    assert ("rest", "out", "mix", "base") in edges(server)
    assert not dimmed("mix", "idle_weight", "target"), "nothing stays dimmed after the drop"


def test_library_subgraph_dragged_in_shows_its_ports_and_ungroups(page, server):
    """A library subgraph dragged from the palette lands at the drop point; inside it, Group Input and
    Group Output show where its exposed ports go; Ungroup puts its blocks back with the outer wires."""
    show_program(page, server, CHAIN, settle=settled)
    pane = page.locator(".react-flow__pane").bounding_box()
    drop = {"x": pane["width"] * 0.45, "y": pane["height"] * 0.85}  # below the blocks: nothing to move off
    page.get_by_test_id("palette-subgraph-sway").drag_to(
        page.locator(".react-flow__pane"), target_position=drop
    )
    node = page.get_by_test_id("node-sway")
    node.wait_for()
    box = node.bounding_box()
    # at the drop point (moved down, off any block it would cover), in view
    x = pane["x"] + drop["x"]
    assert box["x"] <= x <= box["x"] + box["width"] and inside(box, pane)
    drag(page, handle(page, "sway", "out", "source"), handle(page, "mix", "idle", "target"))
    wait_until(
        lambda: ("sway", "out", "mix", "idle") in edges(server), what="the subgraph wired on the server"
    )
    # inside: the stand-ins list the exposed ports, wired to the inner ones
    page.get_by_test_id("open-sway").click()
    page.get_by_test_id("node-group-io:input").wait_for()
    page.get_by_test_id("node-group-io:output").wait_for()
    assert page.get_by_test_id("group-port-amount").inner_text() == "amount"
    assert page.get_by_test_id("group-port-out").inner_text() == "out"
    assert page.locator(".react-flow__edge[data-id='smooth.out->group-io:output.out']").count() == 1
    page.screenshot(path=str(ARTIFACTS / "room-group-io.png"))
    page.get_by_test_id("crumb-0").click()
    page.get_by_test_id("node-mix").wait_for()
    # ungroup from the node's menu: fresh ids (the program has a wave and a smooth), the wire follows
    page.locator("[data-testid=node-sway] .block-header").click(button="right")
    page.get_by_test_id("context-menu").get_by_role("menuitem", name="Ungroup").click()
    wait_until(
        lambda: ("smooth_2", "out", "mix", "idle") in edges(server), what="the ungrouped wire on the server"
    )
    assert ("wave_2", "out", "smooth_2", "in") in edges(server)
    assert not any(n["type"] == "subgraph" for n in running_program(server)["nodes"])
    page.keyboard.press("Control+z")
    wait_until(lambda: ("sway", "out", "mix", "idle") in edges(server), what="one undo to group it again")


def test_bypass_greys_a_block_and_the_layer_box_edits_the_program(page, server):
    """A bypassed block is greyed and tagged at every zoom; a mixer's layer box is the program's
    `active` (saved with it, one undo step), not a runtime command."""
    prog = json.loads(json.dumps(CHAIN))
    prog["edges"].append({"from": {"node": "smooth", "port": "out"}, "to": {"node": "mix", "port": "idle"}})
    next(n for n in prog["nodes"] if n["id"] == "smooth")["bypass"] = True
    show_program(page, server, prog, settle=settled)
    smooth = page.get_by_test_id("node-smooth")

    def greyed():
        return float(smooth.evaluate("e => parseFloat(getComputedStyle(e).opacity)")) < 0.6

    assert "bypassed" in (smooth.get_attribute("class") or "") and greyed()
    page.get_by_test_id("bypassed-smooth").wait_for()
    for _ in range(6):  # zoomed out: collapsed, still greyed and tagged
        page.get_by_role("button", name="zoom out").click()
    wait_until(lambda: "compact" in (smooth.get_attribute("class") or ""), what="the blocks to collapse")
    assert greyed() and page.get_by_test_id("bypassed-smooth").is_visible()
    page.screenshot(path=str(ARTIFACTS / "room-bypassed.png"))
    page.get_by_role("button", name="fit view").click()
    settled(page)

    def idle_active():
        mix = next(n for n in running_program(server)["nodes"] if n["id"] == "mix")
        return mix["params"]["layers"][1].get("active", True)

    box = page.get_by_test_id("layer-mix-idle")
    box.wait_for()
    assert box.is_checked()
    box.click()
    wait_until(lambda: not idle_active(), what="the layer's `active` off in the program")
    assert not box.is_checked()
    page.get_by_test_id("undo").click()
    wait_until(idle_active, what="one undo to turn it back on")
    wait_until(box.is_checked, what="the box to follow the program")
