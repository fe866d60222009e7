"""Behaviour documents (`nutty-behaviour/1`): every error on its item and field, and the plan (each
item's start and end) from the robot's library and the running program."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from backend.behaviours import parse, plan, vocabulary_of
from backend.behaviours.items import preflight
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession

ROOT = Path(__file__).resolve().parents[1]
DESK = ROOT / "robots" / "nutty_desk"


@pytest.fixture(scope="module")
def session(desk):
    return EngineSession.create(desk, program_text=(DESK / "programs" / "interactive.json").read_text())


def greet() -> dict:
    return json.loads((DESK / "behaviours" / "greet.json").read_text())


def errors(session, doc, params=None, strict=True):
    beh, issues = parse(doc)
    if beh is None:
        return [(i.item, i.field, i.message) for i in issues]
    _, issues = plan(beh, params, vocabulary_of(session), strict=strict)
    return [(i.item, i.field, i.message) for i in issues]


def planned(session, doc, params=None):
    beh, issues = parse(doc)
    assert beh is not None and not issues
    p, issues = plan(beh, params, vocabulary_of(session))
    assert not issues, issues
    return {i.id: i for i in p.items}, p


def test_the_shipped_behaviours_plan_cleanly(session):
    for name in ("greet", "think", "celebrate", "sleepy"):
        doc = json.loads((DESK / "behaviours" / f"{name}.json").read_text())
        _, p = planned(session, doc)
        assert p.duration > 2.0 and not preflight(session, p), name


def test_relative_starts_follow_ends_and_clip_anchors(session):
    items, p = planned(session, greet(), {"name": "Ana"})
    clip = session.library.get("clips", "wave")
    assert items["look"].start == 0.0 and items["look"].end == pytest.approx(0.8)
    assert items["wave"].start == pytest.approx(0.5)  # the look's end, 0.3 s early
    assert items["wave"].end == pytest.approx(0.5 + clip.get("duration", 2.7))
    assert items["wave"].anchors == {"beat": pytest.approx(0.5 + clip["anchors"]["beat"])}
    assert items["hello"].start == pytest.approx(items["wave"].anchors["beat"])  # a word on the beat
    assert items["hello"].spec["text"] == "Hello Ana!"
    assert items["hello"].end - items["hello"].start == pytest.approx(0.8)  # 2 words at 2.5 words/s
    assert p.duration == pytest.approx(items["wave"].end)


def test_retimed_anchors_speed_and_file_lengths(session):
    doc = {
        "tracks": [
            {
                "name": "a",
                "items": [
                    {"id": "n", "kind": "play_clip", "clip": "nod", "speed": 2.0},
                    {"id": "w", "kind": "play_clip", "clip": "wave", "anchors": {"beat": 1.0}, "start": 1.0},
                    {
                        "id": "s",
                        "kind": "play_sound",
                        "sound": "speech_hello",
                        "start": {"item": "w", "at": "anchor", "anchor": "beat", "offset": 0.25},
                    },
                    {"id": "r", "kind": "say", "text": "hi", "audio": "speech_hooray", "start": 0.0},
                    {"id": "p", "kind": "go_posture", "posture": "happy", "start": 0.0},
                ],
            }
        ]
    }
    items, _ = planned(session, doc)
    nod = session.library.get("clips", "nod")
    nod_len = max(k["t"] for keys in nod["tracks"].values() for k in keys)
    assert items["n"].end == pytest.approx(nod_len / 2.0)
    assert items["n"].anchors["down"] == pytest.approx(nod["anchors"]["down"] / 2.0)
    assert items["w"].anchors["beat"] == pytest.approx(2.0)  # landed where the item asked
    assert items["s"].start == pytest.approx(2.25)
    assert items["s"].end - items["s"].start == pytest.approx(
        session.library.sounds.info("speech_hello").duration
    )
    assert items["r"].end == pytest.approx(session.library.sounds.info("speech_hooray").duration)
    posture_block = session.engine.apu.block("posture")
    assert items["p"].end == pytest.approx(posture_block.params.duration)  # the program's own default


def test_every_error_is_reported_on_its_item_and_field(session):
    doc = greet()
    doc["tracks"][1]["items"][0]["clip"] = "wav"
    doc["tracks"][2]["items"][0]["text"] = "Hello {nobody}!"
    doc["tracks"][3]["items"][0]["expression"] = "smirk"
    doc["tracks"][3]["items"][1]["dof"] = "head_yaw"
    doc["tracks"][4]["items"].append({"id": "look", "kind": "wait"})
    doc["tracks"][4]["items"].append({"id": "lost", "kind": "wait", "start": {"item": "ghost"}})
    found = errors(session, doc)
    where = {(item, field) for item, field, _ in found}
    assert ("wave", "clip") in where
    assert ("smile", "expression") in where and ("warm_eyes", "dof") in where
    assert ("look", "id") in where and ("lost", "start.item") in where
    assert any("smirk" in m and "options" in m for _, _, m in found)
    # the say after a clip that cannot be timed is not also blamed for it
    assert not any(item == "hello" and field == "start.anchor" for item, field, _ in found)


def test_format_errors_name_the_item_and_field():
    doc = greet()
    doc["tracks"][0]["items"][0]["duration"] = -1
    doc["tracks"][1]["items"].append({"id": "x", "kind": "dance"})
    doc["tracks"][1]["items"].append({"id": "9bad", "kind": "wait"})
    beh, issues = parse(doc)
    assert beh is None
    where = {(i.item, i.field) for i in issues}
    assert ("look", "duration") in where
    assert any(i.item == "x" and "dance" in i.message for i in issues)
    assert ("9bad", "id") in where
    assert all(i.path.startswith("tracks.") for i in issues)


def test_timing_cycles_and_early_starts_are_errors(session):
    doc = {
        "tracks": [
            {
                "name": "a",
                "items": [
                    {"id": "a", "kind": "wait", "start": {"item": "b", "at": "end"}},
                    {"id": "b", "kind": "wait", "start": {"item": "a", "at": "start"}},
                    {"id": "c", "kind": "wait", "start": {"item": "d", "offset": -2.0}},
                    {"id": "d", "kind": "wait", "start": 1.0},
                    {"id": "e", "kind": "wait", "start": {"item": "d", "at": "anchor", "anchor": "beat"}},
                ],
            }
        ]
    }
    found = errors(session, doc)
    assert any(item in ("a", "b") and "circle" in m for item, _, m in found)
    assert any(item == "c" and field == "start.offset" for item, field, _ in found)
    assert any(item == "e" and "not a clip" in m for item, _, m in found)


def test_parameters_are_typed_and_substituted(session):
    doc = greet()
    assert errors(session, doc, {"name": 3}) == [(None, "name", "'name' is a string, got 3")]
    assert errors(session, doc, {"target": [1, 2]})[0][1] == "target"
    assert errors(session, doc, {"mood": 1})[0][1] == "mood"
    assert errors(session, doc, {"target": "nope"})[0][2].startswith("'target': the running program has no")
    items, _ = planned(session, doc, {"target": "gaze_target"})  # a vec3 input: followed live
    assert items["look"].follow == "gaze_target"
    doc["params"]["name"].pop("default")
    assert errors(session, doc)[0][2] == "parameter 'name' is required"
    assert errors(session, doc, strict=False) == []  # a document can be saved without it
    sleepy = json.loads((DESK / "behaviours" / "sleepy.json").read_text())
    items, _ = planned(session, sleepy, {"slowness": 4.0})
    assert items["droop"].end - items["droop"].start == pytest.approx(4.0)
    assert errors(session, sleepy, {"slowness": 40.0})[0][1] == "slowness"


def test_preflight_names_what_the_running_program_lacks(desk):
    b = ProgramBuilder("bare")
    b.chain(b.node("rest_pose"), b.output())
    bare = EngineSession.create(desk, program=b.to_dict())
    beh, _ = parse(greet())
    p, issues = plan(beh, None, vocabulary_of(bare))
    assert not issues
    missing = {(i.item, i.field): i.message for i in preflight(bare, p)}
    assert "clip player" in missing[("wave", "kind")]
    assert "gaze_target" in missing[("look", "kind")]
    assert "valence" in missing[("happy", "kind")]
    assert ("hello", "kind") not in missing  # speech goes out as an event without a say block


def test_the_document_round_trips_through_the_library():
    doc = copy.deepcopy(greet())
    beh, _ = parse(doc)
    again, issues = parse(json.loads(json.dumps(beh.model_dump(mode="json", exclude_none=True))))
    assert again == beh and not issues
