"""Behaviours (`nutty-behaviour/1`): multi-modal sequences of clips, postures, gaze, speech, sounds,
lights, faces, mood and input ramps, timed against each other, written by animators and played by AIs.

- `format`: the document's pydantic models (the one source of the format and its JSON Schema);
- `plan`: a document and its parameters -> every item's start and end, or every error on its item;
- `vocabulary`: what a behaviour may name on a robot and program (clips, postures, sounds, inputs);
- `player`: the engine side, on the clock thread: items become commands at their ticks;
- the command `play_behaviour` lives with the other commands (backend.control.behaviours).
"""

from __future__ import annotations

from typing import Any

from backend.behaviours.format import BEHAVIOUR_FORMAT, Behaviour, behaviour_json_schema
from backend.behaviours.issues import BehaviourInvalid, Issue
from backend.behaviours.plan import Plan, PlannedItem, parse, plan, plan_or_raise
from backend.behaviours.vocabulary import Vocabulary, vocabulary_of
from backend.engine.asset_errors import LibraryError

__all__ = [
    "BEHAVIOUR_FORMAT",
    "Behaviour",
    "BehaviourInvalid",
    "Issue",
    "Plan",
    "PlannedItem",
    "Vocabulary",
    "behaviour_json_schema",
    "parse",
    "plan",
    "plan_or_raise",
    "validate_behaviour_doc",
    "vocabulary_of",
]


def validate_behaviour_doc(doc: Any) -> dict[str, Any]:
    """The library's format check of a behaviour (its first error as a LibraryError naming the path);
    what it names on the robot is checked by the API with the robot's vocabulary before saving."""
    beh, issues = parse(doc)
    if beh is None:
        first = issues[0]
        raise LibraryError(f"invalid behaviour: {first.render()}", first.path or None)
    return beh.model_dump(mode="json", exclude_none=True)
