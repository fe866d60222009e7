"""The command base classes and their registry.

A command is one pydantic class: its `type` literal, its fields (validated at every entry point),
what it acts on (`acts_on`), whether it is a long action, `run`, and whether and how it is offered to
an AI (`ai_tool`, backend.control.ai). The registry holds the classes the `nutty.commands` entry points
name (backend.plugins; defining a class registers nothing); the union, `parse_command`, the JSON
Schema and `execute` are built from it (backend.control.dispatch), and so are the AI tools
(backend.tools).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field

from backend.control.ai import AiTool
from backend.control.errors import CommandError
from backend.control.session_view import CommandSession
from backend.control.targets import blocks_of, find_block, tell
from backend.engine.blocks.base import Block
from backend.plugins import load


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

    session: CommandSession
    command_id: str | None = None
    cancel: Callable[[str], dict[str, Any]] | None = None


def command_type(cls: Any) -> str | None:
    """The `type` a command class declares (its field's default), or None."""
    field = getattr(cls, "model_fields", {}).get("type")
    return field.default if field is not None and isinstance(field.default, str) else None


class CommandRegistry:
    """Command classes by `type`, in the order of the `nutty.commands` entry points (the order of the
    union), then any added since."""

    def __init__(self) -> None:
        self._classes: dict[str, type[BaseCommand]] = {}
        self.generation = 0  # bumped on every change, so what is built from the registry can be rebuilt

    def add(self, cls: type[BaseCommand]) -> None:
        """Register a command class (the plugin loader does, for each entry point; tests add their own)."""
        if not (isinstance(cls, type) and issubclass(cls, BaseCommand)):
            raise TypeError(f"{cls!r} is not a BaseCommand subclass")
        name = command_type(cls)
        if name is None:
            raise TypeError(f"{cls.__qualname__} declares no `type: Literal[...]` default")
        old = self._classes.get(name)
        if old is not None and old is not cls:
            raise TypeError(f"command type '{name}' is already {old.__module__}.{old.__qualname__}")
        if not (cls.ai_tool is None or isinstance(cls.ai_tool, AiTool)):
            raise TypeError(f"{cls.__qualname__}.ai_tool must be an AiTool or None")
        if cls.ai_tool is not None:
            other = next(
                (c for c in self._classes.values() if c.ai_tool and c.ai_tool.name == cls.ai_tool.name), None
            )
            if other is not None and other is not old:
                raise TypeError(f"AI tool '{cls.ai_tool.name}' is already {other.__qualname__}'s")
        self._classes[name] = cls
        self.generation += 1

    def reload(self) -> None:
        """Read the `nutty.commands` entry points again: exactly the classes they name (after installing
        a plugin package, in tests). On a PluginError the registry is left as it was."""
        found = CommandRegistry()
        load("nutty.commands", command_type, found.add)
        self._classes = found._classes
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
    """A command: a subclass with a `type: Literal["..."]` default, registered by a `nutty.commands`
    entry point of that name.

    `acts_on` declares the target; `long_action` commands are acked `started` and their block reports
    `started` and `completed`/`cancelled` itself (through the session's notes) unless `run` returns
    `{"done": True, ...}`; every other command is `completed` once `run` returns. `run` returns the
    JSON result of the ack, or raises CommandError naming the field. `ai_tool` offers it to AIs as a
    tool (None: not offered).
    """

    model_config = ConfigDict(extra="forbid")
    id: str | None = Field(
        default=None, max_length=64, description="client-chosen id (echoed in acks and events)"
    )

    acts_on: ClassVar[Target] = Target(role="engine")
    long_action: ClassVar[bool] = False
    ai_tool: ClassVar[AiTool | None] = None

    def run(self, ctx: CommandContext) -> Any:
        raise CommandError(f"unsupported command type '{getattr(self, 'type', '?')}'", field="type")

    @classmethod
    def cancel(cls, session: CommandSession, command_id: str) -> None:
        """Stop what command `command_id` of this type started (long actions); others go on."""


class BlockCommand(BaseCommand):
    """A command for a kind of block (`acts_on.blocks`): routed to the block named by `node`, else
    the one on `layer`, else the only block of that kind; when the program has none, the error says so."""

    node: str | None = Field(default=None, description="node id of the target block (optional)")
    layer: str | None = Field(default=None, description="layer whose chain holds the target block (optional)")

    def block(self, session: CommandSession) -> Any:
        return find_block(session, self.acts_on.blocks, self.acts_on.what, self.node, self.layer)

    def args(self, *exclude: str) -> dict[str, Any]:
        """The command's own fields as block arguments (those set, without routing fields)."""
        return self.model_dump(exclude={"type", "node", "layer", "id", *exclude}, exclude_none=True)

    def tell(self, ctx: CommandContext, block: Block, command: str, args: dict[str, Any]) -> Any:
        """Hand `command` to `block`, tagged with this command's id (which its events will carry)."""
        return tell(ctx.session, block, command, {**args, "command_id": ctx.command_id})

    @classmethod
    def cancel(cls, session: CommandSession, command_id: str) -> None:
        for block in blocks_of(session, cls.acts_on.blocks):
            # A block that cannot stop: the command is reported cancelled regardless.
            with contextlib.suppress(Exception):
                session.engine.call(lambda b=block: cls.stop_owned(b, command_id))

    @classmethod
    def stop_owned(cls, block: Block, command_id: str) -> None:
        """Stop what `block` does for command `command_id` only (clock thread); long actions override."""
