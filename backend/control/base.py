"""The command base classes and their registry.

A command is one pydantic class: its `type` literal, its fields (validated at every entry point),
what it acts on (`acts_on`), whether it is a long action, and `run`. Defining a subclass with a
`type` literal registers it; the union, `parse_command`, the JSON Schema and `execute` are built
from the registry (backend.control.dispatch).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field

from backend.control.errors import CommandError
from backend.control.targets import blocks_of, find_block, tell


@dataclass(frozen=True)
class Target:
    """What a command acts on.

    `blocks`: block type names it is routed to (see `BlockCommand`); `role`: what it acts on
    otherwise, or when the program has no such block — "input" (the program's exposed inputs),
    "mixer" (a layer mixer), "engine" (overrides, injected events, the whole session), "command"
    (another command, by id). `what` names the target in error messages ("clip player").
    """

    blocks: tuple[str, ...] = ()
    role: Literal["block", "input", "mixer", "engine", "command"] = "block"
    what: str = ""


@dataclass
class CommandContext:
    """What a running command may use: the EngineSession, the id its events carry, and the server's
    cancellation of a logged command by id (None in process, where no command log exists)."""

    session: Any
    command_id: str | None = None
    cancel: Callable[[str], dict[str, Any]] | None = None


class CommandRegistry:
    """Command classes by `type`, in the order they were defined (the order of the union)."""

    def __init__(self) -> None:
        self._classes: dict[str, type[BaseCommand]] = {}
        self.generation = 0  # bumped on every change, so what is built from the registry can be rebuilt

    def add(self, cls: type[BaseCommand]) -> None:
        name = cls.model_fields["type"].default
        old = self._classes.get(name)
        if old is not None and old.__qualname__ != cls.__qualname__:
            raise TypeError(f"command type '{name}' is already {old.__module__}.{old.__qualname__}")
        self._classes[name] = cls
        self.generation += 1

    def remove(self, name: str) -> None:
        """Forget a command type (for tests that define a command of their own)."""
        if self._classes.pop(name, None) is not None:
            self.generation += 1

    def get(self, name: Any) -> type[BaseCommand] | None:
        return self._classes.get(name) if isinstance(name, str) else None

    def classes(self) -> tuple[type[BaseCommand], ...]:
        return tuple(self._classes.values())

    def long_actions(self) -> frozenset[str]:
        return frozenset(name for name, cls in self._classes.items() if cls.long_action)


REGISTRY = CommandRegistry()


class BaseCommand(BaseModel):
    """A command. Subclasses with a `type: Literal["..."]` default are registered.

    `acts_on` declares the target; `long_action` commands are acked `started` and their block reports
    `started` and `completed`/`cancelled` itself (through the session's notes) unless `run` returns
    `{"done": True, ...}`; every other command is `completed` once `run` returns. `run` returns the
    JSON result of the ack, or raises CommandError naming the field.
    """

    model_config = ConfigDict(extra="forbid")
    id: str | None = Field(None, max_length=64, description="client-chosen id (echoed in acks and events)")

    acts_on: ClassVar[Target] = Target(role="engine")
    long_action: ClassVar[bool] = False

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        field = cls.model_fields.get("type")
        if field is not None and isinstance(field.default, str):
            REGISTRY.add(cls)

    def run(self, ctx: CommandContext) -> Any:
        raise CommandError(f"unsupported command type '{getattr(self, 'type', '?')}'", field="type")

    @classmethod
    def cancel(cls, session: Any, command_id: str) -> None:
        """Stop what command `command_id` of this type started (long actions); others go on."""


class BlockCommand(BaseCommand):
    """A command for a kind of block (`acts_on.blocks`): routed to the block named by `node`, else
    the one on `layer`, else the only block of that kind; when the program has none, the error says so."""

    node: str | None = Field(None, description="node id of the target block (optional)")
    layer: str | None = Field(None, description="layer whose chain holds the target block (optional)")

    def block(self, session: Any) -> Any:
        return find_block(session, self.acts_on.blocks, self.acts_on.what, self.node, self.layer)

    def args(self, *exclude: str) -> dict[str, Any]:
        """The command's own fields as block arguments (those set, without routing fields)."""
        return self.model_dump(exclude={"type", "node", "layer", "id", *exclude}, exclude_none=True)

    def tell(self, ctx: CommandContext, block: Any, command: str, args: dict[str, Any]) -> Any:
        """Hand `command` to `block`, tagged with this command's id (which its events will carry)."""
        return tell(ctx.session, block, command, {**args, "command_id": ctx.command_id})

    @classmethod
    def cancel(cls, session: Any, command_id: str) -> None:
        for block in blocks_of(session, cls.acts_on.blocks):
            try:
                session.engine.call(lambda b=block: cls.stop_owned(b, command_id))
            except Exception:  # a block that cannot stop: the command is reported cancelled regardless
                pass

    @classmethod
    def stop_owned(cls, block: Any, command_id: str) -> None:
        """Stop what `block` does for command `command_id` only (clock thread); long actions override."""
