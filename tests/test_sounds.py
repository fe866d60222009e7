"""Sounds as files (#31): stored and checked with libsndfile, the sound DoF's list follows the folder,
recorded speech moves the mouth with its loudness, and audio events carry their time and URL to the
robot's drivers and the editor (telemetry)."""

from __future__ import annotations

import io
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import soundfile
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.engine.embodiment import load_embodiment
from backend.engine.sounds import MAX_SECONDS, SoundError, SoundLibrary, loudness
from backend.session import EngineSession

ROOT = Path(__file__).resolve().parents[1]
DESK = ROOT / "robots" / "nutty_desk"
INTERACTIVE = (DESK / "programs" / "interactive.json").read_text()


def wav_bytes(seconds: float, rate: int = 8000, fmt: str = "WAV", freq: float = 440.0) -> bytes:
    t = np.arange(int(seconds * rate)) / rate
    buf = io.BytesIO()
    soundfile.write(buf, (0.3 * np.sin(2 * np.pi * freq * t)).astype(np.float32), rate, format=fmt)
    return buf.getvalue()


def test_the_library_stores_checks_and_forgets_sounds(tmp_path):
    lib = SoundLibrary(tmp_path / "sounds")
    info = lib.save("tone", wav_bytes(0.5))
    assert (info.format, info.samplerate, round(info.duration, 3)) == ("WAV", 8000, 0.5)
    assert lib.list() == ["tone"]
    lib.save("tone", wav_bytes(0.25, fmt="FLAC"))  # replaced, in another format
    assert sorted(p.name for p in (tmp_path / "sounds").iterdir()) == ["tone.flac"]
    assert lib.info("tone").duration == pytest.approx(0.25)
    for data, code in [
        (b"RIFF....WAVEnot really", "invalid_audio"),
        (b"", "invalid_audio"),
        (wav_bytes(MAX_SECONDS + 1, rate=1000), "too_long"),
        (wav_bytes(0.1, fmt="AIFF"), "invalid_audio"),
    ]:
        with pytest.raises(SoundError) as refused:
            lib.save("bad", data)
        assert refused.value.code == code
    with pytest.raises(SoundError) as bad_name:
        lib.save("../escape", wav_bytes(0.1))
    assert bad_name.value.code == "invalid_name"
    assert lib.list() == ["tone"]
    lib.delete("tone")
    assert lib.list() == []


def test_loudness_is_the_smoothed_rms_per_tick():
    rate, sr = 100.0, 16000
    t = np.arange(2 * sr) / sr
    envelope = 0.5 + 0.5 * np.sin(2 * np.pi * 2.0 * t)  # loudness rising and falling twice a second
    samples = envelope * np.sin(2 * np.pi * 300 * t)
    env = loudness(samples, sr, rate)
    assert env.shape == (200,) and env.min() >= 0.0 and env.max() == pytest.approx(1.0)
    truth = envelope.reshape(200, -1).mean(axis=1)
    assert np.corrcoef(env, truth)[0, 1] > 0.95
    assert not loudness(np.zeros(sr), sr, rate).any()


def rms_per_tick(path: Path, rate: float) -> np.ndarray:
    """The recording's RMS per engine tick, computed here from the file (independently of the engine)."""
    data, sr = soundfile.read(path, always_2d=True)
    mono = data.mean(axis=1)
    hop = sr / rate
    n = int(np.ceil(len(mono) / hop))
    return np.array([np.sqrt(np.mean(mono[int(k * hop) : int((k + 1) * hop)] ** 2)) for k in range(n)])


@pytest.mark.parametrize("recording", ["speech_hello", "speech_sleepy"])
def test_recorded_speech_moves_the_mouth_with_its_loudness(desk, recording):
    session = EngineSession.create(desk, rate=100, program_text=INTERACTIVE)
    session.engine.run_ticks(20)
    session.execute({"type": "say", "text": "(recorded)", "audio": recording, "id": "r"})
    frames = session.engine.run_ticks(400)
    start = next(i for i, f in enumerate(frames) if any(e.kind == "say" for e in f.events))
    event = next(e for e in frames[start].events if e.kind == "say")
    assert event.payload["url"] == f"/api/sounds/{recording}" and event.payload["t"] == pytest.approx(
        frames[start].t
    )
    truth = rms_per_tick(DESK / "sounds" / f"{recording}.ogg", 100.0)
    mouth = np.array(
        [f.position[desk.channel_index["mouth_open"]] for f in frames[start : start + len(truth)]]
    )
    assert len(mouth) == len(truth)
    r = np.corrcoef(mouth, truth)[0, 1]  # what the robot gets, after the layers and the safety net
    assert r >= 0.8, r
    notes = [n["event"] for n in session.notes if n.get("command_id") == "r"]
    assert notes == ["started", "completed"]


def test_a_jaw_follows_the_recording_too_and_text_alone_still_flaps(desk):
    program = json.loads(INTERACTIVE)
    voice = next(n for n in program["nodes"] if n["id"] == "voice")
    voice["params"]["jaw_dof"] = "ear_left"  # a stand-in jaw: a continuous DoF the voice layer may move
    layer = next(n for n in program["nodes"] if n["type"] == "layer_mixer")
    next(x for x in layer["params"]["layers"] if x["name"] == "voice")["mask"].append("ear_left")
    session = EngineSession.create(desk, rate=100, program=program)
    session.engine.run_ticks(10)
    session.execute({"type": "say", "text": "hi", "audio": "speech_hooray"})
    stage1 = np.array([f.stage1 for f in session.engine.run_ticks(200)])
    jaw, lip = stage1[:, desk.channel_index["ear_left"]], stage1[:, desk.channel_index["mouth_open"]]
    assert jaw.max() > 0.3 and np.corrcoef(jaw[5:], lip[5:])[0, 1] > 0.95
    session.execute({"type": "say", "text": "one two three four five six"})
    flap = np.array([f.stage1[desk.channel_index["mouth_open"]] for f in session.engine.run_ticks(150)])
    assert flap.max() > 0.5 and ((np.diff(np.sign(np.diff(flap))) < 0).sum()) >= 5  # a syllable rhythm


@pytest.fixture()
def server(tmp_path):
    robot = tmp_path / "nutty_desk"
    shutil.copytree(DESK, robot)
    session = EngineSession.create(load_embodiment(robot), rate=100, program_text=INTERACTIVE)
    session.engine.start()
    with TestClient(create_app(session, frontend_dir=None)) as client:
        client.session = session
        yield client
    session.engine.close()


def play_sound_enum(client) -> list[str]:
    tools = client.get("/api/tools").json()["tools"]
    return next(t for t in tools if t["name"] == "play_sound")["parameters"]["properties"]["sound"]["enum"]


def test_sounds_over_the_api_and_the_sound_dof_follows_the_folder(server):
    listed = {s["name"]: s for s in server.get("/api/sounds").json()}
    assert {"chirp", "speech_hello", "yawn"} <= set(listed)
    assert listed["chirp"]["url"] == "/api/sounds/chirp" and listed["chirp"]["format"] == "ogg"
    got = server.get("/api/sounds/chirp")
    assert got.status_code == 200 and got.headers["content-type"] == "audio/ogg"
    assert soundfile.info(io.BytesIO(got.content)).duration == pytest.approx(
        listed["chirp"]["duration"], abs=1e-3
    )

    r = server.put("/api/sounds/ding", content=wav_bytes(0.4), headers={"content-type": "audio/wav"})
    assert r.status_code == 200 and r.json()["duration"] == pytest.approx(0.4)
    assert "ding" in server.session.embodiment.dof("sound").sounds and "ding" in play_sound_enum(server)
    assert server.post("/api/commands", json={"type": "play_sound", "sound": "ding"}).status_code == 200

    r = server.put("/api/sounds/noise", content=b"hello" * 100, headers={"content-type": "audio/wav"})
    assert r.status_code == 422 and r.json()["detail"]["code"] == "invalid_audio"
    r = server.put("/api/sounds/huge", content=b"\0" * (21 * 2**20), headers={"content-type": "audio/wav"})
    assert r.status_code == 413 and r.json()["detail"]["code"] == "too_large"
    r = server.put("/api/sounds/long", content=wav_bytes(MAX_SECONDS + 5, rate=1000))
    assert r.status_code == 422 and r.json()["detail"]["code"] == "too_long"
    assert server.get("/api/sounds/noise").status_code == 404

    assert server.delete("/api/sounds/ding").json() == {"deleted": "ding"}
    assert "ding" not in server.session.embodiment.dof("sound").sounds and "ding" not in play_sound_enum(
        server
    )
    r = server.post("/api/commands", json={"type": "play_sound", "sound": "ding"})
    assert r.status_code == 422 and r.json()["detail"]["field"] == "sound"


def test_telemetry_lists_each_audio_event_with_its_time_and_url(server):
    with server.websocket_connect("/ws/telemetry") as ws:
        ws.send_json({"type": "subscribe", "signals": [], "frames": True, "rate": 30})
        while ws.receive_json()["type"] != "subscribed":
            pass
        server.post("/api/commands", json={"type": "play_sound", "sound": "yawn"})
        seen = {}
        for _ in range(60):
            msg = ws.receive_json()
            for e in msg.get("events", []):
                seen[(e["seq"], e["index"])] = e
            if seen:
                break
    (event,) = seen.values()
    assert event["kind"] == "sound" and event["payload"]["url"] == "/api/sounds/yawn"
    assert event["payload"]["t"] == pytest.approx(event["t"]) and event["payload"][
        "duration"
    ] == pytest.approx(1.8)
