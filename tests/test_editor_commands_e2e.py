"""End-to-end: the editor's commands in headless Chromium against a real `nutty serve` (issue #29, points
7, 8 and 10).

As a user does it, each checked against the server's running program where the program changes: M
bypasses the selected block (the server's program carries `bypass: true`, the block is greyed, Ctrl+Z
takes it back); Shift+D duplicates the selection with its inner wires at the pointer; Ctrl+F finds a
block by name and frames it; "." frames the selection; "?" lists every shortcut; a comment frame is made
around the selection; the light theme changes the canvas and stays after a reload. Screenshots go to
test-artifacts/.
"""

from __future__ import annotations

import time

import pytest
from editor_browser import (
    ARTIFACTS,
    BROWSER,
    VALID,
    canvas_point,
    centre,
    editor_page,
    editor_server,
    running_program,
    show_program,
    wait_until,
    zoom,
)

pytestmark = BROWSER

# A small chain: a source, two operators (one feeding the other), a mixer and the output.
CHAIN = {
    "format": "nutty-program/1",
    "name": "commands chain",
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
        {"id": "louder", "type": "gain_offset", "params": {}, "ui": {"x": 660, "y": 260}},
        {
            "id": "mix",
            "type": "layer_mixer",
            "ui": {"x": 990, "y": 40},
            "params": {"layers": [{"name": "base"}, {"name": "idle", "mode": "additive"}]},
        },
        {"id": "output", "type": "output", "params": {}, "ui": {"x": 1320, "y": 40}},
    ],
    "edges": [
        {"from": {"node": "rest", "port": "out"}, "to": {"node": "mix", "port": "base"}},
        {"from": {"node": "wave", "port": "out"}, "to": {"node": "smooth", "port": "in"}},
        {"from": {"node": "smooth", "port": "out"}, "to": {"node": "louder", "port": "in"}},
        {"from": {"node": "louder", "port": "out"}, "to": {"node": "mix", "port": "idle"}},
        {"from": {"node": "mix", "port": "out"}, "to": {"node": "output", "port": "in"}},
    ],
}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with editor_server(tmp_path_factory) as s:
        yield s


@pytest.fixture(scope="module")
def page(server):
    with editor_page(server["url"], on_dialog=lambda d: d.accept()) as pg:
        yield pg


def server_node(server, node_id):
    return next((n for n in running_program(server)["nodes"] if n["id"] == node_id), None)


def select(page, *ids):
    for k, node_id in enumerate(ids):
        page.locator(f"[data-testid=node-{node_id}] .block-header").click(modifiers=["Shift"] if k else [])
    wait_until(lambda: page.locator(".react-flow__node.selected").count() == len(ids), what=f"{ids} selected")


def pointer_on_canvas(page, fx=0.5, fy=0.5):
    page.mouse.move(*canvas_point(page, fx, fy))


def test_m_bypasses_the_selected_block(page, server):
    """M over the canvas bypasses the selected operator: the program the server runs says so, the block is
    greyed; Ctrl+Z takes it back; a source cannot be bypassed and a notice says why."""
    show_program(page, server, CHAIN)
    select(page, "smooth")
    pointer_on_canvas(page, 0.5, 0.95)
    page.keyboard.press("m")
    wait_until(
        lambda: (server_node(server, "smooth") or {}).get("bypass") is True, what="bypass on the server"
    )
    block = page.get_by_test_id("node-smooth")
    wait_until(lambda: "bypassed" in (block.get_attribute("class") or ""), what="the block greyed")
    page.screenshot(path=str(ARTIFACTS / "commands-bypass.png"))
    page.keyboard.press("Control+z")
    wait_until(lambda: "bypass" not in (server_node(server, "smooth") or {"bypass": 1}), what="bypass undone")
    assert "bypassed" not in (block.get_attribute("class") or "")
    # the context menu offers it too
    page.locator("[data-testid=node-louder] .block-header").click(button="right")
    page.get_by_role("menuitem", name="Bypass (M)").click()
    wait_until(
        lambda: (server_node(server, "louder") or {}).get("bypass") is True, what="bypass from the menu"
    )
    # a source has no frame to pass through
    select(page, "rest")
    pointer_on_canvas(page, 0.5, 0.95)
    page.keyboard.press("m")
    page.get_by_test_id("toast").filter(has_text="cannot bypass rest").wait_for()
    assert "bypass" not in server_node(server, "rest")


def test_shift_d_duplicates_at_the_pointer(page, server):
    """Shift+D copies the selected blocks with the wire between them, at the pointer, selected; the
    server's validation sees them (the copied filter's input is not wired yet)."""
    show_program(page, server, CHAIN)
    select(page, "smooth", "louder")
    x, y = canvas_point(page, 0.3, 0.8)
    page.mouse.move(x, y)
    page.keyboard.press("Shift+D")
    # the copied filter has no input yet: the program is invalid until it is wired, so the editor is checked
    page.get_by_test_id("node-louder_2").wait_for()
    page.get_by_test_id("rf__edge-smooth_2.out->louder_2.in").wait_for()
    copies = page.locator("[data-testid^='rf__edge-'][data-testid*='_2']")
    assert copies.count() == 1, "only the wire between the copies is copied"
    copy = page.get_by_test_id("node-smooth_2").bounding_box()
    assert abs(copy["x"] + copy["width"] / 2 - x) < copy["width"], "the first copy is at the pointer"
    assert abs(copy["y"] - y) < 60
    selected = page.locator(".react-flow__node.selected")
    assert sorted(selected.nth(i).get_attribute("data-id") for i in range(selected.count())) == [
        "louder_2",
        "smooth_2",
    ]
    page.screenshot(path=str(ARTIFACTS / "commands-duplicate.png"))
    page.get_by_test_id("error-smooth_2").wait_for()


def test_ctrl_f_finds_and_frames_a_block(page, server):
    """Ctrl+F, a few letters of a name, Enter: that block is selected and framed; Escape closes the box."""
    show_program(page, server, CHAIN)
    page.mouse.click(*canvas_point(page, 0.02, 0.98))  # nothing selected
    page.keyboard.press("Control+f")
    box = page.get_by_label("find block")
    box.wait_for()
    box.type("loud")
    page.get_by_test_id("find-louder").wait_for()
    page.screenshot(path=str(ARTIFACTS / "commands-find.png"))
    box.press("Enter")
    assert page.get_by_test_id("find-block").count() == 0
    wait_until(
        lambda: page.locator(".react-flow__node.selected").get_attribute("data-id") == "louder",
        what="the found block selected",
    )
    pane = page.locator(".react-flow__pane").bounding_box()
    px, py = centre(pane)

    def framed():
        bx, by = centre(page.get_by_test_id("node-louder").bounding_box())
        return abs(bx - px) < 30 and abs(by - py) < 30

    wait_until(framed, what="the found block at the canvas's centre")
    page.keyboard.press("Control+f")
    box.wait_for()
    box.press("Escape")
    assert page.get_by_test_id("find-block").count() == 0


def test_dot_frames_the_selection(page, server):
    """ "." frames the selected blocks: they fill the view, at a zoom where their names read."""
    show_program(page, server, CHAIN)
    select(page, "wave", "smooth")
    pointer_on_canvas(page)
    page.keyboard.press(".")
    pane = page.locator(".react-flow__pane").bounding_box()
    px, _ = centre(pane)

    def framed():
        a = page.get_by_test_id("node-wave").bounding_box()
        b = page.get_by_test_id("node-smooth").bounding_box()
        mid = (a["x"] + b["x"] + b["width"]) / 2
        return abs(mid - px) < 30 and b["x"] + b["width"] - a["x"] > pane["width"] * 0.5

    wait_until(framed, what="the selection framed")
    assert zoom(page) >= 0.42


def test_question_mark_lists_every_shortcut(page, server):
    """ "?" shows the list of shortcuts (the keys the handlers read); "?" or Escape hides it."""
    show_program(page, server, CHAIN)
    pointer_on_canvas(page)
    page.keyboard.press("?")
    help_ = page.get_by_test_id("shortcut-help")
    help_.wait_for()
    text = help_.inner_text()
    for key in ("Shift+D", "Ctrl+F", "Ctrl+Z", "Ctrl+Enter", "F2", "Tab", "Space", "Delete", "M", "."):
        assert key in text, f"{key} listed"
    page.screenshot(path=str(ARTIFACTS / "commands-shortcuts.png"))
    page.keyboard.press("?")
    wait_until(lambda: help_.count() == 0, what="? hides the list")
    page.get_by_test_id("shortcuts").click()
    help_.wait_for()
    page.keyboard.press("Escape")
    wait_until(lambda: help_.count() == 0, what="Escape hides the list")


def test_comment_frame_around_the_selection(page, server):
    """A comment made with blocks selected surrounds them, with a margin."""
    show_program(page, server, CHAIN)
    select(page, "wave", "smooth")
    page.get_by_test_id("add-comment").click()
    frame = page.locator("[data-testid^=comment-note-]").first
    frame.wait_for()
    f = frame.bounding_box()
    for node_id in ("wave", "smooth"):
        b = page.get_by_test_id(f"node-{node_id}").bounding_box()
        assert f["x"] < b["x"] and f["y"] < b["y"], f"{node_id} inside the frame (top left)"
        assert b["x"] + b["width"] < f["x"] + f["width"] and b["y"] + b["height"] < f["y"] + f["height"]
    wait_until(
        lambda: len((running_program(server).get("ui") or {}).get("comments", [])) == 1,
        what="the comment kept",
    )


def background(page):
    return page.evaluate("getComputedStyle(document.querySelector('.graph')).backgroundColor")


def lightness(rgb: str) -> float:
    r, g, b = (int(v) for v in rgb[rgb.index("(") + 1 : rgb.index(")")].split(",")[:3])
    return (r + g + b) / 3


def test_light_theme_stays_after_reload(page, server):
    """The top bar's toggle turns the editor light (the canvas turns light, blocks white); a reload keeps it."""
    show_program(page, server, CHAIN)
    start = page.evaluate("document.documentElement.dataset.theme")
    if start == "light":  # the system prefers light: go dark first, the toggle's other way
        page.get_by_test_id("theme-toggle").click()
    assert lightness(background(page)) < 80, "dark canvas"
    page.get_by_test_id("theme-toggle").click()
    wait_until(lambda: lightness(background(page)) > 200, what="a light canvas")
    block = page.get_by_test_id("node-smooth")
    assert lightness(block.evaluate("e => getComputedStyle(e).backgroundColor")) > 200
    page.get_by_test_id("node-output").wait_for()
    time.sleep(0.3)
    page.screenshot(path=str(ARTIFACTS / "commands-theme-light.png"))
    page.reload()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    assert page.evaluate("document.documentElement.dataset.theme") == "light"
    assert lightness(background(page)) > 200
    page.get_by_test_id("theme-toggle").click()
    wait_until(lambda: lightness(background(page)) < 80, what="dark again")
    page.screenshot(path=str(ARTIFACTS / "commands-theme-dark.png"))


def _switch_theme(page, want: str) -> None:
    """The top bar's toggle clicked until the page is `want` (a click that landed while the top bar was
    re-laid out under a loaded machine is clicked again; a page already there is not toggled away)."""

    def there() -> bool:
        if page.evaluate("document.documentElement.dataset.theme") == want:
            return True
        page.get_by_test_id("theme-toggle").click()
        time.sleep(0.3)
        return page.evaluate("document.documentElement.dataset.theme") == want

    wait_until(there, timeout=30, what=f"the {want} theme")


def test_previz_follows_the_theme(page, server):
    """With a Pre-Viz (this server has none: its description is stood in for), the editor asks the server
    to give the Pre-Viz scene the editor's theme, on opening and on every switch."""
    import json

    asked: list[str] = []

    def previz(route):
        info = {"url": "about:blank", "direct": None, "token_required": False, "ghost": False}
        route.fulfill(status=200, content_type="application/json", body=json.dumps(info))

    def theme(route):
        body = json.loads(route.request.post_data or "{}")
        asked.append(body.get("theme"))
        route.fulfill(status=200, content_type="application/json", body=json.dumps(body))

    page.route("**/api/previz", previz)
    page.route("**/api/previz/theme", theme)
    try:
        page.reload()
        page.get_by_test_id("status").filter(has_text=VALID).wait_for()
        first = page.evaluate("document.documentElement.dataset.theme")
        wait_until(lambda: asked[-1:] == [first], timeout=30, what="the Pre-Viz given the theme on opening")
        other = "dark" if first == "light" else "light"
        for want in (other, first):  # switched, then back
            _switch_theme(page, want)
            wait_until(
                lambda want=want: asked[-1:] == [want], timeout=30, what=f"the Pre-Viz given the {want} theme"
            )
    finally:
        page.unroute("**/api/previz")
        page.unroute("**/api/previz/theme")


def test_theme_follows_the_system_until_chosen(page, server):
    """With no theme chosen, the editor takes the system's (prefers-color-scheme); a choice outlasts it."""
    show_program(page, server, CHAIN)
    try:
        page.evaluate("localStorage.removeItem('nutty.theme')")
        for scheme in ("dark", "light"):
            page.emulate_media(color_scheme=scheme)
            page.reload()
            page.get_by_test_id("status").filter(has_text=VALID).wait_for()
            assert page.evaluate("document.documentElement.dataset.theme") == scheme
        page.get_by_test_id("theme-toggle").click()  # light -> dark, chosen
        page.emulate_media(color_scheme="light")
        page.reload()
        page.get_by_test_id("status").filter(has_text=VALID).wait_for()
        assert page.evaluate("document.documentElement.dataset.theme") == "dark"
    finally:
        page.evaluate("localStorage.removeItem('nutty.theme')")
        page.emulate_media(color_scheme="no-preference")
