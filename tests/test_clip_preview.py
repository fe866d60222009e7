"""The ghost and Check limits of a clip at the engine's rate (POST /api/filter and /api/analyze with a
`clip`, backend/engine/clip_preview.py), checked against a real engine playing the same clip: the ghost
is the engine's filtered frames, Check limits finds what the engine's rate finds, names the limit that
breaks and suggests the slow-down that fits."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.engine import clip_preview, trajectory
from backend.graph.builder import ProgramBuilder
from backend.importers.limits import scale_clip_time
from backend.session import EngineSession

CLIPS = Path("robots/nutty_desk/clips")
RATE = 100.0
FPS = 24.0


def _engine_frames(desk, clip: str, ticks: int, preset: str | None):
    """A real engine playing `clip` from the robot's library from its first tick (no crossfade), through
    the stage-2 filter `preset` (None: no stage 2)."""
    b = ProgramBuilder("preview", robot=desk.name)
    rest = b.node("rest_pose", "rest")
    player = b.node("clip_player", "clips", clip=clip, autoplay=True, crossfade=0.0, release=0.0, hold=True)
    mix = b.node("layer_mixer", "mix", layers=[{"name": "base"}, {"name": "gesture"}])
    b.connect(rest, mix, dst_port="base").connect(player, mix, dst_port="gesture")
    if preset is None:
        b.chain(mix, b.output())
    else:
        b.chain(mix, b.node("nmf_stage2", "nmf", preset=preset), b.output())
    session = EngineSession.create(desk, rate=RATE, program=b.build())
    return list(session.run_headless(ticks))


@pytest.fixture(scope="module")
def client(desk):
    session = EngineSession.create(desk, rate=RATE)
    with TestClient(create_app(session, frontend_dir=None)) as c:
        yield c


def _clip(name: str) -> dict:
    return json.loads((CLIPS / f"{name}.json").read_text())


@pytest.mark.parametrize("name", ["shake", "surprised", "wave"])
def test_ghost_is_what_the_engine_plays(client, desk, name):
    """At the engine's rate the ghost is the engine's output exactly; at 24 fps, between ticks, it stays
    within 0.2 deg of the engine's frames around it."""
    doc = _clip(name)
    frames = _engine_frames(desk, name, 700, "A")
    exact = client.post("/api/filter", json={"rate": RATE, "clip": doc, "preset": "A"}).json()
    assert exact["engine_rate"] == RATE and exact["preset"] == "A"
    scene = client.post("/api/filter", json={"rate": FPS, "clip": doc, "preset": "A"}).json()
    for dof, values in exact["tracks"].items():
        played = np.array([f.position[desk.channel_index[dof]] for f in frames])
        ghost = np.array(values)
        # the engine's frame j plays clip time (j + 1) / rate: its first frame already moves
        assert np.abs(played[: ghost.size - 1] - ghost[1:]).max() < 1e-6, dof
        at24 = np.array(scene["tracks"][dof])
        ticks = np.arange(at24.size) * RATE / FPS
        engine_at = np.interp(ticks - 1.0, np.arange(played.size), played)
        assert math.degrees(np.abs(engine_at - at24).max()) < 0.2, dof
        on_grid = np.arange(0, at24.size, 6)  # every 6th frame at 24 fps is a tick at 100 Hz
        assert np.abs(at24[on_grid] - ghost[(on_grid * 25) // 6]).max() < 1e-12


def test_check_limits_finds_what_the_engine_rate_finds(client, desk):
    """The ranges cover exactly the ticks where the engine's own (pre-net) frames break a limit."""
    doc = _clip("wave")
    out = client.post("/api/analyze", json={"rate": FPS, "clip": doc}).json()
    assert out["engine_rate"] == RATE and out["rate"] == FPS
    frames = _engine_frames(desk, "wave", 400, None)
    for dof in out["dofs"]:
        ch = desk.channel_index[dof]
        x = np.array([0.0, *[f.program[ch] for f in frames]])  # the engine's frames from clip time 0
        d = desk.dof(dof)
        ref = trajectory.analyze(x, RATE, d.velocity, d.acceleration, d.jerk, d.min, d.max).classes[:, 0]
        got = np.zeros(ref.size, dtype=bool)
        for r in out["ranges"]:
            if r["dof"] == dof:
                got[round(r["t_start"] * RATE) : round(r["t_end"] * RATE) + 1] = True
        n = min(got.size, round(max(f["t"] for k in doc["tracks"].values() for f in k) * RATE) + 1)
        assert np.array_equal(got[:n], ref[:n] != trajectory.OK), dof


def test_check_limits_names_the_limit_and_the_slow_down_that_fits(client, desk):
    """A quick turn (~10 rad/s, 4x head_yaw's velocity limit) is a velocity overrun, though it breaks the
    acceleration and jerk limits by more; the suggested slow-down brings the clip within every limit at
    the engine's rate, and 10% less does not."""
    doc = {
        "format": "nutty-clip/1",
        "name": "quick_turn",
        "duration": 2.0,
        "tracks": {
            "head_yaw": [
                {"t": 0.0, "v": 0.0, "interp": "bezier"},
                {"t": 0.3, "v": 0.0, "interp": "bezier"},
                {"t": 0.45, "v": 1.0, "interp": "bezier"},
                {"t": 2.0, "v": 1.0},
            ]
        },
    }
    out = client.post("/api/analyze", json={"rate": FPS, "clip": doc}).json()
    assert not out["ok"] and len(out["ranges"]) == 1
    turn = out["ranges"][0]
    assert turn["dof"] == "head_yaw" and turn["kind"] == "velocity"
    assert set(turn["limits"]) == {"velocity", "acceleration", "jerk"}
    x = clip_preview.engine_samples(desk, doc, RATE).x[:, 0]
    peak = np.abs(np.diff(x)).max() * RATE
    assert turn["limits"]["velocity"] == pytest.approx(peak / desk.dof("head_yaw").velocity)
    assert turn["start"] == math.floor(turn["t_start"] * FPS) and turn["end"] == math.ceil(
        turn["t_end"] * FPS
    )
    assert 0.3 < turn["t_start"] < turn["t_end"] < 0.5
    scale = out["fit_scale"]
    assert scale is not None and scale > 1.0 and f"{scale:.3g}x slower" in out["suggestion"]
    fitted = copy.deepcopy(doc)
    scale_clip_time(fitted, scale)
    assert client.post("/api/analyze", json={"rate": FPS, "clip": fitted}).json()["ok"] is True
    short = copy.deepcopy(doc)
    scale_clip_time(short, scale * 0.9)
    assert client.post("/api/analyze", json={"rate": FPS, "clip": short}).json()["ok"] is False


def test_a_key_past_the_limit_is_a_position_range_and_no_slow_down(client, desk):
    doc = {
        "format": "nutty-clip/1",
        "name": "too_far",
        "tracks": {"head_pitch": [{"t": 0.0, "v": 0.0}, {"t": 2.0, "v": 0.8}]},
    }
    out = client.post("/api/analyze", json={"rate": FPS, "clip": doc}).json()
    kinds = {r["kind"] for r in out["ranges"]}
    assert kinds == {"position"} and out["fit_scale"] is None
    assert "head_pitch" in out["suggestion"] and "range" in out["suggestion"]


def test_a_clip_within_the_limits_is_ok(client):
    doc = {
        "format": "nutty-clip/1",
        "name": "calm",
        "tracks": {"head_yaw": [{"t": 0.0, "v": 0.0}, {"t": 3.0, "v": 0.2}]},
    }
    out = client.post("/api/analyze", json={"rate": FPS, "clip": doc}).json()
    assert out["ok"] and out["ranges"] == [] and out["fit_scale"] == 1.0 and out["samples"] == 73


@pytest.mark.parametrize(
    "body, field",
    [
        ({"rate": 24}, None),
        (
            {"rate": 24, "clip": {"format": "nutty-clip/1", "name": "x", "tracks": {}}, "tracks": {"a": [0]}},
            None,
        ),
        (
            {
                "rate": 24,
                "clip": {"format": "nutty-clip/1", "name": "x", "tracks": {"nope": [{"t": 0, "v": 0}]}},
            },
            "clip",
        ),
        (
            {
                "rate": 24,
                "clip": {
                    "format": "nutty-clip/1",
                    "name": "x",
                    "tracks": {"mouth": [{"t": 0, "v": "smile"}]},
                },
            },
            "clip.tracks",
        ),
        ({"rate": 24, "clip": "nod"}, "clip"),
    ],
)
def test_bad_clip_bodies_say_what_is_wrong(client, body, field):
    for route in ("/api/analyze", "/api/filter"):
        r = client.post(route, json={**body, **({"preset": "A"} if route == "/api/filter" else {})})
        assert r.status_code in (400, 422), r.text
        if field is not None:
            assert r.json()["detail"]["field"] == field, r.text


def test_engine_samples_hold_the_last_value_after_the_last_key(desk):
    doc = {
        "format": "nutty-clip/1",
        "name": "h",
        "duration": 1.0,
        "tracks": {"head_yaw": [{"t": 0, "v": 0.1}, {"t": 0.5, "v": 0.3}]},
    }
    s = clip_preview.engine_samples(desk, doc, RATE)
    assert s.x.shape == (101, 1) and s.x[-1, 0] == pytest.approx(0.3) and s.x[60, 0] == pytest.approx(0.3)
