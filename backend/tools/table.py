"""The tools an AI is offered: one per command class that declares an `ai_tool` (backend.control.ai),
in the command registry, plus the one tool that sends no command, get_status.

A command's declaration says which command the tool sends, when the running program can carry it out,
and which of its arguments take a value from the live robot, program or library. Everything else is
generated (backend.tools.build): the argument schemas come from the command models (backend.control),
the enums and their one-line descriptions from the robot's library and program (backend.tools.live).
A tool whose command the running program cannot carry out is not offered. A command added by an entry
point (a plugin's included) with an `ai_tool` is a tool with no edit here.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from backend.control import REGISTRY
from backend.control.ai import AiTool, Choices, always
from backend.tools.live import Live

MAX_WAIT = 120.0  # s: the longest a tool call may wait for its action to end
DEFAULT_WAIT = 30.0  # s


class WaitOptions(BaseModel):
    """How long a tool call waits for its action (every long-action tool, and get_status with an id)."""

    model_config = ConfigDict(extra="forbid")
    wait: bool = Field(
        default=False,
        description="answer only once the action has ended (completed or cancelled), "
        "or `timeout` has passed; otherwise answer at once with its id",
    )
    timeout: float = Field(
        default=DEFAULT_WAIT,
        gt=0.0,
        le=MAX_WAIT,
        description=f"longest wait (s, at most {MAX_WAIT:g}); the action goes on after it",
    )


class StatusArguments(WaitOptions):
    """get_status: the robot's activity, and one command's status when `id` is given."""

    id: str | None = Field(
        default=None,
        max_length=64,
        description="a command id from an earlier answer: report its "
        "status too (with `wait`: once it has ended)",
    )


class FrameArguments(BaseModel):
    """get_frame takes no arguments (a request id at most, which a read does not replay)."""

    model_config = ConfigDict(extra="forbid")


@dataclass(frozen=True)
class ToolSpec:
    """One tool: its name, the command it sends (`command`, whose fields are its arguments unless
    `fields` names another model; None for get_status), and the rest of its declaration (see
    `backend.control.ai.AiTool`: when it is offered, its enums, hidden fields, notes, schema shape,
    route and place in the list)."""

    name: str
    summary: str
    command: type | None
    available: Callable[[Live], bool]
    choices: Mapping[str, tuple[Choices, str]] = field(default_factory=dict)
    hide: tuple[str, ...] = ()
    fields: type | None = None
    layer_choice: bool = False  # offer `layer` even when the program has one target block
    notes: Callable[[Live], str] | None = None
    shape: Callable[[Live, dict[str, Any]], None] | None = None
    route: Callable[[dict[str, Any]], dict[str, Any]] | None = None
    order: float = 500.0
    idempotent: bool = False
    destructive: bool = False

    @property
    def model(self) -> type:
        return self.fields or self.command or StatusArguments

    @classmethod
    def of(cls, command: type, decl: AiTool) -> ToolSpec:
        """The tool a command class declares."""
        return cls(
            decl.name,
            decl.summary,
            command,
            decl.available,
            decl.choices,
            decl.hide,
            decl.fields,
            decl.layer_choice,
            decl.notes,
            decl.shape,
            decl.route,
            decl.order,
            decl.idempotent,
            decl.destructive,
        )


# The tools that send no command.
EXTRA_TOOLS: tuple[ToolSpec, ...] = (
    ToolSpec(
        "get_status",
        "What the robot is doing: what plays on each layer (clip, command id, progress), the "
        "posture move, where it looks, the mood and inputs, the layers' weights and the "
        "engine's health. With `id`: that command's status (and with `wait`, once it ends).",
        None,
        always,
        order=920,
        idempotent=True,
    ),
    ToolSpec(
        "get_frame",
        "The last Animation Frame the robot got, compactly: every DoF's value (rad or m; display "
        "DoFs by option or colour), the joints the motors get (rad) and the DoFs the safety net "
        "corrected on it. Where the robot is now, not what was asked.",
        None,
        always,
        fields=FrameArguments,
        order=925,
        idempotent=True,
    ),
)

_specs: tuple[int, tuple[ToolSpec, ...]] | None = None  # (registry generation, the tools)


def tool_specs() -> tuple[ToolSpec, ...]:
    """Every declared tool, in order (`AiTool.order`, then command-registry order): one per registered
    command with an `ai_tool`, and EXTRA_TOOLS. Rebuilt when the registry changes."""
    global _specs
    if _specs is None or _specs[0] != REGISTRY.generation:
        declared = [ToolSpec.of(c, c.ai_tool) for c in REGISTRY.classes() if c.ai_tool is not None]
        specs = sorted([*declared, *EXTRA_TOOLS], key=lambda spec: spec.order)  # stable: ties keep order
        names = [spec.name for spec in specs]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise TypeError(f"AI tool name(s) {twice} declared by more than one command")
        _specs = (REGISTRY.generation, tuple(specs))
    return _specs[1]
