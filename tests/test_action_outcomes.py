"""Honest results for long actions (issue: an AI's tools at the level of ROS 2 actions): look_at says
whether a point is within reach and, if not, where the gaze stops; a waited action completes when the
robot's motion has ended, not when its block is done; its outcome says what the safety net did."""

from __future__ import annotations

import math

import pytest
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.engine.embodiment import load_embodiment, robots_dir
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession

INTERACTIVE = robots_dir() / "nutty_desk" / "programs" / "interactive.json"


def _client(session: EngineSession):
    session.engine.start()
    return TestClient(create_app(session, frontend_dir=None))


@pytest.fixture(scope="module")
def interactive():
    session = EngineSession.create(
        load_embodiment(robots_dir() / "nutty_desk"), rate=100, program_text=INTERACTIVE.read_text()
    )
    with _client(session) as c:
        yield c
    session.engine.close()


def call(client, name, **arguments):
    r = client.post(f"/api/tools/{name}", json=arguments)
    assert r.status_code == 200, r.text
    return r.json()


def test_look_at_a_reachable_point_waits_until_the_gaze_arrives(interactive):
    answer = call(interactive, "look_at", target=[1.0, 0.3, 0.35], wait=True, timeout=20)
    assert answer["result"]["reachable"] is True and answer["result"]["clamped_to"] is None
    assert answer["status"] == "completed" and answer["waited"] is True
    assert answer["outcome"]["settled"] is True and answer["outcome"]["reached"] is True


@pytest.mark.parametrize("target", [[0.0, 0.0, 0.0], [0.3, 0.0, 3.0]])
def test_look_at_out_of_reach_says_so_and_where_the_gaze_stops(interactive, target):
    answer = call(interactive, "look_at", target=target, wait=True, timeout=20)
    result = answer["result"]
    assert result["reachable"] is False and result["reason"]
    assert answer["status"] == "completed" and answer["outcome"]["reached"] is False
    if target == [0.0, 0.0, 0.0]:  # at the robot's foot, below the eyes: pitch beyond its range
        assert "pitch" in result["reason"] and result["pitch"] > result["pitch_range"][1]
    else:  # high above the head
        assert "pitch" in result["reason"] and result["pitch"] < result["pitch_range"][0]
    stop = result["clamped_to"]
    yaw = math.atan2(stop[1], stop[0])
    assert result["yaw_range"][0] - 0.02 <= yaw <= result["yaw_range"][1] + 0.02
    entry = interactive.get(f"/api/commands/{answer['id']}").json()
    assert entry["status"] == "completed" and entry["outcome"] == answer["outcome"]


def test_a_point_behind_is_reached_by_turning_the_body(interactive):
    answer = call(interactive, "look_at", target=[-1.0, 0.05, 0.3], wait=True, timeout=30)
    assert answer["result"]["reachable"] is True and answer["outcome"]["reached"] is True
    call(interactive, "look_at", target=[1.0, 0.0, 0.3], wait=True, timeout=30)


def test_a_newer_look_at_replaces_the_one_in_progress(interactive):
    first = call(interactive, "look_at", target=[1.0, -0.4, 0.3])
    second = call(interactive, "look_at", target=[1.0, 0.4, 0.3], wait=True, timeout=20)
    assert second["status"] == "completed"
    assert interactive.get(f"/api/commands/{first['id']}").json()["status"] in ("cancelled", "completed")


def test_outcome_says_what_the_safety_net_did():
    """An unfiltered program plays 'nod' faster than the neck may move: the net corrects it, and the
    waited answer says on which DoFs and by how much; the completion waits for the robot to catch up."""
    desk = load_embodiment(robots_dir() / "nutty_desk")
    b = ProgramBuilder("raw", robot=desk.name)
    rest = b.node("rest_pose", "rest")
    clips = b.node("clip_player", "gesture_clips", crossfade=0.0)
    mix = b.node("layer_mixer", "mix", layers=[{"name": "base"}, {"name": "gesture", "mode": "additive"}])
    b.connect(rest, mix, dst_port="base").connect(clips, mix, dst_port="gesture").chain(mix, b.output())
    session = EngineSession.create(desk, rate=100, program=b.build())
    with _client(session) as client:
        answer = call(client, "play_clip", clip="nod", wait=True, timeout=20)
        assert answer["status"] == "completed"
        outcome = answer["outcome"]
        safety = outcome["safety"]
        assert safety["corrected_ticks"] > 0 and "head_pitch" in safety["dofs"]
        assert safety["dofs"]["head_pitch"]["max_correction"] > 0.001
        assert outcome["settled"] is True and outcome["settle_time"] >= 0.0
        events = client.get(f"/api/commands/{answer['id']}").json()
        assert events["outcome"] == outcome
    session.engine.close()
