"""Play a behaviour: a multi-modal sequence of the robot's library (backend.behaviours), one command."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from backend.control.ai import AiTool, Choice
from backend.control.base import BaseCommand, CommandContext, Target
from backend.control.errors import CommandError
from backend.control.session_view import CommandSession


def _behaviour_notes(live: Any) -> str:
    lines = []
    for b in live.behaviours:
        params = ", ".join(f"{n}: {p.get('type')}" for n, p in live.behaviour_params.get(b.name, {}).items())
        lines.append(f"{b.name}({params})")
    return (
        "Everything a behaviour does goes through the running program and the robot's limits; it ends "
        "with one event (completed, cancelled or failed) and reports each item as it starts and ends. "
        "Signatures: " + "; ".join(lines)
    )


def _params_schema(live: Any, schema: dict[str, Any]) -> None:
    """`params`: every behaviour's parameters, each described with the behaviours that take it."""
    props: dict[str, Any] = {}
    for name, params in live.behaviour_params.items():
        for pname, p in params.items():
            entry = props.setdefault(pname, _param_schema(p))
            entry.setdefault("x-behaviours", []).append(name)
    for entry in props.values():
        users = entry.pop("x-behaviours")
        entry["description"] = f"{entry.get('description') or ''} (for {', '.join(users)})".strip()
    schema["properties"]["params"] = {
        "type": "object",
        "additionalProperties": False,
        "properties": props,
        "description": "the behaviour's parameters by name; those left out take their defaults",
    }


def _param_schema(p: dict[str, Any]) -> dict[str, Any]:
    kind = p.get("type")
    if kind == "number":
        out: dict[str, Any] = {"type": "number"}
        if p.get("min") is not None:
            out["minimum"] = p["min"]
        if p.get("max") is not None:
            out["maximum"] = p["max"]
    elif kind == "bool":
        out = {"type": "boolean"}
    elif kind == "vec3":
        point = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}
        out = {"anyOf": [point, {"type": "string"}]}
        p = {
            **p,
            "description": f"{p.get('description') or ''} [x, y, z] in m (x forward, y left, z up), "
            "or the name of an exposed input to follow".strip(),
        }
    else:
        out = {"type": "string", **({"enum": p["choices"]} if p.get("choices") else {})}
    if p.get("default") is not None:
        out["default"] = p["default"]
    out["description"] = p.get("description") or ""
    return out


class PlayBehaviour(BaseCommand):
    """Play a behaviour of the robot's library (`robots/<robot>/behaviours/<name>.json`) with
    parameters. One behaviour plays at a time: while one plays, `if_busy` decides: `replace` (default;
    the playing one is cancelled), `queue` (it starts when the playing ones end; acked `queued`) or
    `reject` (code `busy`, naming the playing behaviour's id)."""

    acts_on = Target(role="engine", what="behaviour player")
    long_action = True
    ai_tool = AiTool(
        "play_behaviour",
        "Play one of the robot's behaviours: a whole performance (gestures, gaze, speech, sounds, "
        "lights, mood) timed by an animator, with parameters.",
        available=lambda live: bool(live.behaviours),
        choices={"behaviour": (lambda live: live.behaviours, "the robot's behaviours")},
        hide=("document",),
        notes=_behaviour_notes,
        shape=_params_schema,
        order=5,
    )
    type: Literal["play_behaviour"] = "play_behaviour"
    behaviour: str = Field(..., min_length=1, max_length=80, description="name of a behaviour of the robot")
    params: dict[str, Any] | None = Field(default=None, description="parameter name -> value")
    if_busy: Literal["replace", "queue", "reject"] | None = Field(
        default=None,
        description="while another behaviour plays: replace it (default), queue behind it, or reject this",
    )
    document: dict[str, Any] | None = Field(
        default=None,
        description="an unsaved behaviour (nutty-behaviour/1) to play under the name `behaviour`: the "
        "editor's working copy",
    )

    def run(self, ctx: CommandContext) -> Any:
        # the behaviours package imports the commands (its items are commands): only when one plays
        from backend.behaviours import BehaviourInvalid, parse, plan, vocabulary_of
        from backend.behaviours.items import preflight
        from backend.behaviours.player import BusyError

        session = ctx.session
        doc = self.document if self.document is not None else _stored(session, self.behaviour)
        beh, issues = parse(doc)
        if beh is None:
            raise _invalid(BehaviourInvalid(issues, f"behaviour '{self.behaviour}'"))
        planned, issues = plan(beh, self.params, vocabulary_of(session))
        issues = issues or preflight(session, planned)
        if issues:
            raise _invalid(BehaviourInvalid(issues, f"behaviour '{self.behaviour}'"))
        try:
            return session.behaviours.play(planned, ctx.command_id, self.behaviour, self.if_busy or "replace")
        except BusyError as exc:
            raise CommandError(str(exc), field="if_busy", code="busy", playing=exc.playing) from exc

    @classmethod
    def cancel(cls, session: CommandSession, command_id: str) -> None:
        session.behaviours.cancel(command_id)


def _stored(session: CommandSession, name: str) -> dict[str, Any]:
    try:
        return session.library.get("behaviours", name)
    except ValueError as exc:  # NotFound, a bad name or a broken file
        known = _names(session)
        raise CommandError(f"{exc} (behaviours: {known})", field="behaviour", code="not_found") from exc


def _names(session: CommandSession) -> list[str]:
    try:
        return session.library.list("behaviours")
    except ValueError:
        return []


def _invalid(exc: Any) -> CommandError:
    """A behaviour's errors as the command's: the first one's path is the field, all are listed."""
    return CommandError(str(exc), field=exc.field, code="invalid_behaviour", errors=exc.extra["errors"])


def behaviour_choices(session: CommandSession) -> tuple[list[Choice], dict[str, dict[str, Any]]]:
    """The behaviours AIs may play (those the running program can carry out with their defaults), with
    descriptions and lengths, and their parameters (name -> declared parameters)."""
    from backend.behaviours import parse, plan, vocabulary_of  # as in PlayBehaviour.run
    from backend.behaviours.items import preflight

    choices, params = [], {}
    vocab = None
    for name in _names(session):
        try:
            beh, _ = parse(session.library.get("behaviours", name))
        except ValueError:
            continue
        if beh is None:
            continue
        vocab = vocab or vocabulary_of(session)
        planned, issues = plan(beh, None, vocab, strict=False)
        if issues or preflight(session, planned):
            continue  # it would fail: the editor's list says why (GET /api/behaviours)
        choices.append(Choice(name, " ".join(beh.description.split()), round(planned.duration, 3)))
        params[name] = {k: p.model_dump(exclude_none=True) for k, p in beh.params.items()}
    return choices, params
