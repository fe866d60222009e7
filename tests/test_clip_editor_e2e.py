"""The clip editor in a real browser on a real `nutty serve` (#30): a 2 s nod with an overshoot made
entirely in the browser (keys, a pose, a handle drag), saved, played on the robot and compared with the
editor's curve at every tick; a take recorded with the pose sliders and played back; the deep link,
"Edit clip" and the constant-pose block's pose field.

The server runs a program with no stage-2 filter (a clip player and a puppet layer over the rest pose),
so what the engine plays can be compared with the editor's curve directly: the program's frame is
recorded (`source: "program"`, before the safety net, which may smooth a key's jerk)."""

from __future__ import annotations

import json
import math
import time

import httpx
import numpy as np
import pytest
from editor_browser import BROWSER, editor_page, editor_server, wait_until

from backend.engine.clips import compile_clip
from backend.engine.embodiment import load_embodiment

pytestmark = BROWSER

RATE = 100.0
PROGRAM = {
    "format": "nutty-program/1",
    "name": "clipcheck",
    "max_level": 3,
    "inputs": [],
    "nodes": [
        {"id": "rest", "type": "rest_pose", "params": {}},
        {"id": "gesture", "type": "clip_player", "params": {"crossfade": 0.0, "clip": "wave"}},
        {"id": "hold", "type": "pose", "params": {"values": {}}},
        {"id": "puppet", "type": "puppet", "params": {"timeout": 0.5, "fade_in": 0.2, "fade_out": 0.3}},
        {
            "id": "mix",
            "type": "layer_mixer",
            "params": {
                "layers": [
                    {"name": "base"},
                    {"name": "hold", "mode": "override"},
                    {"name": "gesture", "mode": "override"},
                    {"name": "puppet", "mode": "override"},
                ]
            },
        },
        {"id": "output", "type": "output", "params": {}},
    ],
    "edges": [
        {"from": {"node": "rest", "port": "out"}, "to": {"node": "mix", "port": "base"}},
        {"from": {"node": "hold", "port": "out"}, "to": {"node": "mix", "port": "hold"}},
        {"from": {"node": "gesture", "port": "out"}, "to": {"node": "mix", "port": "gesture"}},
        {"from": {"node": "puppet", "port": "out"}, "to": {"node": "mix", "port": "puppet"}},
        {"from": {"node": "puppet", "port": "weight"}, "to": {"node": "mix", "port": "puppet_weight"}},
        {"from": {"node": "mix", "port": "out"}, "to": {"node": "output", "port": "in"}},
    ],
}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    files = {"programs/clipcheck.json": PROGRAM}
    with editor_server(tmp_path_factory, files=files, program="programs/clipcheck.json") as s:
        s["http"] = httpx.Client(base_url=s["url"], timeout=30)
        yield s
        s["http"].close()


@pytest.fixture(scope="module")
def page(server):
    with editor_page(server["url"], on_dialog=lambda d: d.accept()) as pg:
        yield pg


def api(server, method, path, **kw):
    res = server["http"].request(method, path, **kw)
    assert res.status_code == 200, res.text
    return res.json()


def scrub(page, t: float) -> None:
    """Click the ruler at clip time `t` (s) and wait until the playhead is there (frame-snapped)."""
    ruler = page.get_by_test_id("clip-ruler")
    box = ruler.bounding_box()
    t0, t1, gutter = (float(ruler.get_attribute(a)) for a in ("data-t0", "data-t1", "data-gutter"))
    x = box["x"] + gutter + (t - t0) / (t1 - t0) * (box["width"] - gutter)
    page.mouse.click(x, box["y"] + box["height"] / 2)
    wait_until(
        lambda: abs(float(page.get_by_test_id("clip-playhead").get_attribute("data-t")) - t) < 0.02,
        what=f"the playhead at {t} s",
    )


def key_pose(page, dof: str, value: float) -> None:
    field = page.get_by_test_id(f"pose-{dof}")
    field.fill(str(value))
    field.press("Enter")
    page.get_by_test_id("clip-key-pose").click()


def editor_doc(page) -> dict:
    return page.evaluate("() => window.__nuttyClipEditor.doc()")


def take_samples(server, dofs, seconds, source, during):
    """Record `dofs` from `source` while `during()` runs and `seconds` pass; the take's samples as
    (t, values) (a zero tolerance keeps every sample as a key)."""
    api(server, "POST", "/api/record/start", json={"dofs": dofs, "source": source})
    during()
    time.sleep(seconds)
    name = f"check-{time.monotonic_ns()}"
    take = api(server, "POST", "/api/record/stop", json={"name": name, "tolerance": 0.0})
    api(server, "DELETE", f"/api/clips/{name}")
    tracks = take["clip"]["tracks"]
    t = np.array([k["t"] for k in tracks[dofs[0]]])
    return t, np.array([[k["v"] for k in tracks[d]] for d in dofs]).T


def best_alignment(played: np.ndarray, expected: np.ndarray) -> float:
    """The largest difference between `expected` (one value per tick from the clip's start) and the
    recording `played` at the tick offset that fits best (the play starts on some tick of the take)."""
    n = len(expected)
    errs = [np.max(np.abs(played[j : j + n] - expected)) for j in range(len(played) - n + 1)]
    return float(min(errs))


def test_a_nod_with_an_overshoot_made_in_the_browser_plays_as_drawn(page, server):
    page.get_by_test_id("tab-clips").click()
    page.get_by_test_id("clip-new").click()
    page.get_by_test_id("clip-name").fill("browser_nod")
    page.get_by_test_id("clip-name").press("Enter")
    page.get_by_test_id("clip-editor").wait_for()
    page.get_by_test_id("track-head_pitch").click()  # the DoF the keys go to
    scrub(page, 0.0)
    page.get_by_test_id("dopesheet").focus()
    page.keyboard.press("i")  # a key at the playhead for the selected DoF: its rest value
    page.get_by_test_id("key-head_pitch-0").wait_for()
    for t, v in ((0.6, 0.3), (1.3, -0.06), (2.0, 0.0)):  # down, the overshoot back up, settle
        scrub(page, t)
        key_pose(page, "head_pitch", v)
    page.get_by_test_id("key-head_pitch-3").wait_for()
    keys = editor_doc(page)["tracks"]["head_pitch"]
    assert [(k["t"], k["v"]) for k in keys] == [(0.0, 0.0), (0.6, 0.3), (1.3, -0.06), (2.0, 0.0)]

    # a key dragged in the dopesheet moves in frame steps; one undo puts it back
    box = page.get_by_test_id("key-head_pitch-3").bounding_box()
    kx, ky = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(kx, ky)
    page.mouse.down()
    page.mouse.move(kx + 40, ky, steps=5)
    page.mouse.up()
    moved = editor_doc(page)["tracks"]["head_pitch"][3]["t"]
    assert moved > 2.0 and abs(moved * 30 - round(moved * 30)) < 1e-6  # on a frame of the clip's 30 fps
    page.get_by_test_id("clip-undo").click()
    assert editor_doc(page)["tracks"]["head_pitch"][3]["t"] == 2.0

    # a handle drag: the overshoot key's right handle pulled down makes it dip deeper
    page.get_by_test_id("gkey-head_pitch-2").click()
    handle = page.get_by_test_id("handle-head_pitch-2-right")
    before = page.evaluate("() => window.__nuttyClipEditor.sample('head_pitch', [1.45])")[0]
    hb = handle.bounding_box()
    hx, hy = hb["x"] + hb["width"] / 2, hb["y"] + hb["height"] / 2
    page.mouse.move(hx, hy)
    page.mouse.down()
    page.mouse.move(hx + 4, hy + 20, steps=6)
    page.mouse.up()
    key = editor_doc(page)["tracks"]["head_pitch"][2]
    assert key["right_type"] == "aligned" and key["left_type"] == "aligned" and key["right"][1] < 0
    after = page.evaluate("() => window.__nuttyClipEditor.sample('head_pitch', [1.45])")[0]
    assert after < before - 0.005  # the segment after the overshoot now dips deeper

    page.get_by_test_id("clip-save").click()
    wait_until(lambda: page.get_by_test_id("clip-dirty").count() == 0, what="the clip saved")
    saved = api(server, "GET", "/api/clips/browser_nod")
    assert saved["tracks"]["head_pitch"][2]["right"] == key["right"]

    # the editor's curve is the engine's playback code's, at every tick
    ticks = np.arange(0, round(2.0 * RATE) + 1) / RATE
    drawn = np.array(page.evaluate("(t) => window.__nuttyClipEditor.sample('head_pitch', t)", ticks.tolist()))
    emb = load_embodiment(server["robot"])
    clip = compile_clip(saved, emb)
    row = int(np.flatnonzero(clip.channels == emb.dof("head_pitch").channels.start)[0])
    engine = np.array([clip.curves.evaluate(float(t))[row] for t in ticks])
    assert np.max(np.abs(drawn - engine)) < 1e-9

    # and on the robot: what the program plays, tick by tick, within 0.1° of the editor's curve
    scrub(page, 0.0)  # "On robot" plays from the playhead

    def play():
        page.get_by_test_id("clip-on-robot").check()

    t, values = take_samples(server, ["head_pitch"], 2.6, "program", play)
    page.get_by_test_id("clip-on-robot").uncheck()
    assert best_alignment(values[:, 0], drawn) < math.radians(0.1)


def test_a_take_puppeteered_with_the_sliders_plays_back_within_005_rad(page, server):
    page.get_by_test_id("track-head_yaw").click()
    page.get_by_test_id("pose-live").check()
    page.get_by_test_id("clip-record").click()
    page.get_by_test_id("record-countin").wait_for()
    page.get_by_test_id("record-elapsed").wait_for(timeout=10000)
    field = page.get_by_test_id("pose-head_yaw")
    start = time.monotonic()
    while (t := time.monotonic() - start) < 3.0:  # the performer sweeps the head left and right
        field.fill(f"{0.35 * math.sin(2 * math.pi * 0.4 * t):.3f}")
        field.press("Enter")
        time.sleep(0.04)
    field.fill("0")
    field.press("Enter")
    time.sleep(0.5)
    page.get_by_test_id("clip-record-stop").click()
    report = page.get_by_test_id("record-report")
    report.wait_for()
    assert "head_yaw" in report.inner_text()
    page.get_by_test_id("pose-live").uncheck()
    wait_until(
        lambda: page.get_by_test_id("clip-editor").get_attribute("data-clip") == "browser_nod-take-1",
        what="the take opened",
    )
    take = api(server, "GET", "/api/clips/browser_nod-take-1")
    assert take["source"]["recorded"] == "output"
    performance = take["tracks"]["head_yaw"]
    assert 2 <= len(performance) < 250 and max(abs(k["v"]) for k in performance) > 0.25

    emb = load_embodiment(server["robot"])
    clip = compile_clip(take, emb)
    row = int(np.flatnonzero(clip.channels == emb.dof("head_yaw").channels.start)[0])
    expected = np.array([clip.curves.evaluate(j / RATE)[row] for j in range(int(clip.duration * RATE))])
    time.sleep(1.0)  # the puppet layer has faded out: the take alone moves the head
    scrub(page, 0.0)

    def play():
        page.get_by_test_id("clip-on-robot").check()

    _, values = take_samples(server, ["head_yaw"], clip.duration + 0.8, "output", play)
    page.get_by_test_id("clip-on-robot").uncheck()
    assert best_alignment(values[:, 0], expected) < 0.05


def test_deep_link_edit_clip_and_the_pose_field(page, server):
    page.goto(server["url"] + "/?clip=nod")
    page.get_by_test_id("clip-editor").wait_for()
    wait_until(
        lambda: page.get_by_test_id("clip-editor").get_attribute("data-clip") == "nod", what="nod open"
    )
    page.get_by_test_id("key-head_pitch-2").wait_for()
    assert page.get_by_test_id("anchor-down").count() == 1
    rev = int(page.get_by_test_id("clip-editor").get_attribute("data-helper-rev") or 0)
    page.get_by_test_id("track-head_pitch").click()
    page.get_by_test_id("clip-ghost").select_option("B")  # this program has no stage 2: a preset's ghost
    page.get_by_test_id("ghost-head_pitch").wait_for()
    page.get_by_test_id("limit-head_pitch-acceleration").wait_for()  # the bundled nod is too quick for it
    assert int(page.get_by_test_id("clip-editor").get_attribute("data-helper-rev") or 0) >= rev

    # an edit, then another clip: the editor asks before dropping the edit
    page.get_by_test_id("dopesheet").focus()
    page.keyboard.press("x")  # the selection (none yet): nothing to lose
    page.get_by_test_id("key-head_pitch-2").click()
    page.keyboard.press("x")
    page.get_by_test_id("clip-dirty").wait_for()
    page.get_by_test_id("tab-clips").click()
    page.get_by_test_id("clip-open-wave").click()
    page.get_by_test_id("clip-confirm").wait_for()
    page.get_by_test_id("clip-confirm-cancel").click()
    assert page.get_by_test_id("clip-editor").get_attribute("data-clip") == "nod"
    page.get_by_test_id("tab-clip").click()
    page.get_by_test_id("clip-undo").click()
    wait_until(lambda: page.get_by_test_id("clip-dirty").count() == 0, what="the edit undone")

    # a clip the robot cannot play (written by another tool): the server's refusal sits on its track
    broken = {
        "format": "nutty-clip/1",
        "tracks": {
            "head_pitch": [{"t": 0, "v": 0}, {"t": 1, "v": 0.1}],
            "antenna": [{"t": 0, "v": 0}, {"t": 1, "v": 0.2}],
        },
    }
    (server["robot"] / "clips" / "broken.json").write_text(json.dumps(broken))
    page.get_by_test_id("tab-clips").click()
    page.get_by_test_id("clip-open-broken").click()
    wait_until(lambda: page.get_by_test_id("clip-editor").get_attribute("data-clip") == "broken", what="open")
    page.get_by_test_id("clip-save").click()
    page.get_by_test_id("clip-error").wait_for()
    assert "antenna" in page.get_by_test_id("clip-error").inner_text()
    row = page.get_by_test_id("track-antenna")
    wait_until(lambda: "has-error" in (row.get_attribute("class") or ""), what="the error on its track")
    assert "has-error" not in (page.get_by_test_id("track-head_pitch").get_attribute("class") or "")

    page.get_by_test_id("tab-program").click()
    page.get_by_test_id("node-gesture").click()
    page.get_by_test_id("param-edit-clip").click()
    wait_until(
        lambda: page.get_by_test_id("clip-editor").get_attribute("data-clip") == "wave", what="wave open"
    )

    # the constant-pose block's values: one field per DoF, not a JSON box
    page.get_by_test_id("tab-program").click()
    page.get_by_test_id("node-hold").click()
    page.get_by_test_id("posefield-add").select_option("ear_right")
    field = page.get_by_test_id("posefield-ear_right-text")
    field.fill("0.4")
    field.press("Enter")

    def hold_values():
        node = next(n for n in api(server, "GET", "/api/program")["program"]["nodes"] if n["id"] == "hold")
        return node["params"].get("values", {})

    wait_until(
        lambda: hold_values().get("ear_right") == pytest.approx(0.4), what="the pose reached the program"
    )
    page.get_by_test_id("posefield-remove-ear_right").click()
    wait_until(lambda: "ear_right" not in hold_values(), what="the DoF removed")


FAKE_GAMEPAD = """
window.__pad = {id: "test pad", index: 0, connected: true, mapping: "standard", timestamp: 0,
                axes: [0, 0, 0, 0], buttons: []};
navigator.getGamepads = () => [window.__pad];
"""


def test_a_gamepad_stick_puppeteers_a_take(page, server):
    """The browser's Gamepad API (a stand-in pad: headless Chromium has no device) drives a chosen DoF
    live through the puppet layer, and Record turns the performance into a clip."""
    page.add_init_script(FAKE_GAMEPAD)
    page.goto(server["url"] + "/?clip=browser_nod")
    wait_until(
        lambda: page.get_by_test_id("clip-editor").get_attribute("data-clip") == "browser_nod", what="open"
    )
    page.evaluate("() => window.dispatchEvent(new Event('gamepadconnected'))")
    page.get_by_test_id("pose-pad-x").select_option("ear_left")
    page.get_by_test_id("pose-live").check()
    page.get_by_test_id("track-ear_left").click()
    page.get_by_test_id("clip-record").click()
    page.get_by_test_id("record-elapsed").wait_for(timeout=10000)
    start = time.monotonic()
    while (t := time.monotonic() - start) < 2.5:  # the stick swings right and back
        page.evaluate("(x) => { window.__pad.axes = [x, 0, 0, 0]; }", 0.8 * math.sin(math.pi * t / 2.5))
        time.sleep(0.05)
    page.evaluate("() => { window.__pad.axes = [0, 0, 0, 0]; }")
    time.sleep(0.6)
    page.get_by_test_id("clip-record-stop").click()
    page.get_by_test_id("record-report").wait_for()
    page.get_by_test_id("pose-live").uncheck()
    wait_until(
        lambda: page.get_by_test_id("clip-editor").get_attribute("data-clip") != "browser_nod",
        what="take open",
    )
    name = page.get_by_test_id("clip-editor").get_attribute("data-clip")
    take = api(server, "GET", f"/api/clips/{name}")
    peak = max(k["v"] for k in take["tracks"]["ear_left"])
    ear = load_embodiment(server["robot"]).dof("ear_left")
    assert peak > 0.3 * ear.max  # the stick's swing, within the DoF's limits, reached the robot
    assert peak <= ear.max + 1e-9
