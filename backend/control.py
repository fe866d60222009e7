"""Commands that AIs and the editor send to a running engine (REST, WebSocket, `nutty run --commands`).

One typed union (pydantic, discriminated by `type`), so every entry point validates the same way and
the editor's TypeScript types are generated from it. A command addressed to a kind of block (a clip
player, a posture block, a say block) is routed to the block named by `node`, else to the one on
`layer`, else to the only block of that kind; when the running program has none, the error says so.
Display and audible commands fall back to the engine itself (a display override, an injected event).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, field_validator

from backend.security import JsonSafetyError, check_json

Vec3 = tuple[float, float, float]


class _Command(BaseModel):
    model_config = ConfigDict(extra="forbid")
    id: str | None = Field(None, max_length=64, description="client-chosen id (echoed in acks and events)")


class _Targeted(_Command):
    node: str | None = Field(None, description="node id of the target block (optional)")
    layer: str | None = Field(None, description="layer whose chain holds the target block (optional)")


class PlayClip(_Targeted):
    """Play a clip on a clip player (e.g. the one on layer 'gesture')."""

    type: Literal["play_clip"] = "play_clip"
    clip: str = Field(..., min_length=1, max_length=80)
    speed: float | None = Field(None, gt=0.0, le=5.0, description="playback speed (1 = authored timing)")
    mode: Literal["once", "loop", "ping_pong"] | None = None
    crossfade: float | None = Field(None, ge=0.0, le=10.0, description="crossfade from the current pose (s)")
    anchors: dict[str, float] | None = Field(None, description="anchor name -> time (s) it must land at")


class StopClip(_Targeted):
    type: Literal["stop_clip"] = "stop_clip"
    fade: float | None = Field(None, ge=0.0, le=10.0)


class SeekClip(_Targeted):
    type: Literal["seek_clip"] = "seek_clip"
    t: float = Field(..., ge=0.0, description="time in the clip (s)")


class GoPosture(_Targeted):
    """Go to a named posture of the robot's pose library."""

    type: Literal["go_posture"] = "go_posture"
    posture: str = Field(..., min_length=1, max_length=80)
    duration: float | None = Field(None, gt=0.0, le=30.0, description="s")
    easing: str | None = None


class SetGaze(_Command):
    """Look at a point (m, robot base frame): sets the program's `gaze_target` input."""

    type: Literal["set_gaze"] = "set_gaze"
    target: Vec3


class SetInput(_Command):
    """Set one exposed input of the running program."""

    type: Literal["set_input"] = "set_input"
    name: str
    value: Any


class SetInputs(_Command):
    """Set several exposed inputs at the same tick."""

    type: Literal["set_inputs"] = "set_inputs"
    values: dict[str, Any]


class SetLayer(_Command):
    """Activate or deactivate a layer of a layer mixer, fading over `fade` seconds."""

    type: Literal["set_layer"] = "set_layer"
    layer: str
    active: bool = True
    fade: float | None = Field(None, ge=0.0, le=30.0)
    mixer: str | None = Field(None, description="mixer node id; default: the mixer that has this layer")


class Say(_Targeted):
    type: Literal["say"] = "say"
    text: str = Field(..., min_length=1, max_length=2000)


class PlaySound(_Targeted):
    type: Literal["play_sound"] = "play_sound"
    sound: str = Field(..., min_length=1, max_length=80)


class SetLed(_Command):
    """Set a colour DoF (an LED or LED group) to an RGB colour in [0, 1]."""

    type: Literal["set_led"] = "set_led"
    dof: str | None = Field(None, description="colour DoF; default: the robot's first")
    colour: Vec3

    @field_validator("colour")
    @classmethod
    def _range(cls, v: Vec3) -> Vec3:
        if not all(0.0 <= c <= 1.0 for c in v):
            raise ValueError("colour components must be within [0, 1]")
        return v


class SetFace(_Command):
    """Show a face/screen expression (an option of an enum display DoF)."""

    type: Literal["set_face"] = "set_face"
    dof: str | None = None
    expression: str


class SetEmotion(_Command):
    """Set the program's `valence` and `arousal` inputs (-1..1)."""

    type: Literal["set_emotion"] = "set_emotion"
    valence: float = Field(..., ge=-1.0, le=1.0)
    arousal: float = Field(..., ge=-1.0, le=1.0)


class Reset(_Command):
    """Start the running program afresh: long actions are cancelled, every block, layer and exposed
    input is as the program declares it, display overrides are cleared; the robot blends there over
    `fade` seconds (longer if its limits need it)."""

    type: Literal["reset"] = "reset"
    fade: float = Field(1.0, ge=0.0, le=30.0)


class StopAll(_Command):
    """Stop everything now: clips, pending actions, overrides; exposed inputs back to their defaults."""

    type: Literal["stop_all"] = "stop_all"


class Cancel(_Command):
    """Cancel a long action by the id it was given."""

    type: Literal["cancel"] = "cancel"
    target: str


Command = Annotated[
    Union[PlayClip, StopClip, SeekClip, GoPosture, SetGaze, SetInput, SetInputs, SetLayer, Say, PlaySound,
          SetLed, SetFace, SetEmotion, Reset, StopAll, Cancel],
    Field(discriminator="type"),
]
COMMAND_ADAPTER: TypeAdapter = TypeAdapter(Command)
LONG_ACTIONS = {"play_clip", "go_posture", "say"}


class CommandError(ValueError):
    """A command that is malformed or cannot be carried out; `field` names the culprit."""

    def __init__(self, message: str, field: str | None = None, code: str = "invalid_command"):
        super().__init__(message)
        self.field = field
        self.code = code


def parse_command(data: Any, where: str = "command") -> Any:
    """Validate a command; raises CommandError (a ValueError) naming the field.

    Every entry point (REST, WebSocket, `nutty run --commands`, in-process callers) gets the same
    JSON-safety check (`backend.security.check_json`: finite numbers, valid Unicode, bounded depth)
    before the typed union.
    """
    if not isinstance(data, dict):
        raise CommandError(f"{where}: a command is a JSON object with a 'type'")
    try:
        check_json(data)
    except JsonSafetyError as exc:
        raise CommandError(f"{where}: {exc}", field=exc.field, code=exc.code) from exc
    try:
        return COMMAND_ADAPTER.validate_python(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = [str(x) for x in err["loc"]]
        if loc and loc[0] == data.get("type"):
            loc = loc[1:]
        field = ".".join(loc) or "type"
        raise CommandError(f"{where}: {field}: {err['msg']}", field=field) from exc


def command_json_schema() -> dict[str, Any]:
    return COMMAND_ADAPTER.json_schema()


# --------------------------------------------------------------------------------------------------
# Execution
# --------------------------------------------------------------------------------------------------


def _blocks(session: Any, type_names: tuple[str, ...]) -> list[Any]:
    apu = session.engine.apu
    return [s.block for s in apu.steps if s.block.type_name in type_names] if apu else []


def _upstream_of_layer(session: Any, layer: str) -> set[str]:
    """Node ids whose output reaches the mixer input named `layer`."""
    apu = session.engine.apu
    if apu is None:
        return set()
    heads = [apu.steps[w.src].node_id for s in apu.steps if s.block.role.value == "mixer"
             for w in s.wires if w.port == layer]
    seen: set[str] = set()
    stack = list(heads)
    while stack:
        nid = stack.pop()
        if nid in seen:
            continue
        seen.add(nid)
        stack.extend(apu.steps[w.src].node_id for w in apu.steps[apu.index[nid]].wires)
    return seen


def find_block(session: Any, type_names: tuple[str, ...], what: str, node: str | None = None,
               layer: str | None = None) -> Any:
    blocks = _blocks(session, type_names)
    if node:
        found = [b for b in blocks if b.node_id == node]
        if not found:
            raise CommandError(f"the running program has no {what} with id '{node}'", field="node",
                               code="no_target")
        return found[0]
    if layer:
        ids = _upstream_of_layer(session, layer)
        found = [b for b in blocks if b.node_id in ids]
        if not found:
            raise CommandError(f"the running program has no {what} on layer '{layer}'", field="layer",
                               code="no_target")
        return found[0]
    if len(blocks) == 1:
        return blocks[0]
    if not blocks:
        raise CommandError(f"the running program has no {what}", code="no_target")
    raise CommandError(f"the running program has {len(blocks)} {what}s ({[b.node_id for b in blocks]}); "
                       f"name one with 'node' or 'layer'", field="node", code="ambiguous_target")


def _handle(session: Any, block: Any, command: str, args: dict[str, Any]) -> Any:
    from backend.engine.blocks.base import BlockCommandError

    try:
        return session.engine.call(lambda: block.handle(command, args))
    except BlockCommandError as exc:
        raise CommandError(str(exc), code="rejected") from exc


def _mixer_layers(session: Any) -> list[Any]:
    from backend.engine.blocks.mixer import LayerMixer

    apu = session.engine.apu
    return [s.block for s in apu.steps if isinstance(s.block, LayerMixer)] if apu else []


def _declared(session: Any, name: str) -> bool:
    return session.program is not None and session.program.input(name) is not None


def _set_inputs(session: Any, values: dict[str, Any]) -> dict[str, Any]:
    """Check every value first, then set them all at one tick: a rejected command changes nothing."""
    program = session.program
    out = {}
    for name, value in values.items():
        decl = program.input(name) if program is not None else None
        if decl is None:
            declared = [i.name for i in program.inputs] if program is not None else []
            raise CommandError(f"the running program has no exposed input '{name}' (declared: {declared})",
                               field=name, code="invalid_input")
        try:
            out[name] = decl.coerce(value)
        except (ValueError, TypeError, OverflowError) as exc:
            raise CommandError(str(exc), field=name, code="invalid_input") from exc
    session.engine.call(lambda: session.engine.ctx.inputs.update(out))
    return out


def execute(session: Any, command: Any, command_id: str | None = None) -> Any:
    """Carry out a parsed command on an EngineSession (changes land at the next tick boundary)."""
    cid = command_id or command.id
    t = command.type
    if t == "set_input":
        return _set_inputs(session, {command.name: command.value})
    if t == "set_inputs":
        return _set_inputs(session, command.values)
    if t == "set_gaze":
        if not _declared(session, "gaze_target"):
            raise CommandError("the running program declares no 'gaze_target' input", code="no_target")
        return _set_inputs(session, {"gaze_target": list(command.target)})
    if t == "set_emotion":
        names = [n for n in ("valence", "arousal") if _declared(session, n)]
        if not names:
            raise CommandError("the running program declares no 'valence'/'arousal' inputs", code="no_target")
        return _set_inputs(session, {n: getattr(command, n) for n in names})
    if t == "set_layer":
        mixers = _mixer_layers(session)
        if command.mixer:
            mixers = [m for m in mixers if m.node_id == command.mixer]
        target = next((m for m in mixers if command.layer in m.names), None)
        if target is None:
            raise CommandError(f"no layer mixer has a layer '{command.layer}'", field="layer", code="no_target")
        session.engine.call(lambda: target.set_layer_active(command.layer, command.active, command.fade))
        return {"layer": command.layer, "active": command.active}
    if t == "play_clip":
        block = find_block(session, ("clip_player",), "clip player", command.node, command.layer)
        args = command.model_dump(exclude={"type", "node", "layer", "id"}, exclude_none=True)
        return _handle(session, block, "play", {**args, "command_id": cid})
    if t == "stop_clip":
        block = find_block(session, ("clip_player",), "clip player", command.node, command.layer)
        return _handle(session, block, "stop", {"fade": command.fade, "command_id": cid})
    if t == "seek_clip":
        block = find_block(session, ("clip_player",), "clip player", command.node, command.layer)
        return _handle(session, block, "seek", {"t": command.t, "command_id": cid})
    if t == "go_posture":
        block = find_block(session, ("posture",), "posture block", command.node, command.layer)
        args = command.model_dump(exclude={"type", "node", "layer", "id"}, exclude_none=True)
        return _handle(session, block, "go", {**args, "command_id": cid})
    if t in ("say", "play_sound"):
        kind = "speech" if t == "say" else "sound"
        blocks = _blocks(session, ("say",) if t == "say" else ("play_sound",))
        if blocks:
            block = find_block(session, (blocks[0].type_name,), f"{t} block", command.node, command.layer)
            payload = {"text": command.text} if t == "say" else {"sound": command.sound}
            return _handle(session, block, t, {**payload, "command_id": cid})
        dof = next((d for d in session.embodiment.event_dofs if d.kind == kind), None)
        if dof is None:
            raise CommandError(f"robot '{session.embodiment.name}' has no {kind} channel", code="no_target")
        if t == "play_sound" and dof.sounds and command.sound not in dof.sounds:
            raise CommandError(f"unknown sound '{command.sound}' (one of {list(dof.sounds)})", field="sound")
        from backend.engine.frames import FrameEvent

        payload = {"text": command.text} if t == "say" else {"clip": command.sound}
        session.engine.inject_event(FrameEvent(dof.name, "say" if t == "say" else "sound", payload))
        return {"dof": dof.name, **payload, "done": True}  # emitted at once: nothing left to wait for
    if t in ("set_led", "set_face"):
        block = _display_block(session, command)
        if block is not None:  # the program shows this DoF itself: tell its led/face block
            args = command.model_dump(exclude={"type", "id"}, exclude_none=True)
            return _handle(session, block, t, {**args, "command_id": cid})
        return _display_override(session, command)
    if t == "reset":
        # Long actions end as cancelled (their blocks are about to be replaced), then the program
        # starts afresh as it declares itself: layers, inputs, no overrides.
        for block in _blocks(session, ("clip_player", "posture", "say")):
            try:
                _handle(session, block, "stop", {"fade": 0.0})
            except CommandError:  # a block with nothing to stop
                pass
        session.reset(fade=command.fade)
        return {"reset": True}
    if t == "stop_all":
        for block in _blocks(session, ("clip_player",)):
            _handle(session, block, "stop", {"fade": 0.0})
        session.engine.call(session.engine.clear_overrides)
        if session.program is not None:
            defaults = {i.name: i.default for i in session.program.inputs}
            if defaults:
                _set_inputs(session, defaults)
        return {"stopped": True}
    raise CommandError(f"unsupported command type '{t}'", field="type")


def _display_block(session: Any, command: Any) -> Any:
    """The program's led/face block driving the command's DoF (or the only one, if no DoF is named)."""
    blocks = _blocks(session, ("led",) if command.type == "set_led" else ("face",))
    if command.dof:
        blocks = [b for b in blocks if getattr(getattr(b, "dof", None), "name", None) == command.dof]
    return blocks[0] if len(blocks) == 1 else None


def _display_override(session: Any, command: Any) -> Any:
    from backend.engine.blocks.core import pose_vector
    from backend.engine.embodiment import DofType

    emb = session.embodiment
    want = DofType.colour if command.type == "set_led" else DofType.enum
    if command.dof:
        if not emb.has_dof(command.dof):
            raise CommandError(f"robot '{emb.name}' has no DoF '{command.dof}'", field="dof")
        dof = emb.dof(command.dof)
        if dof.type is not want:
            raise CommandError(f"DoF '{dof.name}' is {dof.type.value}, not {want.value}", field="dof")
    else:
        dof = next((d for d in emb.dofs if d.type is want), None)
        if dof is None:
            raise CommandError(f"robot '{emb.name}' has no {want.value} display DoF", code="no_target")
    value = list(command.colour) if command.type == "set_led" else command.expression
    try:
        vec, mask = pose_vector(emb, {dof.name: value})
    except ValueError as exc:
        raise CommandError(str(exc), field="expression" if command.type == "set_face" else "colour") from exc
    session.engine.call(lambda: session.engine.set_override(mask, vec))
    return {"dof": dof.name, "value": value}
