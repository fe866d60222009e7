"""Commands that AIs and the editor send to a running engine (REST, WebSocket, `nutty run --commands`).

One typed union (pydantic, discriminated by `type`) so every entry point validates the same way.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError


class _Command(BaseModel):
    model_config = ConfigDict(extra="forbid")


class SetInput(_Command):
    """Set one exposed input of the running program."""

    type: Literal["set_input"] = "set_input"
    name: str
    value: Any


class SetLayer(_Command):
    """Activate or deactivate a layer of a layer mixer, fading over `fade` seconds."""

    type: Literal["set_layer"] = "set_layer"
    layer: str
    active: bool = True
    fade: float | None = Field(None, ge=0.0, le=30.0)
    mixer: str | None = Field(None, description="mixer node id; default: the mixer that has this layer")


Command = Annotated[Union[SetInput, SetLayer], Field(discriminator="type")]
_adapter: TypeAdapter = TypeAdapter(Command)


def parse_command(data: Any, where: str = "command") -> Any:
    """Validate a command; raises ValueError naming the field."""
    try:
        return _adapter.validate_python(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        field = ".".join(str(x) for x in err["loc"])
        raise ValueError(f"{where}: {field or 'type'}: {err['msg']}") from exc


def execute(session: Any, command: Any) -> Any:
    """Carry out a parsed command on an EngineSession."""
    if isinstance(command, SetInput):
        return session.set_input(command.name, command.value)
    if isinstance(command, SetLayer):
        from backend.engine.blocks.mixer import LayerMixer

        apu = session.engine.apu
        mixers = [s.block for s in apu.steps if isinstance(s.block, LayerMixer)] if apu else []
        if command.mixer:
            mixers = [m for m in mixers if m.node_id == command.mixer]
        target = next((m for m in mixers if command.layer in m.names), None)
        if target is None:
            raise ValueError(f"no layer mixer has a layer '{command.layer}'")
        return session.engine.call(lambda: target.set_layer_active(command.layer, command.active, command.fade))
    raise ValueError(f"unsupported command {command!r}")
