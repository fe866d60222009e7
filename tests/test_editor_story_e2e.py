"""End-to-end, in Chromium against a real `nutty serve`: a new user's whole session with the editor.

From an empty draft, the idle layer of the interactive program (breathing, and a filtered noise
wander, as additive layers over the rest pose) is built with the two fast ways only: dragging a
wire into empty space and picking from the search, and quick-add (Tab) at the pointer. Its blocks are
grouped into a reusable "idle" subgraph saved in the robot's library; the draft goes live without
the robot jumping (every recorded frame within the velocity, acceleration and jerk limits); and every
block on the graph then shows what it costs and what it outputs.
"""

from __future__ import annotations

import re
import time

import pytest
from editor_browser import (
    ARTIFACTS,
    BROWSER,
    VALID,
    centre,
    drag_to_point,
    editor_page,
    handle,
    scratch_robot,
    wait_until,
)
from playwright.sync_api import TimeoutError as PlaywrightTimeout
from server_process import running_server
from test_safe_swaps import assert_smooth, recorded_frames, recorded_positions

pytestmark = BROWSER


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    robot = scratch_robot(tmp_path_factory)
    record = robot.parent / "frames.jsonl"
    with running_server("--robot", str(robot), "--no-previz", "--record", str(record)) as (url, _, client):
        yield {"url": url, "client": client, "record": record, "robot": robot}


@pytest.fixture(scope="module")
def page(server):
    # the browser's own dialogs (a confirm before discarding unsaved edits) are accepted
    with editor_page(server["url"], on_dialog=lambda d: d.accept()) as pg:
        yield pg


def pane_point(page, fx, fy):
    box = page.locator(".react-flow__pane").bounding_box()
    return box["x"] + box["width"] * fx, box["y"] + box["height"] * fy


def empty_point(page, fx, fy):
    """The point of the pane's empty space nearest (fx, fy) of its box: a wire dropped there opens the
    quick-add search (one dropped on a node would not, nor one within React Flow's connection radius of
    a port, which connects to it; where nodes land after a fit varies)."""
    x0, y0 = pane_point(page, fx, fy)
    found = page.evaluate(
        """([x0, y0]) => {
            const ports = [...document.querySelectorAll(".react-flow__handle")].map((h) => {
                const r = h.getBoundingClientRect();
                return [r.x + r.width / 2, r.y + r.height / 2];
            });
            const nodes = [...document.querySelectorAll(".react-flow__node")].map((n) => n.getBoundingClientRect());
            const empty = (x, y) => {
                const el = document.elementFromPoint(x, y);
                return !!el && el.classList.contains("react-flow__pane")
                    && ports.every(([px, py]) => Math.hypot(px - x, py - y) > 48)
                    && nodes.every((r) => x < r.left - 12 || x > r.right + 12 || y < r.top - 12 || y > r.bottom + 12);
            };
            for (let r = 0; r <= 400; r += 20)
                for (let a = 0; a < 16; a++) {
                    const x = x0 + r * Math.cos((a * Math.PI) / 8), y = y0 + r * Math.sin((a * Math.PI) / 8);
                    if (empty(x, y)) return [x, y];
                }
            return null;
        }""",
        [x0, y0],
    )
    assert found is not None, "no empty space on the pane"
    return found


def wire_into_empty_space(page, src, fx, fy) -> None:
    """Drag a wire from `src` into the pane's empty space near (fx, fy) until the quick-add search opens.

    On a loaded 2-core machine the browser can drop a gesture (its first moves, while a node it just
    added still lays out); a person would drag again, and so does this, at most three times."""
    search = page.get_by_label("quick add search")
    for _ in range(3):
        settled(page)
        drag_to_point(page, src, *empty_point(page, fx, fy))
        try:
            search.wait_for(timeout=5000)
            return
        except PlaywrightTimeout:
            page.keyboard.press("Escape")
            fit(page)  # (a block the last fit left out may sit under the canvas controls)
    search.wait_for()  # the third miss fails here, with playwright's message


def settled(page) -> None:
    """Wait until the canvas's viewport stops moving (a fit animates it)."""
    viewport, last = page.locator(".react-flow__viewport"), None
    for _ in range(50):
        style = viewport.get_attribute("style")
        if style == last:
            return
        last = style
        time.sleep(0.1)


def pick(page, text, block):
    """Type in the open quick-add search and take `block`."""
    search = page.get_by_label("quick add search")
    search.wait_for()
    search.type(text)
    page.get_by_test_id(f"qa-{block}").wait_for()
    search.press("Enter")
    page.get_by_test_id(f"node-{block}").wait_for()


def fit(page):
    """Frame every block, as Fit does. On a loaded machine a block added a moment ago may not be measured
    yet, and Fit leaves it out (it can end up under the canvas controls): a person sees that and presses
    Fit again, and so does this, until every block is inside the canvas."""
    for _ in range(5):
        page.locator(".react-flow__pane").click(position={"x": 5, "y": 5})  # nothing selected: Fit frames all
        page.get_by_test_id("canvas-controls").get_by_role("button", name="Fit").click()
        time.sleep(0.2)
        settled(page)
        if all_blocks_in_view(page):
            return


def all_blocks_in_view(page) -> bool:
    """Whether every block lies inside the pane and clear of the canvas controls."""
    return page.evaluate(
        """() => {
            const pane = document.querySelector(".react-flow__pane").getBoundingClientRect();
            const controls = document.querySelector("[data-testid=canvas-controls]")?.getBoundingClientRect();
            const apart = (a, b) => a.right < b.left || a.left > b.right || a.bottom < b.top || a.top > b.bottom;
            return [...document.querySelectorAll(".react-flow__node")].every((n) => {
                const r = n.getBoundingClientRect();
                const inside = r.left >= pane.left && r.right <= pane.right && r.top >= pane.top
                    && r.bottom <= pane.bottom;
                return r.width > 0 && inside && (!controls || apart(r, controls));
            });
        }"""
    )


def draft_edges(page) -> set[tuple[str, str, str, str]]:
    """The draft's wires as the graph draws them (`rf__edge-<from>.<port>-><to>.<port>`)."""
    ids = page.locator(".react-flow__edge").evaluate_all("els => els.map(e => e.dataset.testid)")
    out = set()
    for i in ids:
        m = re.match(r"rf__edge-(.+)\.(.+)->(.+)\.(.+)$", i or "")
        if m:
            out.add(m.groups())
    return out


def test_build_group_and_go_live(page, server):
    from backend.engine.embodiment import load_embodiment

    client = server["client"]
    swaps = client.status()["swaps"]
    page.get_by_role("button", name="New").click()
    page.get_by_test_id("node-rest").wait_for()
    assert page.get_by_test_id("mode").inner_text().startswith("draft")
    fit(page)
    # 1. a wire from the rest pose into empty space -> "layer mixer": the rest pose is its base layer
    wire_into_empty_space(page, handle(page, "rest", "out", "source"), 0.45, 0.8)
    pick(page, "layer mix", "layer_mixer")
    assert ("rest", "out", "layer_mixer", "base") in draft_edges(page)
    fit(page)
    # the mixer's output dropped on the output's occupied input replaces the rest pose's wire
    drag_to_point(
        page,
        handle(page, "layer_mixer", "out", "source"),
        *centre(handle(page, "output", "in", "target").bounding_box()),
    )
    wait_until(
        lambda: ("layer_mixer", "out", "output", "in") in draft_edges(page), what="the mixer on the output"
    )
    assert ("rest", "out", "output", "in") not in draft_edges(page)
    # two additive layers on the mixer, from its layer stack
    page.locator("[data-testid=node-layer_mixer] .block-header").click()
    for layer in ("idle", "wander"):
        page.get_by_test_id("ls-new-name").fill(layer)
        page.get_by_test_id("ls-add").click()
        handle(page, "layer_mixer", layer, "target").wait_for()
    fit(page)
    # 2. from the idle layer's input into empty space -> "breathing", which feeds it
    wire_into_empty_space(page, handle(page, "layer_mixer", "idle", "target"), 0.12, 0.25)
    pick(page, "breath", "breathe")
    # 3. quick-add (Tab) at the pointer: a smooth noise, then from its output -> a motion filter
    fit(page)
    page.mouse.move(*empty_point(page, 0.1, 0.85))
    page.keyboard.press("Tab")
    pick(page, "smooth noise", "noise")
    fit(page)
    wire_into_empty_space(page, handle(page, "noise", "out", "source"), 0.3, 0.9)
    pick(page, "motion filter", "motion_filter")
    fit(page)
    drag_to_point(
        page,
        handle(page, "motion_filter", "out", "source"),
        *centre(handle(page, "layer_mixer", "wander", "target").bounding_box()),
    )
    wait_until(
        lambda: (
            {
                ("breathe", "out", "layer_mixer", "idle"),
                ("noise", "out", "motion_filter", "in"),
                ("motion_filter", "out", "layer_mixer", "wander"),
            }
            <= draft_edges(page)
        ),
        what="the idle wiring",
    )
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    assert client.status()["swaps"] == swaps  # a draft: the robot has not been touched
    page.screenshot(path=str(ARTIFACTS / "story-built.png"))

    # 4. group the idle blocks into a reusable "idle" subgraph, and keep it in the robot's library
    fit(page)
    for i, node in enumerate(("breathe", "noise", "motion_filter")):
        page.locator(f"[data-testid=node-{node}] .block-header").click(modifiers=["Shift"] if i else [])
    page.get_by_test_id("group").click()
    page.get_by_test_id("group-name").fill("idle")
    page.get_by_test_id("group-confirm").click()
    page.get_by_test_id("node-idle").wait_for()
    assert page.get_by_test_id("node-breathe").count() == 0
    # the wires that crossed the selection now leave the subgraph node, from its exposed outputs
    assert {
        ("idle", "breathe_out", "layer_mixer", "idle"),
        ("idle", "motion_filter_out", "layer_mixer", "wander"),
    } <= draft_edges(page), draft_edges(page)
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    page.locator("[data-testid=node-idle] .block-header").click()
    page.get_by_test_id("save-subgraph").click()
    page.get_by_test_id("save-as-name").fill("idle")  # the editor's dialog names it
    page.get_by_test_id("save-as-save").click()
    wait_until(lambda: "idle" in client._call("GET", "/api/subgraphs"), what="the subgraph in the library")
    page.get_by_test_id("palette-subgraph-idle").wait_for()

    # 5. go live: the robot moves to the new program within its limits
    desk = load_embodiment("nutty_desk")
    rows = lambda: recorded_frames(server["record"])
    start = len(rows())
    page.get_by_test_id("go-live").click()
    page.get_by_test_id("mode").filter(has_text="live").wait_for()
    wait_until(
        lambda: any(n["type"] == "subgraph" for n in client.program()["program"]["nodes"]),
        timeout=30,
        what="the program on the robot",
    )
    assert client.status()["swaps"] == swaps + 1
    time.sleep(2.5)  # the swap's transition and then some
    frames = rows()[max(0, start - 5) :]
    assert_smooth(desk, recorded_positions(desk, frames), 100.0)

    # 6. every block shows its cost, and (zoomed in) its output moving
    ids = ["rest", "layer_mixer", "idle", "output"]
    for node in ids:
        badge = page.get_by_test_id(f"cook-{node}")
        wait_until(
            lambda badge=badge: re.search(r"\d+(\.\d+)?\s*(µs|ms)", badge.inner_text() or ""),
            timeout=20,
            what=f"the cook time of {node}",
        )
    page.locator("[data-testid=node-idle] .block-header").click()
    page.keyboard.press("f")  # frame the subgraph node: its outputs' values and sparklines show
    value = page.get_by_test_id("live-idle.breathe_out")
    value.wait_for()
    first = value.inner_text()
    wait_until(lambda: value.inner_text() not in (first, "–"), what="the idle subgraph's output to move")
    page.screenshot(path=str(ARTIFACTS / "story-live.png"))
