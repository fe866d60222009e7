"""End-to-end: numbers at an animator's pace, and saving under a name (headless Chromium, real server).

Covers: a number field takes free typing ("-0.2" reaches the robot once, on Enter, and nothing while it is
typed), refuses text that is not a number with a visible hint, clamps to the hard range, takes values
beyond the soft range (the slider pins at its end), reverts on Escape and steps with the arrow keys; a
drag on its label scrubs the value and is one undo step, as is a slider drag with pauses in it; a burst
of Ctrl+Z while live is one hot swap; inside a subgraph a slider drag sends only PATCHes, which the
server keeps in the definition; Save as is an in-page dialog that refuses bad names visibly and asks
before replacing a file; an exposed input's field sends one value, on Enter. Screenshots go to
test-artifacts/.
"""

from __future__ import annotations

import json
import re

import pytest
from editor_browser import (
    ARTIFACTS,
    BROWSER,
    ROOT,
    VALID,
    editor_page,
    editor_server,
    wait_until,
)

pytestmark = BROWSER

WAVE = {
    "id": "wave",
    "type": "sine",
    "params": {"dofs": ["head_*"], "amplitude": 0.1},
    "ui": {"x": 0, "y": 0},
}
OUTPUT = {"id": "output", "type": "output", "params": {}, "ui": {"x": 320, "y": 0}}

# A sine on the head, shaped by a gain: two blocks whose parameters the tests type, step and drag.
FIELDS = {
    "format": "nutty-program/1",
    "name": "fields",
    "max_level": 3,
    "inputs": [],
    "ui": {},
    "nodes": [
        WAVE,
        {"id": "shape", "type": "gain_offset", "params": {}, "ui": {"x": 160, "y": 0}},
        OUTPUT,
    ],
    "edges": [
        {"from": {"node": "wave", "port": "out"}, "to": {"node": "shape", "port": "in"}},
        {"from": {"node": "shape", "port": "out"}, "to": {"node": "output", "port": "in"}},
    ],
}

# The same sine inside a subgraph `wave_sg`, used by the node `idle` (inner blocks run as idle/wave).
NESTED = {
    "format": "nutty-program/1",
    "name": "nested",
    "max_level": 3,
    "inputs": [],
    "ui": {},
    "subgraphs": {
        "wave_sg": {
            "description": "a sine",
            "nodes": [WAVE],
            "edges": [],
            "inputs": [],
            "outputs": [{"name": "out", "node": "wave", "port": "out"}],
        }
    },
    "nodes": [
        {"id": "idle", "type": "subgraph", "params": {"subgraph": "wave_sg"}, "ui": {"x": 0, "y": 0}},
        OUTPUT,
    ],
    "edges": [{"from": {"node": "idle", "port": "out"}, "to": {"node": "output", "port": "in"}}],
}

PROGRAM_REQUEST = re.compile(r"/api/program(/|\?|$)")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with editor_server(
        tmp_path_factory, {"programs/fields.json": FIELDS}, program="programs/fields.json"
    ) as s:
        yield s


@pytest.fixture(scope="module")
def page(server):
    with editor_page(server["url"], on_dialog=lambda d: d.accept()) as pg:
        pg.dialogs = []  # browser dialogs (prompt, confirm) seen: Save as must open none
        pg.on("dialog", lambda d: pg.dialogs.append(d.type))
        yield pg


class Requests:
    """The program requests (PUT, PATCH, validate) the page sends from now on."""

    def __init__(self, page):
        self.sent: list[tuple[str, str]] = []
        self.page = page
        page.on("request", self._seen)

    def _seen(self, r) -> None:
        if PROGRAM_REQUEST.search(r.url):
            self.sent.append((r.method, r.url))

    def of(self, method: str) -> list[str]:
        return [u for m, u in self.sent if m == method]

    def stop(self) -> None:
        self.page.remove_listener("request", self._seen)


def param(server, node: str, name: str):
    prog = server["client"].program()["program"]
    return next(n for n in prog["nodes"] if n["id"] == node)["params"].get(name)


def select(page, node: str) -> None:
    page.locator(f"[data-testid=node-{node}] .block-header").click()
    page.get_by_test_id("param-panel").filter(has_text=node).wait_for()


def blur(page) -> None:
    page.evaluate("() => document.activeElement && document.activeElement.blur()")


def test_typing_sends_only_the_committed_value(page, server):
    select(page, "wave")
    text = page.get_by_test_id("param-offset-text")
    requests = Requests(page)
    text.click()
    text.press("Control+a")
    for key in "-0.2":  # "-", "-0", "-0." are on the way: none of them may reach the robot
        text.press(key)
        page.wait_for_timeout(120)
    assert text.input_value() == "-0.2"
    assert requests.of("PATCH") == [] and requests.of("PUT") == [], requests.sent
    text.press("Enter")
    wait_until(lambda: param(server, "wave", "offset") == -0.2, what="the typed offset on the robot")
    page.wait_for_timeout(300)
    assert len(requests.of("PATCH")) == 1 and requests.of("PUT") == [], requests.sent
    # cleared, then left: nothing is sent, the value stays
    text.fill("")
    blur(page)
    assert page.get_by_test_id("param-offset-hint").inner_text().startswith("type a number")
    assert text.input_value() == "-0.2"
    # not a number: refused with a hint, the field shows its value again
    text.fill("abc")
    text.press("Enter")
    hint = page.get_by_test_id("param-offset-hint")
    assert "'abc' is not a number" in hint.inner_text()
    assert text.input_value() == "-0.2"
    page.wait_for_timeout(300)
    assert len(requests.of("PATCH")) == 1, requests.sent
    requests.stop()
    page.get_by_test_id("param-panel").screenshot(path=str(ARTIFACTS / "fields-refused.png"))


def test_soft_and_hard_ranges_escape_and_arrows(page, server):
    select(page, "wave")
    text = page.get_by_test_id("param-amplitude-text")
    slider = page.get_by_test_id("param-amplitude")
    assert (slider.get_attribute("min"), slider.get_attribute("max")) == ("0", "1")  # x-soft
    # beyond the soft range, inside the hard one: taken; the slider pins at its end
    text.fill("3")
    text.press("Enter")
    wait_until(lambda: param(server, "wave", "amplitude") == 3, what="an amplitude beyond the soft range")
    assert slider.input_value() == "1"
    # beyond the hard range (10): clamped, and the field says so
    text.fill("50")
    text.press("Enter")
    wait_until(lambda: param(server, "wave", "amplitude") == 10, what="the amplitude clamped to its maximum")
    assert "limited to max 10" in page.get_by_test_id("param-amplitude-hint").inner_text()
    text.fill("0.2")
    text.press("Enter")
    wait_until(lambda: param(server, "wave", "amplitude") == 0.2, what="0.2, reachable")
    # Escape: back to the value the field had when it was entered, nothing sent
    blur(page)
    text.click()
    text.fill("0.9")
    text.press("Escape")
    assert text.input_value() == "0.2"
    page.wait_for_timeout(300)
    assert param(server, "wave", "amplitude") == 0.2
    # arrows step by the block's x-step (0.005), Shift a tenth of it, Ctrl ten times it
    text.press("ArrowUp")
    wait_until(lambda: param(server, "wave", "amplitude") == 0.205, what="one step up")
    text.press("Shift+ArrowDown")
    wait_until(lambda: param(server, "wave", "amplitude") == 0.2045, what="a fine step down")
    text.press("Control+ArrowUp")
    wait_until(lambda: param(server, "wave", "amplitude") == 0.2545, what="a coarse step up")
    blur(page)


def _undo(page) -> None:
    blur(page)
    page.keyboard.press("Control+z")


def _undo_burst_in_page(page, times: int, gap_ms: int) -> None:
    """Ctrl+Z `times` times, `gap_ms` apart, timed by the page's own clock.

    Pressed from Python, each key is a round trip whose delay on a loaded 2-core machine can exceed the
    editor's undo quiet window; in the page, the presses and the editor's sync timer share one event loop,
    so a late press is never overtaken by the sync it should have postponed.
    """
    blur(page)
    page.evaluate(
        """async ([times, gap]) => {
            for (let k = 0; k < times; k++) {
                const key = { key: "z", code: "KeyZ", ctrlKey: true, bubbles: true, cancelable: true };
                document.body.dispatchEvent(new KeyboardEvent("keydown", key));
                document.body.dispatchEvent(new KeyboardEvent("keyup", key));
                if (k < times - 1) await new Promise((done) => setTimeout(done, gap));
            }
        }""",
        [times, gap_ms],
    )


def test_a_label_scrub_is_live_and_one_undo_step(page, server):
    select(page, "shape")
    text = page.get_by_test_id("param-gain-text")
    text.fill("1.5")
    text.press("Enter")
    wait_until(lambda: param(server, "shape", "gain") == 1.5, what="gain 1.5")
    page.wait_for_timeout(700)  # the next edit is a new undo step
    blur(page)
    label = page.get_by_test_id("param-gain-label")
    box = label.bounding_box()
    x, y = box["x"] + 10, box["y"] + box["height"] / 2
    requests = Requests(page)
    page.mouse.move(x, y)
    page.mouse.down()
    for k in range(1, 11):  # 40 px to the right in 10 moves, with a pause longer than the undo coalescing
        page.mouse.move(x + 4 * k, y)
        page.wait_for_timeout(700 if k == 5 else 30)
    page.mouse.up()
    # 20 steps of 0.01 (gain's x-step)
    wait_until(lambda: param(server, "shape", "gain") == 1.7, what="the scrubbed gain on the robot")
    assert text.input_value() == "1.7"
    assert len(requests.of("PATCH")) >= 2 and requests.of("PUT") == [], requests.sent  # live while dragged
    requests.stop()
    # the whole drag, pause included, is one undo step
    _undo(page)
    wait_until(
        lambda: param(server, "shape", "gain") == 1.5, what="one undo back to the gain before the drag"
    )
    assert text.input_value() == "1.5"
    # a click on the label without moving focuses the text to type
    label.click()
    assert page.evaluate("() => document.activeElement?.dataset.testid") == "param-gain-text"
    blur(page)


def test_a_slider_drag_with_a_pause_is_one_undo_step(page, server):
    select(page, "wave")
    slider = page.get_by_test_id("param-frequency")
    slider.fill("1")
    wait_until(lambda: param(server, "wave", "frequency") == 1, what="frequency 1")
    page.wait_for_timeout(700)
    box = slider.bounding_box()
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + box["width"] * 0.5, y)
    page.mouse.down()
    for k in range(10):
        page.mouse.move(box["x"] + box["width"] * (0.5 + 0.04 * k), y)
        page.wait_for_timeout(700 if k == 4 else 30)
    page.mouse.up()
    wait_until(lambda: param(server, "wave", "frequency") > 2, what="the dragged frequency")
    _undo(page)
    wait_until(lambda: param(server, "wave", "frequency") == 1, what="one undo back to before the drag")


def test_a_burst_of_undo_is_one_hot_swap(page, server):
    text = page.get_by_test_id
    for k in range(6):  # alternate the blocks: each commit is its own undo step
        node, name = ("wave", "offset") if k % 2 == 0 else ("shape", "offset")
        select(page, node)
        value = round(0.1 * (k + 1), 2)
        text(f"param-{name}-text").fill(str(value))
        text(f"param-{name}-text").press("Enter")
        wait_until(lambda n=node, v=value: param(server, n, "offset") == v, what=f"{node}.offset = {value}")
    blur(page)
    page.wait_for_timeout(500)
    requests = Requests(page)
    _undo_burst_in_page(page, times=4, gap_ms=120)
    # two undone on each block: back to the first two values
    wait_until(lambda: param(server, "wave", "offset") == 0.1, what="the undone offsets on the robot")
    assert param(server, "shape", "offset") == 0.2
    page.wait_for_timeout(1000)  # a second PUT would have gone by now
    assert len(requests.of("PUT")) == 1, requests.sent
    assert requests.of("PATCH") == [], requests.sent
    requests.stop()


def test_save_as_is_a_dialog(page, server):
    page.dialogs.clear()
    page.get_by_role("button", name="Save as").click()
    dialog = page.get_by_test_id("save-as-dialog")
    dialog.wait_for()
    name = page.get_by_test_id("save-as-name")
    assert name.input_value() == "fields"
    # a name the library would refuse: said, and Enter does not close the dialog
    name.fill("my fields")
    name.press("Enter")
    assert "no spaces" in page.get_by_test_id("save-as-problem").inner_text()
    assert dialog.is_visible()
    page.screenshot(path=str(ARTIFACTS / "fields-save-as-refused.png"))
    # Escape cancels: nothing saved
    name.press("Escape")
    dialog.wait_for(state="detached")
    # a new name: saved at once, and the program takes its name
    page.get_by_role("button", name="Save as").click()
    page.get_by_test_id("save-as-name").fill("fields_copy")
    page.keyboard.press("Enter")
    path = server["robot"] / "programs" / "fields_copy.json"
    wait_until(
        lambda: path.exists() and json.loads(path.read_text())["name"] == "fields_copy", what="the saved file"
    )
    wait_until(lambda: page.get_by_label("program name").input_value() == "fields_copy", what="the new name")
    # an existing name: asked before replacing; Escape goes back, Replace saves
    page.get_by_role("button", name="Save as").click()
    page.get_by_test_id("save-as-name").fill("interactive")
    page.keyboard.press("Enter")
    page.get_by_test_id("save-as-overwrite").wait_for()
    page.screenshot(path=str(ARTIFACTS / "fields-save-as-overwrite.png"))
    page.keyboard.press("Escape")
    page.get_by_test_id("save-as-name").wait_for()
    page.keyboard.press("Enter")
    page.get_by_test_id("save-as-replace").click()
    target = server["robot"] / "programs" / "interactive.json"
    wait_until(
        lambda: (
            json.loads(target.read_text())["name"] == "interactive"
            and any(n["type"] == "sine" for n in json.loads(target.read_text())["nodes"])
        ),
        what="the library's interactive program replaced",
    )
    assert page.get_by_test_id("save-as-dialog").count() == 0
    assert page.dialogs == [], "no browser prompt or confirm"
    # live, the new name reaches the robot too (before the next test swaps in another program)
    wait_until(
        lambda: server["client"].program()["program"]["name"] == "interactive", what="the renamed program"
    )


def test_a_slider_drag_inside_a_subgraph_sends_only_patches(page, server):
    server["client"].load_program(NESTED)
    page.reload()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    swaps = server["client"].status()["swaps"]  # opening the subgraph and selecting in it swap nothing either
    requests = Requests(page)
    page.locator("[data-testid=node-idle] .block-header").dblclick()  # opens the subgraph
    select(page, "wave")
    slider = page.get_by_test_id("param-amplitude")
    box = slider.bounding_box()
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + 4, y)
    page.mouse.down()
    for k in range(20):
        page.mouse.move(box["x"] + 4 + (box["width"] / 2) * k / 19, y)
        page.wait_for_timeout(20)
    page.mouse.up()
    final = float(slider.input_value())
    assert final > 0.3

    def kept():
        prog = server["client"].program()["program"]
        inner = next(n for n in prog["subgraphs"]["wave_sg"]["nodes"] if n["id"] == "wave")
        return inner["params"].get("amplitude") == final

    wait_until(kept, what="the dragged amplitude in the running program's definition")
    page.wait_for_timeout(600)
    assert requests.of("PUT") == [], requests.sent
    patches = requests.of("PATCH")
    assert patches and all(re.search(r"/nodes/idle(/|%2F)wave/params", u) for u in patches), patches
    assert server["client"].status()["swaps"] == swaps
    requests.stop()
    page.screenshot(path=str(ARTIFACTS / "fields-subgraph-slider.png"))


def test_an_exposed_input_takes_typed_values(page, server):
    server["client"].load_program(
        json.loads((ROOT / "robots" / "nutty_desk" / "programs" / "interactive.json").read_text())
    )
    page.reload()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    text = page.get_by_test_id("input-valence-text")
    sent: list[str] = []
    page.on("request", lambda r: sent.append(r.method) if "/api/inputs/valence" in r.url else None)
    text.click()
    text.press("Control+a")
    for key in "-0.5":
        text.press(key)
    page.wait_for_timeout(300)
    assert sent == [], "nothing sent while typing"
    text.press("Enter")
    wait_until(
        lambda: server["client"]._call("GET", "/api/inputs")["values"]["valence"] == -0.5,
        what="the typed valence",
    )
    assert page.get_by_label("input valence").input_value() == "-0.5"  # the slider follows
    assert sent == ["PUT"]
