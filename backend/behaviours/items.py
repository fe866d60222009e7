"""How each planned item of a behaviour becomes a command of the running program (the same commands
REST and AIs send, so everything goes through the program's blocks, its layers and the safety net), and
what the program must have for it (checked before a behaviour starts)."""

from __future__ import annotations

from typing import Any

from backend.behaviours.issues import Issue
from backend.behaviours.plan import Plan, PlannedItem

#: items whose block reports their end (started/completed/cancelled under the item's command id)
REPORTED = frozenset({"play_clip", "go_posture", "say", "play_sound"})


def command_for(item: PlannedItem, target: Any = None) -> dict[str, Any] | None:
    """The command that starts `item` (None for a ramp or a wait, which the player carries out).
    `target`: a followed input's value, for a look_at that follows one."""
    spec = item.spec
    kind = item.kind
    if kind == "play_clip":
        keep = ("clip", "speed", "crossfade", "layer", "anchors")
        return {
            "type": "play_clip",
            **{k: spec[k] for k in keep if spec.get(k) is not None},
            "if_busy": "replace",
        }
    if kind == "go_posture":
        return {
            "type": "go_posture",
            **{k: spec[k] for k in ("posture", "duration", "easing") if spec.get(k)},
        }
    if kind == "look_at":
        return {"type": "set_gaze", "target": list(target if target is not None else spec["target"])}
    if kind == "say":
        return {
            "type": "say",
            "text": spec["text"],
            **({"audio": spec["audio"]} if spec.get("audio") else {}),
        }
    if kind == "play_sound":
        return {"type": "play_sound", "sound": spec["sound"]}
    if kind == "set_led":
        return {
            "type": "set_led",
            "colour": list(spec["colour"]),
            **({"dof": spec["dof"]} if spec.get("dof") else {}),
        }
    if kind == "set_face":
        return {
            "type": "set_face",
            "expression": spec["expression"],
            **({"dof": spec["dof"]} if spec.get("dof") else {}),
        }
    if kind == "set_emotion":
        return {"type": "set_emotion", "valence": spec["valence"], "arousal": spec["arousal"]}
    return None


def preflight(session: Any, plan: Plan) -> list[Issue]:
    """What keeps the running program from carrying out the plan's items, each on its item: a command
    that does not parse, or that has nothing to act on (no clip player, no gaze_target input, ...)."""
    from backend import control  # the commands: imported when a behaviour is checked, not with the format
    from backend.control.targets import blocks_of, declares_input

    issues: list[Issue] = []
    for item in plan.items:
        spec_cmd = command_for(item, target=[1.0, 0.0, 0.0] if item.follow else None)
        where = item.path
        if spec_cmd is None:
            continue
        try:
            cmd = control.parse_command(spec_cmd)
        except control.CommandError as exc:
            issues.append(Issue(str(exc), where, item.track, item.id, exc.field))
            continue
        acts_on = cmd.acts_on
        missing = None
        if acts_on.role == "block" and not blocks_of(session, acts_on.blocks):
            missing = f"the running program has no {acts_on.what} to {item.kind.replace('_', ' ')}"
        elif item.kind == "look_at" and not declares_input(session, "gaze_target"):
            missing = "the running program declares no 'gaze_target' input to look with"
        elif item.kind == "set_emotion" and not (
            declares_input(session, "valence") or declares_input(session, "arousal")
        ):
            missing = "the running program declares no 'valence'/'arousal' inputs"
        elif item.kind in ("say", "play_sound") and not blocks_of(session, acts_on.blocks):
            channel = "speech" if item.kind == "say" else "sound"
            if not any(d.kind == channel for d in session.embodiment.event_dofs):
                missing = f"robot '{session.embodiment.name}' has no {channel} channel"
        if missing is not None:
            issues.append(Issue(missing, where, item.track, item.id, "kind"))
    return issues
