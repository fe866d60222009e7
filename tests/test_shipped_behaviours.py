"""The behaviours nutty_desk ships (#31), each played through the interactive program: their events
(speech, sounds, items) and their motion (gaze, gestures, postures, lights, face, mood), within limits."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from joint_truth import joint_truth

from backend.session import EngineSession

DESK = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk"
INTERACTIVE = (DESK / "programs" / "interactive.json").read_text()


def play(desk, behaviour, **params):
    session = EngineSession.create(desk, rate=100, program_text=INTERACTIVE)
    before = session.engine.run_ticks(50)[-1]
    session.notes.clear()
    name = behaviour
    session.execute({"type": "play_behaviour", "behaviour": name, "params": params, "id": name})
    frames = []
    for _ in range(2000):
        frames.append(session.engine.tick())
        if any(n.get("command_id") == name and n["event"] == "completed" for n in session.notes):
            break
    notes = [n for n in session.notes if n.get("command_id") == name]
    assert [n["event"] for n in notes if n["event"] in ("started", "completed", "cancelled", "failed")] == [
        "started",
        "completed",
    ]
    items = {n["item"]: n["state"] for n in notes if n["event"] == "item"}
    assert set(items.values()) == {"completed"}, items  # every item ended as planned
    vel = np.array([f.velocity for f in frames])[:, desk.continuous_mask]
    assert np.all(np.abs(vel) <= desk.vel_limit[desk.continuous_mask] * (1 + 1e-6) + 1e-9)
    # the joints the motors get (own DoF plus the symbolic gaze and blink), recomposed from the robot's
    # own files, within the URDF's range and every limit
    truth = joint_truth(DESK)
    truth.assert_within(
        truth.compose(desk, np.array([f.position for f in frames])), session.engine.rate, name
    )
    events = [(round(f.t - frames[0].t, 2), e.kind, e.payload) for f in frames for e in f.events]
    return session, before, frames, events, items


def value(desk, frame, dof):
    sl = desk.dof(dof).channels
    return frame.position[sl] if sl.stop - sl.start > 1 else frame.position[sl.start]


def peak(desk, frames, dof):
    k = desk.channel_index[dof]
    return max(abs(f.position[k] - frames[0].position[k]) for f in frames)


def test_greet_looks_at_the_person_waves_says_their_name_and_smiles(desk):
    session, before, frames, events, items = play(desk, "greet", name="Ana", target=[1.0, 0.6, 0.35])
    assert set(items) == {"look", "wave", "hello", "smile", "warm_eyes", "happy"}
    assert [p["text"] for _, kind, p in events if kind == "say"] == ["Hello Ana!"]
    assert value(desk, frames[-1], "head_yaw") > value(desk, before, "head_yaw") + 0.2  # turned to the left
    assert peak(desk, frames, "ear_right") > 0.3  # the wave
    mouth = desk.dof("mouth")
    assert mouth.options[int(value(desk, frames[-1], "mouth"))] == "smile"
    eyes = value(desk, frames[-1], "eye_leds")  # the program's LED block breathes: the hue is the colour
    assert np.allclose(eyes / eyes.max(), [1.0, 0.8, 0.2], atol=0.03)
    assert session.engine.ctx.inputs["valence"] == pytest.approx(0.7)


def test_think_looks_up_ponders_speaks_a_recording_and_nods(desk):
    session, before, frames, events, _ = play(desk, "think")
    said = [p for _, kind, p in events if kind == "say"]
    assert [(p["audio"], p["url"]) for p in said] == [("speech_thinking", "/api/sounds/speech_thinking")]
    assert [p["clip"] for _, kind, p in events if kind == "sound"] == ["purr"]
    mouth_open = [f.position[desk.channel_index["mouth_open"]] for f in frames]
    assert max(mouth_open) > 0.3  # the recording moves the mouth
    turned = max(f.position[desk.channel_index["head_yaw"]] for f in frames)
    assert turned > value(desk, before, "head_yaw") + 0.1  # looked up and aside, to the left
    assert peak(desk, frames, "head_roll") > 0.1  # the curious tilt
    assert session.engine.ctx.inputs["arousal"] == pytest.approx(-0.3)


def test_celebrate_bounces_cheers_chirps_and_glows(desk):
    session, _, frames, events, _ = play(desk, "celebrate", intensity=1.0)
    sounds = [(t, p["clip"]) for t, kind, p in events if kind == "sound"]
    assert [c for _, c in sounds] == ["giggle", "chirp"]
    (cheer,) = [(t, p) for t, kind, p in events if kind == "say"]
    assert cheer[1]["audio"] == "speech_hooray" and cheer[0] == pytest.approx(0.45, abs=0.02)
    assert sounds[1][0] == pytest.approx(cheer[0] + cheer[1]["duration"], abs=0.03)  # right after the words
    assert peak(desk, frames, "ear_left") > 0.3
    assert np.allclose(value(desk, frames[-1], "chest_led"), [1.0, 0.85, 0.1], atol=0.05)
    assert session.engine.ctx.inputs["arousal"] == pytest.approx(0.2)


def test_sleepy_yawns_says_good_night_and_sinks(desk):
    session, before, frames, events, _ = play(desk, "sleepy", slowness=2.0)
    assert [p["clip"] for _, kind, p in events if kind == "sound"] == ["yawn"]
    assert [p["audio"] for _, kind, p in events if kind == "say"] == ["speech_sleepy"]
    lid = desk.channel_index["eyelid_left"]
    assert frames[-1].position[lid] > 0.7  # the eyes close
    assert value(desk, frames[-1], "neck_pitch") > value(desk, before, "neck_pitch") + 0.15  # the head sinks
    eyes = value(desk, frames[-1], "eye_leds")
    assert np.allclose(eyes / eyes.max(), [0.375, 0.375, 1.0], atol=0.03)
    assert session.engine.ctx.inputs["arousal"] == pytest.approx(-0.9)
