"""Clips and the clip player: format validation, playback modes, speed, seek, crossfades, anchors, events."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from backend.engine.blocks import BLOCKS, BlockContext
from backend.engine.blocks.base import BlockCommandError
from backend.engine.clips import ClipError, compile_clip, time_map
from backend.engine.library import LibraryError, RobotLibrary
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession

RAMP = {
    "format": "nutty-clip/1",
    "name": "ramp",
    "duration": 1.0,
    "anchors": {"mid": 0.5},
    "tracks": {
        "head_yaw": [{"t": 0, "v": 0.0, "interp": "linear"}, {"t": 1.0, "v": 1.0}],
        "mouth": [{"t": 0, "v": "neutral"}, {"t": 0.5, "v": "smile"}],
    },
    "events": [{"t": 0.25, "dof": "sound", "kind": "sound", "payload": {"clip": "chirp"}}],
}
STEP = {
    "format": "nutty-clip/1",
    "name": "step",
    "tracks": {"head_yaw": [{"t": 0, "v": -0.5, "interp": "constant"}, {"t": 0.5, "v": -0.5}]},
}


@pytest.fixture
def lib(tmp_path: Path, desk) -> RobotLibrary:
    library = RobotLibrary(tmp_path, desk)
    library.save("clips", "ramp", RAMP)
    library.save("clips", "step", STEP)
    return library


def player(desk, lib, notes=None, **params):
    ctx = BlockContext(embodiment=desk, rate=100.0, resources=lib)
    block = BLOCKS["clip_player"](BLOCKS["clip_player"].Params(**params), ctx, "gesture")
    return block, ctx


def run(block, n, dt=0.01, inputs=None):
    return [block.tick(dt, inputs or {}) for _ in range(n)]


def yaw(desk, outs):
    i = desk.channel_index["head_yaw"]
    return np.array([o["out"].values[i] for o in outs])


def test_bundled_clips_validate_and_fit_the_default_robot(desk):
    folder = Path("robots/nutty_desk/clips")
    names = sorted(p.stem for p in folder.glob("*.json"))
    assert {"happy", "sad", "surprised", "nod", "shake", "wave"} <= set(names)
    lib = RobotLibrary(Path("robots/nutty_desk"), desk)
    for name in names:
        clip = compile_clip(lib.get("clips", name), desk)
        out = desk.rest.copy()
        values = np.array([clip.sample(t, desk.rest, out).copy() for t in np.arange(0, clip.duration, 0.01)])
        assert np.all(values >= desk.min - 1e-9) and np.all(values <= desk.max + 1e-9), name


def test_a_broken_clip_is_refused_naming_the_track(desk, lib):
    with pytest.raises(ClipError, match="track 'tail'.*no DoF 'tail'"):
        compile_clip({"tracks": {"tail": [{"t": 0, "v": 0}]}}, desk)
    with pytest.raises(ClipError, match="track 'mouth' key 0.*no option 'smirk'"):
        compile_clip({"tracks": {"mouth": [{"t": 0, "v": "smirk"}]}}, desk)
    with pytest.raises(LibraryError, match="tracks.head_yaw.1.t"):
        lib.save("clips", "bad", {"tracks": {"head_yaw": [{"t": 0, "v": 0}, {"t": -1, "v": 0}]}})
    with pytest.raises(LibraryError, match="increase strictly"):
        lib.save("clips", "bad", {"tracks": {"head_yaw": [{"t": 1, "v": 0}, {"t": 0.5, "v": 0}]}})
    assert not lib.exists("clips", "bad")


def test_play_once_follows_the_curve_reports_events_and_fades_out(desk, lib):
    block, ctx = player(desk, lib, crossfade=0.0, release=0.2)
    block.handle("play", {"clip": "ramp", "command_id": "c1"})
    outs = run(block, 140)
    y = yaw(desk, outs)
    assert y[49] == pytest.approx(0.5, abs=0.011)  # clip time 0.5 s after 50 ticks of 10 ms
    kinds = [(n["event"], n.get("command_id")) for n in ctx.events]
    assert kinds == [("started", "c1"), ("completed", "c1")]
    sounds = [e for o in outs for e in o["out"].events]
    assert len(sounds) == 1 and sounds[0].payload == {"clip": "chirp"}
    weights = [o["weight"] for o in outs]
    assert weights[50] == 1.0 and 0.0 < weights[110] < 1.0 and weights[-1] == 0.0
    assert not outs[-1]["out"].mask.any() and not outs[-1]["playing"]
    mouth = desk.channel_index["mouth"]
    assert outs[20]["out"].values[mouth] == 0 and outs[60]["out"].values[mouth] == desk.dof(
        "mouth"
    ).options.index("smile")


def test_speed_scales_timing_and_the_speed_input_overrides_it(desk, lib):
    block, _ = player(desk, lib, crossfade=0.0)
    block.handle("play", {"clip": "ramp", "speed": 2.0})
    assert yaw(desk, run(block, 25))[-1] == pytest.approx(0.5, abs=0.021)
    block.handle("play", {"clip": "ramp"})
    assert yaw(desk, run(block, 25, inputs={"speed": 0.5}))[-1] == pytest.approx(0.125, abs=0.011)


def test_loop_and_ping_pong(desk, lib):
    block, _ = player(desk, lib, crossfade=0.0, mode="loop")
    block.handle("play", {"clip": "ramp"})
    y = yaw(desk, run(block, 250))
    assert np.sum(np.diff(y) < -0.5) == 2  # wrapped twice in 2.5 s
    block.handle("play", {"clip": "ramp", "mode": "ping_pong"})
    y = yaw(desk, run(block, 250))
    assert np.max(np.abs(np.diff(y))) < 0.02  # no wrap jumps: it turns around
    assert y.max() > 0.98 and y[-1] < 0.6


def test_seek_and_stop(desk, lib):
    block, ctx = player(desk, lib, crossfade=0.0, release=0.0)
    block.handle("play", {"clip": "ramp", "command_id": "s"})
    run(block, 5)
    block.handle("seek", {"t": 0.8})
    assert yaw(desk, run(block, 1))[0] == pytest.approx(0.81, abs=0.011)
    with pytest.raises(BlockCommandError, match="outside the clip"):
        block.handle("seek", {"t": 3.0})
    assert block.handle("stop", {})["stopped"]
    assert [n["event"] for n in ctx.events] == ["started", "cancelled"]
    assert not run(block, 2)[-1]["out"].mask.any()


def test_a_new_clip_crossfades_from_the_current_pose(desk, lib):
    block, ctx = player(desk, lib, crossfade=0.3)
    block.handle("play", {"clip": "ramp", "command_id": "a"})
    y1 = yaw(desk, run(block, 80))
    block.handle("play", {"clip": "step", "command_id": "b"})  # jumps to -0.5 in the clip
    y2 = yaw(desk, run(block, 40))
    assert ("a", "cancelled") in [(n.get("command_id"), n["event"]) for n in ctx.events]
    steps = np.abs(np.diff(np.concatenate([y1[-1:], y2])))
    assert steps.max() < 0.15  # spread over the crossfade instead of a 1.3 rad jump
    assert y2[-1] == pytest.approx(-0.5)


def test_anchors_warp_time_so_a_mark_lands_when_asked(desk, lib):
    block, _ = player(desk, lib, crossfade=0.0)
    block.handle("play", {"clip": "ramp", "anchors": {"mid": 1.0}})  # 0.5 s of clip stretched to 1 s
    y = yaw(desk, run(block, 150))
    assert y[99] == pytest.approx(0.5, abs=0.006)
    assert y[124] == pytest.approx(0.75, abs=0.011)  # after the anchor, authored speed again
    with pytest.raises(BlockCommandError, match="no anchor 'beat'"):
        block.handle("play", {"clip": "ramp", "anchors": {"beat": 1.0}})
    play, clip = time_map(2.0, 1.0, {"a": 0.5, "b": 1.0}, {"a": 1.0, "b": 1.2})
    assert np.interp(1.2, play, clip) == pytest.approx(1.0) and np.all(np.diff(play) >= 0)


def test_unknown_clip_is_a_clear_error_and_a_configuration_error(desk, lib):
    block, _ = player(desk, lib)
    with pytest.raises(BlockCommandError, match="no clip named 'moonwalk'"):
        block.handle("play", {"clip": "moonwalk"})
    with pytest.raises(ValueError, match="moonwalk"):
        player(desk, lib, clip="moonwalk")


def test_trigger_and_autoplay(desk, lib):
    block, ctx = player(desk, lib, clip="ramp", crossfade=0.0)
    run(block, 3)
    assert not ctx.events
    run(block, 1, inputs={"trigger": True})
    run(block, 3, inputs={"trigger": True})  # held high: one start only
    assert [n["event"] for n in ctx.events] == ["started"]
    auto, actx = player(desk, lib, clip="ramp", autoplay=True, mode="loop")
    assert run(auto, 1)[0]["playing"] and actx.events[0]["event"] == "started"


def test_play_clip_command_on_the_gesture_layer_of_a_program(desk):
    b = ProgramBuilder("gestures", robot=desk.name)
    rest = b.node("rest_pose", "rest")
    clips = b.node("clip_player", "gesture_clips", crossfade=0.2)
    mix = b.node("layer_mixer", "mix", layers=[{"name": "base"}, {"name": "gesture", "mode": "additive"}])
    b.connect(rest, mix, dst_port="base").connect(clips, mix, dst_port="gesture").chain(mix, b.output())
    session = EngineSession.create(desk, rate=100, program=b.build())
    notes = []
    session.on_note(notes.append)
    session.execute({"type": "play_clip", "clip": "nod", "layer": "gesture", "id": "n1"})
    frames = list(session.run_headless(200))
    # The program's own frames: this unfiltered program plays the clip faster than the robot's limits
    # allow, so what reaches the robot is the safety net's gentler version (checked below).
    pitch = np.array([f.program[desk.channel_index["head_pitch"]] for f in frames])
    assert pitch.max() > 0.2 and pitch.min() < -0.02  # the nod and its anticipation lift
    assert abs(pitch[-1]) < 1e-6  # back to rest after the release
    robot = np.array([f.position[desk.channel_index["head_pitch"]] for f in frames])
    assert robot.max() > 0.1 and robot[-1] == 0.0 and session.engine.safety.corrections.any()
    assert [n["event"] for n in notes if n.get("command_id") == "n1"] == ["started", "completed"]
    from backend.control import CommandError

    with pytest.raises(CommandError, match="no clip named 'moonwalk'"):
        session.execute({"type": "play_clip", "clip": "moonwalk"})


def test_mixer_weight_port_fades_an_override_layer(desk, lib):
    b = ProgramBuilder("w", robot=desk.name)
    rest = b.node("rest_pose", "rest")
    pose = b.node("pose", "look", values={"head_yaw": 1.0})
    w = b.node("input", "w", name="w", type="float")
    b.doc["inputs"].append({"name": "w", "type": "float", "default": 0.25, "min": 0.0, "max": 1.0})
    mix = b.node("layer_mixer", "mix", layers=[{"name": "base"}, {"name": "top"}])
    b.connect(rest, mix, dst_port="base").connect(pose, mix, dst_port="top").connect(
        w, mix, "value", "top_weight"
    )
    b.chain(mix, b.output())
    session = EngineSession.create(desk, rate=100, program=b.build())
    frames = list(session.run_headless(3))
    assert frames[-1].program[desk.channel_index["head_yaw"]] == pytest.approx(0.25)  # before the safety net
    json.dumps(BLOCKS["layer_mixer"].describe())  # the dynamic weight ports are describable
