"""The JSON bodies the API takes, as pydantic types, so OpenAPI (/docs) describes every one.

Two kinds:
- Small bodies validated by their model: one that does not fit is a 422 `invalid_body` naming the
  field (`InputValue`, `GhostToggle`, `PortsRequest`).
- Documents with a checker of their own that names the node, field or key at fault (programs,
  clips, postures, commands, parameter values): documented by their model but handed to the route
  as parsed (`SkipValidation`), so that checker, and its specific errors, stay the only judge.
Either way the body was JSON-safe before (backend.routes.json_body).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, RootModel, SkipValidation

from backend import control
from backend.behaviours.format import Behaviour
from backend.engine.clips import Clip
from backend.engine.library import Posture
from backend.graph.schema import Program, Subgraph


class InputValue(BaseModel):
    """Body of PUT /api/inputs/{name}."""

    value: Any = Field(
        ..., description="the new value, checked against the input's declaration (type, range, options)"
    )


class GhostToggle(BaseModel):
    """Body of PUT /api/previz/ghost."""

    visible: bool = Field(..., description="show (true) or hide the ghost, the stage-1 pose")


class ThemeChoice(BaseModel):
    """Body of PUT /api/previz/theme."""

    theme: Literal["light", "dark"] = Field(..., description="the editor's theme, which the Pre-Viz follows")


class PortsRequest(BaseModel):
    """Body of POST /api/blocks/{type}/ports."""

    params: SkipValidation[dict[str, Any]] = Field(
        default_factory=dict,
        description="the block's parameters, checked against its params schema (invalid_param)",
    )


class CommandBody(RootModel[control.Command]):
    """One command of the union (see GET /api/schema/commands)."""

    model_config = ConfigDict(title="Command")


# Checked by their own checkers (commands: control.parse_command; programs: the compiler's report;
# clips and postures: the library's validators; parameter values: the block's Params).
CommandDoc = SkipValidation[CommandBody]
ProgramDoc = SkipValidation[Program]
ClipDoc = SkipValidation[Clip]
PostureDoc = SkipValidation[Posture]
SubgraphDoc = SkipValidation[Subgraph]
ParamValues = SkipValidation[dict[str, Any]]
ToolArguments = SkipValidation[dict[str, Any]]  # checked by the tool (its enums) and its command's model
BehaviourDoc = SkipValidation[Behaviour]  # checked by backend.behaviours (every error on its item)


class BehaviourRequest(BaseModel):
    """Body of POST /api/behaviours/plan and /api/behaviours/render: a behaviour (the stored one named
    `behaviour`, or an unsaved `document`) and its parameters."""

    behaviour: str | None = Field(default=None, description="name of a stored behaviour")
    document: SkipValidation[dict[str, Any]] | None = Field(
        default=None, description="an unsaved behaviour (nutty-behaviour/1), checked item by item"
    )
    params: SkipValidation[dict[str, Any]] | None = Field(default=None, description="parameter name -> value")
    rate: float = Field(default=30.0, ge=5.0, le=100.0, description="render: frames per second sent back")
