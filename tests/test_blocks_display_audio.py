"""Display and audible sources: LED, face, say and play-sound, and commands routed to them."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from backend.engine.blocks import BLOCKS, BlockContext
from backend.engine.blocks.base import BlockCommandError
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession


def make(desk, type_name, **kw):
    cls = BLOCKS[type_name]
    ctx = BlockContext(embodiment=desk, rate=100.0)
    return cls(cls.Params(**kw), ctx, "n"), ctx


def led_rgb(desk, out, dof="eye_leds"):
    return out.values[desk.dof(dof).channels]


# --- LED ------------------------------------------------------------------------------------------


def test_led_solid_defaults_to_first_colour_dof(desk):
    blk, _ = make(desk, "led", colour=[0.2, 0.4, 0.6])
    out = blk.tick(0.01, {})["out"]
    assert np.allclose(led_rgb(desk, out), [0.2, 0.4, 0.6])
    assert out.mask.sum() == 3 and out.mask[desk.dof("eye_leds").channels].all()


def test_led_pulse_and_breathe_oscillate_within_unit_range(desk):
    for mode in ("pulse", "breathe"):
        blk, _ = make(
            desk, "led", dof="chest_led", colour=[1.0, 0.5, 0.0], mode=mode, frequency=2.0, depth=0.8
        )
        r = np.array([led_rgb(desk, blk.tick(0.01, {})["out"], "chest_led") for _ in range(200)])
        assert r.min() >= 0.0 and r.max() <= 1.0
        assert r[:, 0].max() == pytest.approx(1.0, abs=0.02) and r[:, 0].min() == pytest.approx(0.2, abs=0.03)
        assert np.allclose(r[:50, 0], r[50:100, 0])  # period 0.5 s
        assert np.allclose(r[:, 1], 0.5 * r[:, 0])  # brightness scales the colour


def test_led_command_and_colour_input(desk):
    blk, _ = make(desk, "led")
    assert blk.handle("set_led", {"colour": [0.0, 1.0, 0.0]}) == {
        "dof": "eye_leds",
        "colour": [0.0, 1.0, 0.0],
    }
    assert np.allclose(led_rgb(desk, blk.tick(0.01, {})["out"]), [0, 1, 0])
    assert np.allclose(led_rgb(desk, blk.tick(0.01, {"colour": [1.0, 0.0, 0.0]})["out"]), [1, 0, 0])
    with pytest.raises(BlockCommandError, match="0..1"):
        blk.handle("set_led", {"colour": [2.0, 0.0, 0.0]})
    with pytest.raises(ValidationError, match="within 0..1"):
        BLOCKS["led"].Params(colour=[1.5, 0, 0])
    with pytest.raises(ValueError, match="not a colour DoF"):
        make(desk, "led", dof="mouth")


# --- face -----------------------------------------------------------------------------------------


def test_face_sets_the_enum_option(desk):
    mouth = desk.channel_index["mouth"]
    options = list(desk.dof("mouth").options)
    blk, _ = make(desk, "face", expression="smile")
    out = blk.tick(0.01, {})["out"]
    assert out.values[mouth] == options.index("smile") and out.mask.sum() == 1
    blk.handle("set_face", {"expression": "frown"})
    assert blk.tick(0.01, {})["out"].values[mouth] == options.index("frown")
    assert blk.tick(0.01, {"expression": "grin"})["out"].values[mouth] == options.index("grin")
    default, _ = make(desk, "face")
    assert default.tick(0.01, {})["out"].values[mouth] == options.index("neutral")


def test_face_rejects_unknown_expressions_naming_the_options(desk):
    with pytest.raises(ValueError, match=r"no expression 'ecstatic'.*smile"):
        make(desk, "face", expression="ecstatic")
    blk, _ = make(desk, "face")
    with pytest.raises(BlockCommandError, match=r"options: \['neutral', 'smile'"):
        blk.handle("set_face", {"expression": "ecstatic"})


# --- say ------------------------------------------------------------------------------------------


def test_say_emits_once_notifies_and_flaps_the_mouth(desk):
    blk, ctx = make(desk, "say", words_per_second=2.0, syllable_rate=4.0)
    mouth = desk.channel_index["mouth_open"]
    blk.tick(0.01, {})
    assert (
        blk.handle("say", {"text": "hello there robot friend", "command_id": "s1"})["text"]
        == "hello there robot friend"
    )
    outs = [blk.tick(0.01, {}) for _ in range(300)]
    events = [(k, e) for k, o in enumerate(outs) for e in o["out"].events]
    assert len(events) == 1
    k, ev = events[0]
    assert (
        k == 0
        and ev.dof == "speech"
        and ev.kind == "say"
        and ev.payload == {"text": "hello there robot friend"}
    )
    assert [(n["event"], n["command_id"]) for n in ctx.events] == [("started", "s1"), ("completed", "s1")]
    speaking = [o["speaking"] for o in outs]
    assert sum(speaking) == 200  # 4 words at 2 words/s = 2 s
    flap = np.array([o["out"].values[mouth] for o in outs[:200]])
    assert all(o["out"].mask[mouth] for o in outs[:200])
    assert flap.max() > 0.6 and flap.min() == pytest.approx(0.0)
    assert np.count_nonzero(np.diff(np.sign(np.diff(flap))) < 0) >= 6  # opens and closes repeatedly
    assert outs[200]["out"].mask[mouth] and outs[200]["out"].values[mouth] == 0.0  # closes at the end
    assert not any(o["out"].mask[mouth] for o in outs[201:])  # then leaves the mouth alone


def test_say_trigger_rising_edge_and_cancel(desk):
    blk, ctx = make(desk, "say", text="boo")
    said = []
    for k in range(60):
        out = blk.tick(0.01, {"trigger": 10 <= k < 30 or k >= 50})
        said += [(k, e.payload["text"]) for e in out["out"].events]
    assert said == [(10, "boo"), (50, "boo")]
    blk.handle("say", {"text": "second", "command_id": "x"})
    blk.tick(0.01, {})
    assert [n["event"] for n in ctx.events][-2:] == ["cancelled", "started"]
    with pytest.raises(BlockCommandError, match="empty"):
        blk.handle("say", {"text": "  "})


# --- play sound -----------------------------------------------------------------------------------


def test_play_sound_emits_and_notifies(desk):
    blk, ctx = make(desk, "play_sound", duration=0.5)
    assert blk.handle("play_sound", {"sound": "purr", "command_id": "p"})["sound"] == "purr"
    outs = [blk.tick(0.01, {}) for _ in range(80)]
    events = [e for o in outs for e in o["out"].events]
    assert [(e.dof, e.kind, e.payload) for e in events] == [("sound", "sound", {"clip": "purr"})]
    assert [(n["event"], n["command_id"]) for n in ctx.events] == [("started", "p"), ("completed", "p")]
    assert sum(o["playing"] for o in outs) == 50
    assert not any(o["out"].mask.any() for o in outs)


def test_play_sound_rejects_unknown_sounds_and_triggers(desk):
    blk, _ = make(desk, "play_sound", sound="beep")
    with pytest.raises(BlockCommandError, match=r"unknown sound 'moo'.*chirp"):
        blk.handle("play_sound", {"sound": "moo"})
    with pytest.raises(ValueError, match="unknown sound 'moo'"):
        make(desk, "play_sound", sound="moo")
    clips = [e.payload["clip"] for k in range(10) for e in blk.tick(0.01, {"trigger": k >= 3})["out"].events]
    assert clips == ["beep"]


# --- end to end -----------------------------------------------------------------------------------


def _program_with_voice(desk):
    b = ProgramBuilder("talker", robot=desk.name)
    rest = b.node("rest_pose", "rest")
    say = b.node("say", "voice", words_per_second=4.0)
    sound = b.node("play_sound", "sfx", duration=0.2)
    mix = b.node(
        "layer_mixer",
        "mix",
        layers=[{"name": "base"}, {"name": "voice", "mode": "override"}, {"name": "sfx", "mode": "override"}],
    )
    b.connect(rest, mix, "out", "base").connect(say, mix, "out", "voice").connect(sound, mix, "out", "sfx")
    b.chain(mix, b.node("safety_limiter", "safety"), b.output())
    return b.to_dict()


def test_say_and_play_sound_commands_route_to_blocks_end_to_end(desk):
    from backend.control import CommandError

    session = EngineSession.create(desk, rate=100, program=_program_with_voice(desk))
    notes = []
    session.on_note(notes.append)
    list(session.run_headless(3))
    session.execute({"type": "say", "text": "hi there", "id": "c1"})
    frames = list(session.run_headless(80))
    speech = [e for f in frames for e in f.events if e.kind == "say"]
    assert [(e.dof, e.payload["text"]) for e in speech] == [("speech", "hi there")]
    assert [n["event"] for n in notes if n.get("command_id") == "c1"] == ["started", "completed"]
    mouth = desk.channel_index["mouth_open"]
    assert max(f.stage1[mouth] for f in frames) > 0.3  # the face talked

    session.execute({"type": "play_sound", "sound": "chirp", "id": "c2"})
    frames = list(session.run_headless(5))
    played = [(f.t, e.payload) for f in frames for e in f.events if e.kind == "sound"]
    # the event names the sound, and (it is a file of the robot's sounds/) where and when it plays
    assert played == [
        (
            played[0][0],
            {
                "clip": "chirp",
                "sound": "chirp",
                "t": round(played[0][0], 6),
                "url": "/api/sounds/chirp",
                "duration": 0.35,
            },
        )
    ]
    with pytest.raises(CommandError, match="unknown sound 'moo'"):
        session.execute({"type": "play_sound", "sound": "moo"})


def test_set_led_and_set_face_commands_reach_the_program_blocks(desk):
    b = ProgramBuilder("display", robot=desk.name)
    mix = b.node(
        "layer_mixer",
        "mix",
        layers=[{"name": "base"}, {"name": "eyes", "mode": "override"}, {"name": "face", "mode": "override"}],
    )
    b.connect(b.node("rest_pose", "rest"), mix, "out", "base")
    b.connect(b.node("led", "eyes", colour=[0.1, 0.2, 0.3]), mix, "out", "eyes")
    b.connect(b.node("face", "face", expression="smile"), mix, "out", "face")
    b.chain(mix, b.output())
    session = EngineSession.create(desk, rate=100, program=b.to_dict())
    eyes, mouth = desk.dof("eye_leds").channels, desk.channel_index["mouth"]
    options = list(desk.dof("mouth").options)
    f = list(session.run_headless(2))[-1]
    assert np.allclose(f.position[eyes], [0.1, 0.2, 0.3]) and f.position[mouth] == options.index("smile")
    session.execute({"type": "set_led", "colour": [1.0, 0.0, 0.5]})
    session.execute({"type": "set_face", "expression": "grin"})
    f = list(session.run_headless(2))[-1]
    assert np.allclose(f.position[eyes], [1.0, 0.0, 0.5]) and f.position[mouth] == options.index("grin")
