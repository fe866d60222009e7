"""From JSON to a carried-out command: the union built from the registry, parsing with errors that
name the field, the JSON Schema, and `execute` (look the command up, run it)."""

from __future__ import annotations

import typing
from collections.abc import Callable
from typing import Annotated, Any, Union

import annotated_types
import orjson
from pydantic import Field, TypeAdapter, ValidationError

from backend.control.base import REGISTRY, BaseCommand, CommandContext
from backend.control.errors import CommandError
from backend.control.session_view import CommandSession
from backend.safe_json import validation_bytes
from backend.security import JsonSafetyError, check_json

_built: tuple[int, Any, TypeAdapter] | None = None  # (registry generation, union, its adapter)


def _union() -> tuple[Any, TypeAdapter]:
    global _built
    if _built is None or _built[0] != REGISTRY.generation:
        union: Any = Annotated[Union[REGISTRY.classes()], Field(discriminator="type")]  # noqa: UP007 (X | Y cannot spread a runtime tuple)
        _built = (REGISTRY.generation, union, TypeAdapter(union))
    return _built[1], _built[2]


def command_union() -> Any:
    """Every registered command as one pydantic union, discriminated by `type`."""
    return _union()[0]


def command_json_schema() -> dict[str, Any]:
    """JSON Schema of the command union (GET /api/schema/commands; the editor's types come from it)."""
    return _union()[1].json_schema()


def parse_command(data: Any, where: str = "command") -> BaseCommand:
    """Validate a command; raises CommandError (a ValueError) naming the field in plain words.

    Every entry point (REST, WebSocket, `nutty run --commands`, in-process callers) gets the same
    JSON-safety check (`backend.security.check_json`: finite numbers, valid Unicode, bounded depth)
    before the typed union, which is validated *strictly*, as JSON: a number is a JSON number (not a
    bool, not a string), a vector a JSON array, an option one of its names; nothing is coerced.
    """
    if not isinstance(data, dict):
        raise CommandError(f"{where}: a command is a JSON object with a 'type'")
    try:
        check_json(data)
    except JsonSafetyError as exc:
        raise CommandError(f"{where}: {exc}", field=exc.field, code=exc.code) from exc
    try:
        return _union()[1].validate_json(validation_bytes(data), strict=True)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = [str(x) for x in err["loc"]]
        if loc and loc[0] == data.get("type"):  # the union's tag, not a field of the command
            loc = loc[1:]
        field = ".".join(loc) or "type"
        raise CommandError(
            f"{where}: {plain_error(err, REGISTRY.get(data.get('type')), loc)}", field=field
        ) from exc


def _bounds(cls: Any, loc: list[str]) -> tuple[Any, Any]:
    """(lower, upper) a command field (or, for `target.0`, its tuple item) declares (ge/gt, le/lt; None
    when open), for an error message."""
    field = getattr(cls, "model_fields", {}).get(loc[0]) if loc else None
    metadata = list(getattr(field, "metadata", []))
    if field is not None and len(loc) > 1 and loc[1].isdigit():  # an item of a tuple of Annotated numbers
        items = typing.get_args(field.annotation)
        item = items[int(loc[1])] if int(loc[1]) < len(items) else None
        for extra in typing.get_args(item)[1:]:
            metadata += list(getattr(extra, "metadata", [extra]))
    lo = hi = None
    for m in metadata:
        if isinstance(m, (annotated_types.Ge, annotated_types.Gt)):
            lo = getattr(m, "ge", getattr(m, "gt", None))
        if isinstance(m, (annotated_types.Le, annotated_types.Lt)):
            hi = getattr(m, "le", getattr(m, "lt", None))
    return lo, hi


def plain_error(err: Any, cls: Any, loc: list[str]) -> str:
    """One pydantic error of a command as a sentence naming the field: "valence must be between -1 and
    1", "speed must be a number, not true"."""
    name = ".".join(loc) or "type"
    kind, ctx, given = err["type"], err.get("ctx") or {}, err.get("input")
    shown = (
        orjson.dumps(given).decode()[:60] if isinstance(given, (bool, int, float, str, type(None))) else None
    )
    if kind in ("greater_than_equal", "less_than_equal", "greater_than", "less_than"):
        lo, hi = _bounds(cls, loc)
        if lo is not None and hi is not None:
            return f"{name} must be between {lo:g} and {hi:g}, got {shown}"
        bound = next(iter(ctx.values()), "?")
        word = {
            "greater_than_equal": "at least",
            "less_than_equal": "at most",
            "greater_than": "more than",
            "less_than": "less than",
        }[kind]
        return f"{name} must be {word} {bound}, got {shown}"
    if kind in ("float_type", "int_type", "float_parsing", "int_from_float", "int_parsing"):
        what = "a whole number" if kind.startswith("int") else "a number"
        return f"{name} must be {what}, not {shown}" if shown is not None else f"{name} must be {what}"
    if kind in ("bool_type", "bool_parsing"):
        return f"{name} must be true or false, not {shown}"
    if kind in ("string_type",):
        return f"{name} must be a string, not {shown}"
    if kind in ("tuple_type", "list_type", "too_short", "too_long") and shown is not None:
        return f"{name}: {err['msg']} (a JSON array), not {shown}"
    return f"{name}: {err['msg']}"


def execute(
    session: CommandSession,
    command: BaseCommand,
    command_id: str | None = None,
    *,
    cancel: Callable[[str], dict[str, Any]] | None = None,
) -> Any:
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


def cancel_command(session: CommandSession, command_type: Any, command_id: str) -> None:
    """Stop what the long action `command_id` (of `command_type`) started; anything else is left alone."""
    cls = REGISTRY.get(command_type)
    if cls is not None and cls.long_action:
        cls.cancel(session, command_id)
