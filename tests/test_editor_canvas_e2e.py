"""End-to-end: the editor's canvas in headless Chromium against a real `nutty serve` (issue #14, parts 1–2).

As a user does it, each checked against the server's running program: the editor opens readable (block
titles ≥ 11 px on screen, in view); a wire dragged from an output into empty space opens the search and
Enter adds a block wired to it; Tab and Shift+A add a block at the pointer; a wire dropped on an occupied
input replaces the old wire; deleting a wired block and one Ctrl+Z restores it with all its wires (and no
PUT ever carried the block without them); the context menu of a wire inserts a block on it; Ctrl+A
selects every block. Screenshots go to test-artifacts/.
"""

from __future__ import annotations

import json
import time

import pytest
from editor_browser import (
    ARTIFACTS,
    BROWSER,
    canvas_point,
    centre,
    drag,
    drag_to_point,
    edges,
    editor_page,
    editor_server,
    empty_canvas_point,
    handle,
    running_program,
    show_program,
    wait_until,
    zoom,
)

READABLE_PX = 11.0

pytestmark = BROWSER

# A small chain the wiring tests start from (loaded on the server, then the page reloads it).
CHAIN = {
    "format": "nutty-program/1",
    "name": "canvas chain",
    "max_level": 3,
    "inputs": [],
    "ui": {},
    "nodes": [
        {"id": "rest", "type": "rest_pose", "params": {}, "ui": {"x": 0, "y": 0}},
        {
            "id": "wave",
            "type": "sine",
            "params": {"dofs": ["head_*"], "amplitude": 0.1},
            "ui": {"x": 0, "y": 200},
        },
        {
            "id": "swell",
            "type": "lfo",
            "params": {"frequency": 0.5, "amplitude": 0.2, "offset": 0.5},
            "ui": {"x": 0, "y": 420},
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
        {"from": {"node": "swell", "port": "value"}, "to": {"node": "smooth", "port": "sigma"}},
        {"from": {"node": "smooth", "port": "out"}, "to": {"node": "mix", "port": "idle"}},
        {"from": {"node": "mix", "port": "out"}, "to": {"node": "output", "port": "in"}},
    ],
}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with editor_server(tmp_path_factory) as s:
        yield s


@pytest.fixture(scope="module")
def page(server):
    # leaving with unsaved changes on reload: accepted
    with editor_page(server["url"], on_dialog=lambda d: d.accept()) as pg:
        yield pg


def node_types(server):
    return {n["id"]: n["type"] for n in running_program(server)["nodes"]}


def test_opens_readable(page, server):
    """(a) The running 28-block program opens at a zoom where block titles are ≥ 11 px tall, in view."""
    assert len(running_program(server)["nodes"]) >= 20
    page.get_by_test_id("node-output").wait_for()
    time.sleep(0.5)
    z = zoom(page)
    pane = page.locator(".react-flow__pane").bounding_box()
    titles = page.locator(".react-flow__node .block-title")
    visible = 0
    for i in range(titles.count()):
        t = titles.nth(i)
        box = t.bounding_box()
        x, y = centre(box)
        if not (pane["x"] <= x <= pane["x"] + pane["width"] and pane["y"] <= y <= pane["y"] + pane["height"]):
            continue
        visible += 1
        font = float(t.evaluate("e => parseFloat(getComputedStyle(e).fontSize)"))
        assert font * z >= READABLE_PX, f"title {t.inner_text()!r} is {font * z:.1f} px on screen"
        assert box["height"] >= READABLE_PX
    assert visible >= 4, "the opening view shows a few blocks"
    # the output is in view: the part of the graph that matters
    ox, oy = centre(page.get_by_test_id("node-output").bounding_box())
    assert pane["x"] <= ox <= pane["x"] + pane["width"] and pane["y"] <= oy <= pane["y"] + pane["height"]
    page.screenshot(path=str(ARTIFACTS / "canvas-open.png"))
    # Fit keeps titles readable too
    page.get_by_role("button", name="fit view").click()
    time.sleep(0.4)
    # collapsed titles grow as the zoom shrinks: their size on screen is what stays readable
    title = page.locator(".react-flow__node .block-title").first
    wait_until(
        lambda: (
            zoom(page) * float(title.evaluate("e => parseFloat(getComputedStyle(e).fontSize)")) >= READABLE_PX
        ),
        what="titles readable after Fit",
    )


def test_drag_wire_into_empty_space_opens_search(page, server):
    """(b) A wire from an output dropped in empty space -> search -> Enter: a block wired to that output."""
    show_program(page, server, CHAIN)
    x, y = canvas_point(page, 0.5, 0.85)
    drag_to_point(page, handle(page, "wave", "out", "source"), x, y)
    search = page.get_by_label("quick add search")
    search.wait_for()
    assert page.get_by_test_id("qa-sine").count() == 0, "only blocks that take a frame"
    search.type("exagg")
    page.get_by_test_id("qa-exaggerate").wait_for()
    page.screenshot(path=str(ARTIFACTS / "canvas-drag-search.png"))
    search.press("Enter")
    wait_until(
        lambda: node_types(server).get("exaggerate") == "exaggerate", what="the new block on the server"
    )
    wait_until(
        lambda: ("wave", "out", "exaggerate", "in") in edges(server), what="the new wire on the server"
    )
    assert page.get_by_test_id("quick-add").count() == 0
    # Escape closes the search and adds nothing
    drag_to_point(page, handle(page, "wave", "out", "source"), *canvas_point(page, 0.3, 0.9))
    search.wait_for()
    search.press("Escape")
    assert page.get_by_test_id("quick-add").count() == 0


def _flow_pos(page, node_id):
    return page.get_by_test_id(f"node-{node_id}").bounding_box()


def test_quick_add_at_the_cursor(page, server):
    """(c) Tab and Shift+A over the canvas open the search at the pointer; the block lands there."""
    show_program(page, server, CHAIN)
    for key, block, fx, fy in (("Tab", "lfo", 0.45, 0.88), ("Shift+A", "noise", 0.8, 0.86)):
        x, y = canvas_point(page, fx, fy)
        page.mouse.move(x, y)
        page.keyboard.press(key)
        search = page.get_by_label("quick add search")
        search.wait_for()
        qa = page.get_by_test_id("quick-add").bounding_box()
        # at the pointer (a corner of it there: it opens left of / above the pointer near the canvas's edges)
        assert min(abs(qa["x"] - x), abs(qa["x"] + qa["width"] - x)) < 40, "the search opens at the pointer"
        assert min(abs(qa["y"] - y), abs(qa["y"] + qa["height"] - y)) < 40, "the search opens at the pointer"
        search.type(block)
        search.press("Enter")
        wait_until(lambda block=block: block in node_types(server), what=f"{block} on the server")
        box = _flow_pos(page, block)
        assert box["x"] - 60 <= x <= box["x"] + box["width"] + 60, f"{block} near the pointer (x)"
        assert box["y"] - 60 <= y <= box["y"] + box["height"] + 60, f"{block} near the pointer (y)"
    # a tap of Space too: all blocks, grouped by category; Escape closes it
    page.mouse.move(*canvas_point(page, 0.6, 0.5))
    page.keyboard.press("Space")
    page.get_by_label("quick add search").wait_for()
    assert page.locator(".qa-group").count() >= 4
    page.keyboard.press("Escape")
    assert page.get_by_test_id("quick-add").count() == 0
    # not while typing in a field
    page.get_by_label("program name").focus()
    page.keyboard.press("Shift+A")
    page.keyboard.press("Tab")
    assert page.get_by_test_id("quick-add").count() == 0
    # a palette double-click adds the block in the visible part of the canvas
    page.get_by_test_id("palette-breathe").dblclick()
    wait_until(lambda: "breathe" in node_types(server), what="breathe on the server")
    pane = page.locator(".react-flow__pane").bounding_box()
    box = page.get_by_test_id("node-breathe").bounding_box()
    assert pane["x"] <= box["x"] and box["x"] + box["width"] <= pane["x"] + pane["width"]
    assert pane["y"] <= box["y"] and box["y"] + box["height"] <= pane["y"] + pane["height"]


def test_drop_on_occupied_input_replaces_the_wire(page, server):
    """(d) A wire dropped on an input that has one replaces it."""
    show_program(page, server, CHAIN)
    assert ("rest", "out", "mix", "base") in edges(server)
    drag(page, handle(page, "wave", "out", "source"), handle(page, "mix", "base", "target"))
    wait_until(lambda: ("wave", "out", "mix", "base") in edges(server), what="the new wire on the server")
    assert ("rest", "out", "mix", "base") not in edges(server)
    assert page.get_by_test_id("toast").count() == 0
    # one undo step brings the old wire back
    page.keyboard.press("Control+z")
    wait_until(lambda: ("rest", "out", "mix", "base") in edges(server), what="undo to restore the old wire")
    assert ("wave", "out", "mix", "base") not in edges(server)


def test_delete_and_undo_is_one_step(page, server):
    """(e) Delete a wired block, one Ctrl+Z: block and all its wires are back; no PUT had it without them."""
    show_program(page, server, CHAIN)
    bodies = []

    def record(request):
        if request.method == "PUT" and request.url.endswith("/api/program"):
            bodies.append(json.loads(request.post_data))

    page.on("request", record)
    try:
        before = edges(server)
        wires = {e for e in before if "smooth" in (e[0], e[2])}
        assert len(wires) == 3
        page.get_by_test_id("node-smooth").click()
        page.keyboard.press("Delete")
        wait_until(lambda: "smooth" not in node_types(server), what="the block deleted on the server")
        assert not any("smooth" in (e[0], e[2]) for e in edges(server))
        page.keyboard.press("Control+z")
        wait_until(
            lambda: "smooth" in node_types(server) and edges(server) == before,
            what="undo to restore block and wires",
        )
        time.sleep(0.3)
    finally:
        page.remove_listener("request", record)
    assert bodies, "the edits went to the server"
    for body in bodies:
        prog = body.get("program", body)
        has_block = any(n["id"] == "smooth" for n in prog["nodes"])
        sent = {
            (e["from"]["node"], e["from"]["port"], e["to"]["node"], e["to"]["port"]) for e in prog["edges"]
        }
        assert not has_block or wires <= sent, "a PUT carried the block without its wires"


def test_wire_menu_inserts_a_block(page, server):
    """(f) Right-click a wire -> Insert block… -> the block sits between the wire's ends on the server."""
    show_program(page, server, CHAIN)
    edge = page.locator(".react-flow__edge[data-id='mix.out->output.in'] .react-flow__edge-interaction")
    if edge.count() == 0:
        edge = page.locator(".react-flow__edge[data-id='mix.out->output.in'] path").first
    a = handle(page, "mix", "out", "source").bounding_box()
    b = handle(page, "output", "in", "target").bounding_box()
    (ax, ay), (bx, by) = centre(a), centre(b)
    page.mouse.click((ax + bx) / 2, (ay + by) / 2, button="right")
    menu = page.get_by_test_id("context-menu")
    menu.wait_for()
    page.screenshot(path=str(ARTIFACTS / "canvas-wire-menu.png"))
    menu.get_by_role("menuitem", name="Insert block…").click()
    search = page.get_by_label("quick add search")
    search.wait_for()
    assert page.get_by_test_id("qa-sine").count() == 0, "only blocks with a frame input and output"
    search.type("safety")
    search.press("Enter")
    wait_until(lambda: "safety_limiter" in node_types(server), what="the inserted block on the server")
    wait_until(
        lambda: (
            {("mix", "out", "safety_limiter", "in"), ("safety_limiter", "out", "output", "in")}
            <= edges(server)
        ),
        what="the block between the wire's ends",
    )
    assert ("mix", "out", "output", "in") not in edges(server)
    # the canvas menu too
    page.mouse.click(*empty_canvas_point(page), button="right")
    menu.wait_for()
    assert menu.get_by_role("menuitem", name="Auto-layout").count() == 1
    page.screenshot(path=str(ARTIFACTS / "canvas-menu.png"))
    page.keyboard.press("Escape")
    assert page.get_by_test_id("context-menu").count() == 0


def test_select_all(page, server):
    """(g) Ctrl+A selects every block."""
    show_program(page, server, CHAIN)
    page.mouse.click(*canvas_point(page, 0.05, 0.05))
    assert page.locator(".react-flow__node.selected").count() < len(CHAIN["nodes"])
    page.keyboard.press("Control+a")
    wait_until(
        lambda: page.locator(".react-flow__node.selected").count() == len(CHAIN["nodes"]),
        what="all blocks selected",
    )
    assert page.locator(".react-flow__node").count() == len(CHAIN["nodes"])
