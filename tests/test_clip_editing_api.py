"""The clip editor's server side (#30): clip errors that name their key, the Pre-Viz preview pose and
its lease, turning a link in the preview, recorded takes (key reduction, report, playback), and
play_clip with an unsaved document from a clip time."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.graph.builder import ProgramBuilder
from backend.pose_preview import PosePreview
from backend.session import EngineSession

RATE = 100.0


def layered_program():
    """A puppet layer over a clip player, no stage-2 filter: what a take records is what plays back."""
    b = ProgramBuilder("takes")
    b.node("rest_pose", "rest")
    b.node("clip_player", "player", crossfade=0.0)
    b.node("puppet", "puppet", timeout=0.5, fade_in=0.3, fade_out=0.5)
    layers = [
        {"name": "base"},
        {"name": "gesture", "mode": "override"},
        {"name": "puppet", "mode": "override"},
    ]
    b.node("layer_mixer", "mix", layers=layers)
    b.connect("rest", "mix", "out", "base")
    b.connect("player", "mix", "out", "gesture")
    b.connect("puppet", "mix", "out", "puppet")
    b.connect("puppet", "mix", "weight", "puppet_weight")
    b.connect("mix", b.output())
    return b.build()


@pytest.fixture()
def served(desk, tmp_path):
    session = EngineSession.create(desk, rate=RATE, program=layered_program())
    session.library.folder = tmp_path  # never write into the repository's robot folder
    with TestClient(create_app(session)) as client:
        yield session, client
    session.engine.close()


def tick(session, seconds, message=None):
    frames = []
    for _ in range(round(seconds * RATE)):
        if message is not None:
            session.execute(message)
        frames.append(session.engine.tick())
    return frames


# --- errors on the key or track they concern ------------------------------------------------------------


@pytest.mark.parametrize(
    ("tracks", "field"),
    [
        ({"head_pitch": [{"t": 0, "v": 0}, {"t": 0, "v": 0.2}]}, "tracks.head_pitch.1.t"),
        ({"head_pitch": [{"t": 0, "v": 0}, {"t": 0.5, "v": "up"}]}, "tracks.head_pitch.1.v"),
        ({"no_such_dof": [{"t": 0, "v": 0}]}, "tracks.no_such_dof"),
        ({"head_pitch": []}, "tracks.head_pitch"),
        ({"head_pitch": [{"t": 0, "v": 0, "interp": "wobble"}]}, "tracks.head_pitch.0.interp"),
    ],
)
def test_a_bad_clip_is_refused_with_the_field_of_its_key(served, tracks, field):
    _, client = served
    res = client.put("/api/clips/bad", json={"tracks": tracks})
    assert res.status_code in (400, 422), res.text
    assert res.json()["detail"]["field"] == field
    assert client.get("/api/clips/bad").status_code == 404


def test_an_anchor_outside_the_clip_names_the_anchor(served):
    _, client = served
    doc = {"tracks": {"head_pitch": [{"t": 0, "v": 0}, {"t": 1, "v": 0.1}]}, "anchors": {"beat": 3.0}}
    res = client.put("/api/clips/bad", json=doc)
    assert res.json()["detail"]["field"] == "anchors.beat"


# --- the preview pose -----------------------------------------------------------------------------------


class FakePreviz:
    def __init__(self):
        self.calls = []

    def set_preview(self, vector, label, lease):
        self.calls.append((None if vector is None else np.array(vector), label, lease))


def test_a_preview_reaches_the_previz_as_a_full_pose_and_lapses(desk):
    pv = FakePreviz()
    preview = PosePreview(desk, pv, lease=0.2)
    shown = preview.show({"head_pitch": 0.3, "mouth": "grin"}, "nod @ 0.40 s")
    assert shown == {"preview": True, "expires_in": 0.2}
    vector, label, lease = pv.calls[-1]
    assert vector[desk.dof("head_pitch").channels.start] == pytest.approx(0.3)
    assert vector[desk.dof("mouth").channels.start] == desk.dof("mouth").options.index("grin")
    assert vector[desk.dof("head_yaw").channels.start] == pytest.approx(
        desk.rest[desk.dof("head_yaw").channels.start]
    )
    assert label == "nod @ 0.40 s" and lease == 0.2
    assert preview.state()["active"] and preview.state()["values"]["head_pitch"] == 0.3
    time.sleep(0.25)
    assert not preview.state()["active"] and preview.state()["values"] == {}
    assert preview.show(None)["preview"] is False and pv.calls[-1][0] is None


def test_a_bad_preview_names_the_dof_and_changes_nothing(served):
    _, client = served
    res = client.put("/api/previz/preview", json={"values": {"head_pitch": "up"}})
    assert res.status_code in (400, 422) and res.json()["detail"]["field"] == "values.head_pitch"
    res = client.put("/api/previz/preview", json={"values": {"no_dof": 1.0}})
    assert res.json()["detail"]["field"] == "values.no_dof"
    assert client.get("/api/previz/preview").json()["active"] is False


def test_turning_a_link_is_clamped_recorded_and_counted(desk):
    preview = PosePreview(desk, FakePreviz())
    assert preview.grab("head_yaw", 0.2) is None  # no preview shows: a turn counts for nothing
    preview.show({"head_yaw": 0.0}, "x")
    assert preview.grab("head_yaw", 0.2) == pytest.approx(0.2)
    d = desk.dof("head_yaw")
    assert preview.grab("head_yaw", 99.0) == pytest.approx(d.max)
    assert preview.grab("mouth", 1.0) is None
    state = preview.state()
    assert state["grabbed"] == {"head_yaw": d.max} and state["revision"] == 2


# --- play_clip with the editor's working copy -----------------------------------------------------------


def test_play_clip_plays_an_unsaved_document_from_a_clip_time(served, desk):
    session, client = served
    doc = {"tracks": {"ear_left": [{"t": 0, "v": 0, "interp": "linear"}, {"t": 2, "v": 0.8}]}}
    res = client.post(
        "/api/commands",
        json={"type": "play_clip", "clip": "draft", "document": doc, "start": 1.0, "crossfade": 0},
    )
    assert res.status_code == 200, res.text
    frames = tick(session, 0.05)
    ear = desk.dof("ear_left").channels.start
    # the program plays from clip time 1 s; the safety net blends the robot there within its limits
    assert frames[-1].program[ear] == pytest.approx(0.4 + 0.8 * 0.05 / 2, abs=0.02)
    steps = np.abs(np.diff([f.position[ear] for f in frames]))
    assert steps.max() <= desk.vel_limit[ear] / RATE * (1 + 1e-6)
    assert client.get("/api/clips/draft").status_code == 404  # nothing was saved
    bad = client.post(
        "/api/commands",
        json={"type": "play_clip", "clip": "draft", "document": {"tracks": {"nope": [{"t": 0, "v": 0}]}}},
    )
    assert bad.status_code in (400, 422) and "nope" in bad.json()["detail"]["message"]


# --- recorded takes -------------------------------------------------------------------------------------


def performance(t: float) -> dict[str, float]:
    return {"head_yaw": 0.5 * np.sin(2 * np.pi * 0.5 * t), "ear_left": 0.3 * np.sin(2 * np.pi * 1.0 * t)}


def test_a_take_records_the_output_reduces_keys_and_plays_back_within_005_rad(served, desk):
    session, client = served
    tick(session, 0.6, {"type": "puppet", "values": performance(0.0)})  # the puppet layer fades in
    started = client.post("/api/record/start", json={"dofs": ["head_yaw", "ear_left"]})
    assert started.status_code == 200, started.text
    assert started.json()["recording"] is True and started.json()["rate"] == RATE
    performed = []
    for k in range(300):  # 3 s of performance streamed at the engine's rate
        frame = tick(session, 1 / RATE, {"type": "puppet", "values": performance(k / RATE)})[0]
        performed.append(frame)
    deadline = time.monotonic() + 5
    while client.get("/api/record").json()["samples"] < 300 and time.monotonic() < deadline:
        time.sleep(0.02)
    res = client.post("/api/record/stop", json={"name": "take-1", "tolerance": 0.005})
    assert res.status_code == 200, res.text
    take = res.json()
    assert take["saved"] == "take-1" and take["samples"] == 300 and take["dropped"] == 0
    assert take["max_error"] <= 0.005 + 1e-9
    assert 3 <= take["keys"]["head_yaw"] < 100  # reduced: far fewer keys than the 300 samples
    report = take["report"]  # the trajectory-helper's verdict on the take, at the engine's rate
    assert report["engine_rate"] == RATE and set(report["dofs"]) == {"head_yaw", "ear_left"}
    # keyed within the limits the performance kept: only its first ticks may jerk, where the take
    # begins in mid-motion and the check starts it from standstill
    assert all(r["end"] <= 10 for r in report["ranges"]), report["ranges"][:3]
    assert client.get("/api/clips/take-1").json()["tracks"]["head_yaw"]

    tick(session, 0.01, {"type": "puppet", "release": True})
    tick(session, 1.0)  # the puppet layer fades out
    client.post("/api/commands", json={"type": "play_clip", "clip": "take-1", "crossfade": 0})
    played = tick(session, 2.9)
    cols = [desk.dof("head_yaw").channels.start, desk.dof("ear_left").channels.start]
    recorded = np.array([f.position[cols] for f in performed])
    replay = np.array([f.position[cols] for f in played])
    # the play starts on the tick after the command: compare at equal clip times
    err = np.abs(replay[1:] - recorded[1 : len(replay)])
    assert err.max() < 0.05, err.max()


def test_take_errors_are_specific_and_leave_nothing_running(served):
    session, client = served
    res = client.post("/api/record/start", json={"dofs": ["mouth"]})
    assert res.status_code in (400, 422) and res.json()["detail"]["field"] == "dofs.0"
    res = client.post("/api/record/start", json={"dofs": ["head_yaw", "nope"]})
    assert res.json()["detail"]["field"] == "dofs.1"
    assert client.post("/api/record/stop", json={"name": "x"}).json()["detail"]["code"] == "not_recording"
    assert client.post("/api/record/start", json={"dofs": ["head_yaw"]}).status_code == 200
    assert (
        client.post("/api/record/start", json={"dofs": ["head_yaw"]}).json()["detail"]["code"] == "recording"
    )
    bad_name = client.post("/api/record/stop", json={"name": "../evil"})
    assert bad_name.json()["detail"]["field"] == "name"
    assert client.get("/api/record").json()["recording"] is True  # a bad name loses nothing
    assert client.delete("/api/record").status_code == 200
    assert client.get("/api/record").json()["recording"] is False
    assert not any(s.name == "take-recorder" for s in session.engine._sinks)


def test_analyze_without_the_fit_gives_the_same_ranges_and_no_slow_down(served):
    _, client = served
    wave = json.loads((Path(__file__).resolve().parents[1] / "robots/nutty_desk/clips/wave.json").read_text())
    full = client.post("/api/analyze", json={"rate": RATE, "clip": wave}).json()
    quick = client.post("/api/analyze", json={"rate": RATE, "clip": wave, "fit": False}).json()
    assert quick["ranges"] == full["ranges"] and quick["dofs"] == full["dofs"] and full["ranges"]
    assert quick["fit_scale"] is None and quick["suggestion"] is None and full["suggestion"]
    refused = client.post("/api/filter", json={"rate": RATE, "clip": wave, "preset": "B", "fit": False})
    assert refused.status_code == 422  # the filter takes no `fit`
