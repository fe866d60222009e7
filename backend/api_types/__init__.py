"""The shapes of what the API sends (REST responses, WebSocket messages, the block catalog, the
wiring rules), as pydantic models: one per response shape.

They describe docs/api-contract.md. Every route declares its model as its `response_model`
(backend/routes/*), so FastAPI checks each answer against it and /docs shows it; `nutty schema`
exports the same models (`api.schema.json`) and `npm run gen:types` turns them into
frontend/node_editor/generated/api.ts, so the editor declares none of them by hand.
tests/test_editor_types.py validates real responses of `create_app` against them strictly, and
tests/test_api_responses.py checks that every route has one. Program documents and exposed-input
declarations keep their own models (backend.graph.schema); here they are typed by reference.

A model here forbids keys it does not name (a key the route adds is drift, and a response that
drifts fails loudly instead of losing the key); the few open ones (`extra="allow"`) say why.

`editor`: the block catalog, the robot, the program, the library, inputs, commands, errors;
`server`: status, the trajectory-helper and the ghost, the tools for AIs; `sockets`: the WebSocket
messages and the cook-time profile. Import them from here.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel
from pydantic.json_schema import GenerateJsonSchema, models_json_schema

from backend.api_types.behaviours import (
    BehaviourIssue,
    BehaviourPlanned,
    BehaviourRendered,
    BehaviourSummary,
    SoundEntry,
    StoredBehaviour,
)
from backend.api_types.clip_editing import PreviewShown, PreviewState, TakeSaved, TakeStatus
from backend.api_types.editor import (
    BlockEntry,
    BlockPorts,
    Category,
    CommandAccepted,
    CommandCancelled,
    CommandEntry,
    CommandStatus,
    Deleted,
    DofInfo,
    EditorRules,
    ErrorBody,
    ErrorDetail,
    ExposedInputs,
    GhostSet,
    InputSet,
    JointFrame,
    JsonSchemaDocument,
    ParamsApplied,
    PortSpec,
    PrevizInfo,
    ProgramLoaded,
    RobotDescription,
    RunningProgram,
    Saved,
    StoredClip,
    StoredPosture,
    StoredProgram,
    StoredSubgraph,
    ThemeSet,
)
from backend.api_types.server import (
    AnthropicTool,
    ClientCounts,
    ClipChoice,
    ClockCpu,
    ClockPriority,
    FilteredTracks,
    LimitRange,
    OpenAIFunction,
    OpenAITool,
    PostureChoice,
    PrevizStatus,
    RobotStatusAnswer,
    SafetyStats,
    ServerStatus,
    SinkStats,
    TimingSummary,
    ToolAnswer,
    ToolCalled,
    ToolDefinition,
    ToolLibrary,
    Tools,
    ToolSet,
    TrackAnalysis,
    TrackLimits,
    TrackSummary,
)
from backend.api_types.sockets import (
    CommandAck,
    CommandEvent,
    ControlMessage,
    CookTime,
    LayerState,
    NodeCookTime,
    Profile,
    SignalRef,
    SocketError,
    Subscribed,
    Telemetry,
    TelemetryFrame,
    TelemetryMessage,
    TelemetrySubscribe,
)
from backend.engine.blend import BlendMode
from backend.engine.blocks.base import Role
from backend.engine.blocks.ports import PortRule, PortType
from backend.engine.embodiment import Dimension, DofType
from backend.graph.issues import Issue, ValidationReport

__all__ = [
    "API_MODELS",
    "AnthropicTool",
    "BehaviourIssue",
    "BehaviourPlanned",
    "BehaviourRendered",
    "BehaviourSummary",
    "BlendMode",
    "BlockEntry",
    "BlockPorts",
    "Category",
    "ClientCounts",
    "ClipChoice",
    "ClockCpu",
    "ClockPriority",
    "CommandAccepted",
    "CommandAck",
    "CommandCancelled",
    "CommandEntry",
    "CommandEvent",
    "CommandStatus",
    "ControlMessage",
    "CookTime",
    "Deleted",
    "Dimension",
    "DofInfo",
    "DofType",
    "EditorRules",
    "ErrorBody",
    "ErrorDetail",
    "ExposedInputs",
    "FilteredTracks",
    "GhostSet",
    "InputSet",
    "Issue",
    "JointFrame",
    "JsonSchemaDocument",
    "LayerState",
    "LimitRange",
    "NodeCookTime",
    "OpenAIFunction",
    "OpenAITool",
    "ParamsApplied",
    "PortRule",
    "PortSpec",
    "PortType",
    "PostureChoice",
    "PreviewShown",
    "PreviewState",
    "PrevizInfo",
    "PrevizStatus",
    "Profile",
    "ProgramLoaded",
    "RobotDescription",
    "RobotStatusAnswer",
    "Role",
    "RunningProgram",
    "SafetyStats",
    "Saved",
    "ServerStatus",
    "SignalRef",
    "SinkStats",
    "SocketError",
    "SoundEntry",
    "StoredBehaviour",
    "StoredClip",
    "StoredPosture",
    "StoredProgram",
    "StoredSubgraph",
    "Subscribed",
    "TakeSaved",
    "TakeStatus",
    "Telemetry",
    "TelemetryFrame",
    "TelemetryMessage",
    "TelemetrySubscribe",
    "ThemeSet",
    "TimingSummary",
    "ToolAnswer",
    "ToolCalled",
    "ToolDefinition",
    "ToolLibrary",
    "ToolSet",
    "Tools",
    "TrackAnalysis",
    "TrackLimits",
    "TrackSummary",
    "ValidationReport",
    "api_json_schema",
]

API_MODELS: tuple[type[BaseModel], ...] = (
    BlockEntry,
    BlockPorts,
    EditorRules,
    RobotDescription,
    RunningProgram,
    ValidationReport,
    Issue,
    ProgramLoaded,
    ParamsApplied,
    ExposedInputs,
    InputSet,
    Saved,
    Deleted,
    StoredProgram,
    StoredClip,
    StoredPosture,
    StoredSubgraph,
    JsonSchemaDocument,
    CommandAccepted,
    CommandEntry,
    CommandCancelled,
    PrevizInfo,
    GhostSet,
    ThemeSet,
    PreviewShown,
    PreviewState,
    TakeStatus,
    TakeSaved,
    SoundEntry,
    BehaviourIssue,
    BehaviourSummary,
    BehaviourPlanned,
    BehaviourRendered,
    StoredBehaviour,
    ServerStatus,
    TrackAnalysis,
    FilteredTracks,
    Tools,
    ToolAnswer,
    ErrorBody,
    TelemetrySubscribe,
    TelemetryMessage,
    ControlMessage,
    Profile,
)


class _WithoutFieldTitles(GenerateJsonSchema):
    """Field titles would become one TypeScript alias per field (`Name1`, `Id2`, …); models keep theirs."""

    def field_title_should_be_set(self, schema: Any) -> bool:
        return False


def api_json_schema() -> dict[str, Any]:
    """One JSON Schema naming every API model at the top (`properties`), definitions in `$defs`."""
    refs, doc = models_json_schema(
        [(m, "serialization") for m in API_MODELS], schema_generator=_WithoutFieldTitles
    )
    return {
        "title": "NuttyApi",
        "description": "Shapes of the Nutty API the editor reads (backend/api_types).",
        "type": "object",
        "properties": {m.__name__: refs[(m, "serialization")] for m in API_MODELS},
        "additionalProperties": False,
        **doc,
    }
