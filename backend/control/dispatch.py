"""From JSON to a carried-out command: the union built from the registry, parsing with errors that
name the field, the JSON Schema, and `execute` (look the command up, run it)."""

from __future__ import annotations

from typing import Annotated, Any, Callable, Union

from pydantic import Field, TypeAdapter, ValidationError

from backend.control.base import REGISTRY, BaseCommand, CommandContext
from backend.control.errors import CommandError
from backend.security import JsonSafetyError, check_json

_built: tuple[int, Any, TypeAdapter] | None = None  # (registry generation, union, its adapter)


def _union() -> tuple[Any, TypeAdapter]:
    global _built
    if _built is None or _built[0] != REGISTRY.generation:
        union = Annotated[Union[REGISTRY.classes()], Field(discriminator="type")]  # Union[...] of a runtime tuple
        _built = (REGISTRY.generation, union, TypeAdapter(union))
    return _built[1], _built[2]


def command_union() -> Any:
    """Every registered command as one pydantic union, discriminated by `type`."""
    return _union()[0]


def command_json_schema() -> dict[str, Any]:
    """JSON Schema of the command union (GET /api/schema/commands; the editor's types come from it)."""
    return _union()[1].json_schema()


def parse_command(data: Any, where: str = "command") -> BaseCommand:
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
        return _union()[1].validate_python(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = [str(x) for x in err["loc"]]
        if loc and loc[0] == data.get("type"):  # the union's tag, not a field of the command
            loc = loc[1:]
        field = ".".join(loc) or "type"
        raise CommandError(f"{where}: {field}: {err['msg']}", field=field) from exc


def execute(session: Any, command: BaseCommand, command_id: str | None = None, *,
            cancel: Callable[[str], dict[str, Any]] | None = None) -> Any:
    """Carry out a parsed command on an EngineSession (changes land at the next tick boundary).

    `command_id` (default: the command's own `id`) tags the events its blocks report; `cancel` is the
    server's cancellation of a logged command by id, for the `cancel` command.
    """
    cls = REGISTRY.get(getattr(command, "type", None))
    if cls is None or not isinstance(command, cls):
        raise CommandError(f"unsupported command type '{getattr(command, 'type', None)}'", field="type")
    return command.run(CommandContext(session, command_id or command.id, cancel))


def is_long_action(command_type: Any) -> bool:
    """Whether commands of this type report started/completed/cancelled from their block."""
    cls = REGISTRY.get(command_type)
    return cls is not None and cls.long_action


def cancel_command(session: Any, command_type: Any, command_id: str) -> None:
    """Stop what the long action `command_id` (of `command_type`) started; anything else is left alone."""
    cls = REGISTRY.get(command_type)
    if cls is not None and cls.long_action:
        cls.cancel(session, command_id)
