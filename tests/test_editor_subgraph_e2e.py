"""End-to-end: organising a program in the editor (headless Chromium against a real `nutty serve`).

Covers: selecting the idle-layer blocks of the bundled interactive program and grouping them into an
`idle` subgraph through the UI (the server then runs a program with that subgraph, still valid);
opening it (its blocks inside, a breadcrumb back); saving it to the robot's library, seeing it in the
palette and adding it to another program; a comment frame and a reroute point surviving a save and
reopen. Screenshots go to test-artifacts/.
"""

from __future__ import annotations

import pytest
from editor_browser import ARTIFACTS, BROWSER, ROOT, VALID, editor_page, scratch_robot
from editor_browser import wait_until as wait
from server_process import running_server

IDLE = ["breathe", "wander", "wander_filter", "weight_shift", "blink", "eyelid_filter"]

pytestmark = BROWSER


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    robot = scratch_robot(tmp_path_factory, keep=())  # saves go to a scratch copy of the robot
    for p in (robot / "subgraphs").glob("*.json"):
        p.unlink()
    program = ROOT / "robots" / "nutty_desk" / "programs" / "interactive.json"
    with running_server("--robot", str(robot), "--program", str(program), "--no-previz") as (url, _, client):
        yield {"url": url, "client": client, "robot": robot}


@pytest.fixture(scope="module")
def page(server):
    answers: dict[str, str] = {}

    def answer(dialog):  # a prompt is answered by its message's first matching key in `answers`
        if dialog.type == "prompt":
            key = next((k for k in answers if k in dialog.message), None)
            dialog.accept(answers.get(key, dialog.default_value) if key else dialog.default_value)
        else:
            dialog.accept()

    with editor_page(server["url"], on_dialog=answer) as pg:
        pg.answers = answers  # what the next prompt is answered with
        yield pg


def wait_until(fn, timeout=15.0, what="condition"):
    wait(fn, timeout, what)


def running(server):
    return server["client"].program()


def test_group_the_idle_layer_into_a_subgraph(page, server):
    page.get_by_test_id("node-mix").wait_for()
    for k, node in enumerate(IDLE):
        header = page.locator(f"[data-testid=node-{node}] .block-header")
        header.click(modifiers=["Shift"] if k else [])
    wait_until(
        lambda: page.locator(".react-flow__node.selected").count() == len(IDLE),
        what="the idle blocks selected",
    )
    page.get_by_test_id("group").click()
    dialog = page.get_by_test_id("group-dialog")
    dialog.wait_for()
    # the wires crossing the selection's edge are exposed (checked, and cannot be unchecked)
    for port in (
        "input-breathe.amplitude",
        "input-blink.gaze",
        "output-breathe.out",
        "output-eyelid_filter.out",
    ):
        box = page.get_by_test_id(f"expose-{port}")
        assert box.is_checked() and box.is_disabled()
    page.screenshot(path=str(ARTIFACTS / "organise-group-dialog.png"))
    page.get_by_test_id("group-name").fill("idle")
    page.get_by_test_id("group-confirm").click()
    page.get_by_test_id("node-idle").wait_for()
    assert all(page.get_by_test_id(f"node-{n}").count() == 0 for n in IDLE)

    def grouped():
        prog = running(server)["program"]
        return "idle" in (prog.get("subgraphs") or {}) and any(
            n["id"] == "idle" and n["type"] == "subgraph" for n in prog["nodes"]
        )

    wait_until(grouped, what="the server to run the grouped program")
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    state = running(server)
    assert state["report"]["valid"]
    definition = state["program"]["subgraphs"]["idle"]
    assert sorted(n["id"] for n in definition["nodes"]) == sorted(IDLE)
    wire = {"from": {"node": "idle", "port": "eyelid_filter_out"}, "to": {"node": "mix", "port": "blink"}}
    assert wire in state["program"]["edges"]
    # the inner blocks run under their flat ids
    profile = server["client"]._call("GET", "/api/profile")
    assert "idle/breathe" in {n["node"] for n in profile["nodes"]}
    page.screenshot(path=str(ARTIFACTS / "organise-grouped.png"))


def test_open_the_subgraph_and_go_back(page, server):
    page.locator("[data-testid=node-idle] .block-header").click()
    info = page.get_by_test_id("subgraph-info")
    info.wait_for()  # the selected subgraph node's ports, in the side panel
    assert "breathe_amplitude" in info.inner_text() and "eyelid_filter.out" in info.inner_text()
    page.get_by_test_id("open-idle").click()
    page.get_by_test_id("node-breathe").wait_for()
    assert page.get_by_test_id("node-mix").count() == 0
    crumbs = page.get_by_test_id("breadcrumb")
    assert "idle" in crumbs.inner_text() and "›" in crumbs.inner_text()
    assert page.get_by_test_id("node-wander_filter").count() == 1
    # live values of the inner blocks (they run as idle/breathe on the server)
    live = page.get_by_test_id("live-breathe.out")
    wait_until(lambda: live.inner_text() not in ("–", ""), what="a live value inside the subgraph")
    first = live.inner_text()
    wait_until(lambda: live.inner_text() != first, what="the inner block's live value to move")
    page.screenshot(path=str(ARTIFACTS / "organise-inside.png"))
    # its ports can be edited from inside: the exposed ones are checked
    page.get_by_test_id("edit-ports").click()
    page.get_by_test_id("group-dialog").wait_for()
    assert page.get_by_test_id("expose-output-eyelid_filter.out").is_checked()
    assert not page.get_by_test_id("expose-input-breathe.frequency").is_checked()
    page.get_by_role("button", name="Cancel").click()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()  # the program did not change
    assert running(server)["report"]["valid"]
    page.get_by_test_id("crumb-0").click()
    page.get_by_test_id("node-idle").wait_for()
    page.get_by_test_id("node-mix").wait_for()
    assert page.get_by_test_id("node-breathe").count() == 0


def test_save_to_library_and_add_it_to_another_program(page, server):
    page.locator("[data-testid=node-idle] .block-header").click()
    page.get_by_test_id("save-subgraph").click()
    dialog = page.get_by_test_id("save-as-dialog")  # the page's own dialog, not the browser's prompt
    assert dialog.get_attribute("aria-label") == "save subgraph as"
    page.get_by_test_id("save-as-name").fill("idle_layer")
    page.get_by_test_id("save-as-name").press("Enter")
    wait_until(
        lambda: "idle_layer" in server["client"]._call("GET", "/api/subgraphs"), what="the saved subgraph"
    )
    assert (server["robot"] / "subgraphs" / "idle_layer.json").exists()
    # saving it again under that name asks before replacing the library's file
    page.get_by_test_id("save-subgraph").click()
    page.get_by_test_id("save-as-name").fill("idle_layer")
    page.get_by_test_id("save-as-name").press("Enter")
    assert "subgraph 'idle_layer'" in page.get_by_test_id("save-as-overwrite").inner_text()
    page.keyboard.press("Escape")  # back to the name
    page.keyboard.press("Escape")  # closed, nothing saved
    wait_until(lambda: dialog.count() == 0, what="the dialog to close")
    page.get_by_test_id("palette-subgraph-idle_layer").wait_for()
    page.get_by_role("button", name="New").click()
    wait_until(lambda: page.get_by_test_id("node-mix").count() == 0, what="a blank program")
    page.get_by_test_id("add-subgraph-idle_layer").click()
    page.get_by_test_id("node-idle_layer").wait_for()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    page.get_by_test_id("go-live").click()  # New opened a draft: the robot runs it from Go live on

    def added():
        prog = running(server)["program"]
        return "idle_layer" in (prog.get("subgraphs") or {}) and any(
            n["id"] == "idle_layer" for n in prog["nodes"]
        )

    wait_until(
        added,
        timeout=30,
        what="the server to run the program with the library's subgraph "
        f"(mode {page.get_by_test_id('mode').inner_text()!r}, status {page.get_by_test_id('status').inner_text()!r}, "
        f"console {page.get_by_test_id('console').inner_text()[-300:]!r})",
    )
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    page.screenshot(path=str(ARTIFACTS / "organise-from-library.png"))


def stable_box(locator, what: str) -> dict:
    """The element's bounding box once two reads a poll apart (0.1 s) agree (the view may still be fitting)."""
    last = None

    def settled():
        nonlocal last
        box = locator.bounding_box()
        same, last = box is not None and box == last, box
        return same

    wait_until(settled, timeout=30, what=what)
    return last


def test_comment_and_reroute_survive_save_and_reopen(page, server):
    # The reroute first: a new comment lands in a free visible spot, which may be over the wire.
    edge = page.locator("[data-testid='rf__edge-rest.out->output.in'] path.react-flow__edge-path")
    box = stable_box(edge, "the wire rest -> output to stay put")
    page.mouse.dblclick(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.locator("[data-testid^=reroute-reroute-]").first.wait_for()
    page.get_by_test_id("add-comment").click()
    page.locator("[data-testid^=comment-note-]").first.wait_for()

    def kept_by_server():
        ui = running(server)["program"].get("ui") or {}
        return len(ui.get("comments", [])) == 1 and len(ui.get("reroutes", [])) == 1

    wait_until(
        kept_by_server, timeout=30, what="the server's program to keep the comment and the reroute in its ui"
    )
    page.screenshot(path=str(ARTIFACTS / "organise-comment-reroute.png"))
    page.get_by_test_id("save").click()  # never saved: the Save-as dialog asks for a name
    page.get_by_test_id("save-as-name").fill("e2e_organise")
    page.keyboard.press("Enter")
    wait_until(
        lambda: "e2e_organise" in server["client"]._call("GET", "/api/programs"), what="the saved program"
    )
    saved = server["client"]._call("GET", "/api/programs/e2e_organise")
    wire = {"from": {"node": "rest", "port": "out"}, "to": {"node": "output", "port": "in"}}
    assert saved["ui"]["reroutes"][0]["edge"] == wire
    assert saved["ui"]["comments"][0]["title"] == "Comment"
    assert "idle_layer" in saved["subgraphs"]
    page.get_by_role("button", name="New").click()
    wait_until(lambda: page.get_by_test_id("node-idle_layer").count() == 0, what="a blank program")
    assert page.locator("[data-testid^=comment-note-]").count() == 0
    page.get_by_label("open program").select_option("e2e_organise")
    page.get_by_test_id("node-idle_layer").wait_for()
    page.locator("[data-testid^=comment-note-]").first.wait_for()
    page.locator("[data-testid^=reroute-reroute-]").first.wait_for()
    page.locator(".react-flow__edge.routed, [data-testid='rf__edge-rest.out->output.in']").first.wait_for()
    page.screenshot(path=str(ARTIFACTS / "organise-reopened.png"))
