"""The shapes of what the API sends the editor (REST responses, WebSocket messages, the block catalog,
the wiring rules), as pydantic models.

They describe docs/api-contract.md: `nutty schema` exports them (`api.schema.json`) and
`npm run gen:types` turns them into frontend/node_editor/generated/api.ts, so the editor declares
none of them by hand; tests/test_editor_types.py validates real responses of `create_app` against
them, so a route that changes its shape fails there. Program documents and exposed-input
declarations keep their own models (backend.graph.schema); here they are typed by reference.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, RootModel
from pydantic.json_schema import GenerateJsonSchema, models_json_schema

from backend.engine.blend import BlendMode
from backend.engine.blocks.base import Role
from backend.engine.blocks.ports import PortRule, PortType
from backend.engine.embodiment import Dimension, DofType
from backend.graph.issues import Issue, ValidationReport


class _Shape(BaseModel):
    """A response shape: a key the model does not name is drift, not an extension."""

    model_config = ConfigDict(extra="forbid")


class _OpenShape(BaseModel):
    """A message whose details vary (block events, error extras): known keys typed, others kept."""

    model_config = ConfigDict(extra="allow")


def _ts(ts_type: str) -> Any:
    """A field typed in TypeScript by a type of another generated module (see gen-types.mjs)."""
    return Field(..., json_schema_extra={"tsType": ts_type})


# --- blocks and wiring -------------------------------------------------------------------------------


class PortSpec(_Shape):
    type: PortType
    doc: str
    required: bool


class BlockEntry(_Shape):
    """One block type of GET /api/blocks (and generated/blocks.json)."""

    type: str
    title: str
    category: str
    role: Role
    summary: str
    doc: str
    params_schema: dict[str, Any] = _ts("JsonSchema")
    inputs: dict[str, PortSpec] = Field(..., description="ports without parameters (see port_rules)")
    outputs: dict[str, PortSpec]
    dynamic_ports: bool
    port_rules: list[PortRule] = Field(
        ..., description="ports derived from the parameters, after the fixed ones"
    )


class BlockPorts(_Shape):
    """POST /api/blocks/{type}/ports."""

    inputs: dict[str, PortSpec]
    outputs: dict[str, PortSpec]


class Category(_Shape):
    name: str
    title: str


class EditorRules(_Shape):
    """generated/rules.json: the wiring rule and the palette's categories in order."""

    port_types: list[PortType]
    accepts: dict[str, list[PortType]] = Field(..., description="input type -> output types it accepts")
    categories: list[Category]


# --- the robot ---------------------------------------------------------------------------------------


class JointFrame(_Shape):
    """A moving URDF joint with every joint at zero, in the root link's frame (backend/engine/joint_frames.py):
    what a DCC rig needs to put a bone on it."""

    joint: str
    type: str = Field(..., description="URDF joint type: revolute, continuous, prismatic, ...")
    parent_joint: str | None = Field(
        ..., description="the nearest moving joint above it (null: the root link)"
    )
    origin: list[float] = Field(..., min_length=3, max_length=3, description="joint frame origin (m)")
    rotation: list[list[float]] = Field(..., description="joint frame orientation, 3x3 rows")
    axis: list[float] = Field(..., min_length=3, max_length=3, description="unit joint axis (right-handed)")
    links: list[str] = Field(..., description="links that move rigidly with this joint")
    limits: list[float | None] = Field(
        ...,
        min_length=2,
        max_length=2,
        description="[lower, upper] joint position (rad or m); null: unbounded",
    )
    mimic: dict[str, Any] | None = Field(..., description="{joint, multiplier, offset} of a mimic joint")


class DofInfo(_Shape):
    name: str
    dimension: Dimension
    type: DofType
    min: float | None
    max: float | None
    velocity: float | None
    acceleration: float | None
    jerk: float | None
    rest: float | list[float] | None
    channels: list[int] = Field(
        ..., min_length=2, max_length=2, description="first and one-past-last channel in frame vectors"
    )
    joint: str | None = None
    drives: dict[str, float] | None = None
    axis: str | None = None
    group: str | None = None
    options: list[str] | None = None
    links: list[str] | None = None
    kind: str | None = None
    sounds: list[str] | None = None
    description: str | None = None
    joint_frame: JointFrame | None = Field(
        None, description="the frame and axis of `joint` (a URDF joint's DoF)"
    )


class RobotDescription(_Shape):
    """GET /api/robot."""

    name: str
    description: str
    dimensions: dict[str, int]
    dofs: list[DofInfo]
    channels: list[str]
    joints: list[str]
    groups: dict[str, list[str]]
    postures: list[str]
    joint_frames: dict[str, JointFrame] = Field(..., description="every moving URDF joint, parents first")
    root_links: list[str] = Field(..., description="links no joint moves (the base)")
    urdf: str


# --- the running program -----------------------------------------------------------------------------


class RunningProgram(_Shape):
    """GET /api/program."""

    program: dict[str, Any] | None = _ts("Program | null")
    report: ValidationReport | None
    level: int | None


class ProgramLoaded(_Shape):
    """PUT /api/program."""

    report: ValidationReport
    kept: list[str] = Field(..., description="node ids that kept their state")


class ParamsApplied(_Shape):
    """PATCH /api/program/nodes/{id}/params."""

    params: dict[str, Any]


class ExposedInputs(_Shape):
    """GET /api/inputs."""

    values: dict[str, Any]
    declarations: list[dict[str, Any]] = _ts("ExposedInput[]")


class InputSet(_Shape):
    """PUT /api/inputs/{name}."""

    name: str
    value: Any


class Saved(_Shape):
    """PUT /api/programs/{name} (and clips, postures)."""

    saved: str


CommandStatus = Literal["accepted", "started", "completed", "cancelled", "failed"]


class CommandAccepted(_Shape):
    """POST /api/commands."""

    id: str
    status: CommandStatus
    result: Any


class PrevizInfo(_Shape):
    """GET /api/previz."""

    url: str | None
    direct: str | None
    token_required: bool
    ghost: bool | None


class GhostSet(_Shape):
    """PUT /api/previz/ghost."""

    ghost: bool


class ErrorDetail(_OpenShape):
    code: str
    message: str
    field: str | None = None
    id: str | None = None
    report: ValidationReport | None = Field(
        None, description="the program's report, when a program was refused"
    )


class ErrorBody(_Shape):
    """Every 4xx/5xx response."""

    detail: ErrorDetail


# --- WebSockets --------------------------------------------------------------------------------------


class SignalRef(_Shape):
    node: str
    port: str


class TelemetrySubscribe(_Shape):
    """Sent to /ws/telemetry."""

    type: Literal["subscribe"]
    signals: list[SignalRef]
    frames: bool
    rate: float = Field(..., gt=0, le=60)


class Subscribed(_Shape):
    type: Literal["subscribed"]
    signals: int
    rate: float


class LayerState(_Shape):
    name: str
    mode: BlendMode
    weight: float
    fade: float
    effective: float
    active: bool


class CookTime(_Shape):
    """Cook time of one node (or of the whole APU tick) over the profile's window, in µs."""

    mean_us: float
    p50_us: float
    p99_us: float
    max_us: float


class NodeCookTime(CookTime):
    node: str
    type: str
    share: float = Field(..., description="this node's part of the mean APU tick (0..1)")


class Profile(_Shape):
    """GET /api/profile (and `profile` in /ws/telemetry messages, about once a second): how long each
    node of the running program takes per tick. One tick in `every` is timed; `samples` timed ticks
    (at most `window`) are summarised. Nodes come in tick order."""

    every: int
    window: int
    samples: int
    apu: CookTime
    nodes: list[NodeCookTime]


class TelemetryFrame(_Shape):
    position: dict[str, float]
    stage1: dict[str, float]
    classes: dict[str, int] = Field(
        ..., description="channel -> 1 velocity, 2 acceleration, 3 jerk (ok omitted)"
    )
    corrected: list[str]


class Telemetry(_Shape):
    type: Literal["telemetry"]
    t: float
    seq: int
    signals: dict[str, Any] | None = Field(
        None, description="'node.port' -> value (frames as {mask, values})"
    )
    frame: TelemetryFrame | None = None
    layers: dict[str, list[LayerState]] | None = None
    profile: Profile | None = None


class SocketError(_OpenShape):
    type: Literal["error"]
    code: str
    message: str
    field: str | None = None
    id: str | None = None


class CommandAck(_Shape):
    type: Literal["ack"]
    id: str
    status: CommandStatus
    result: Any


class CommandEvent(_OpenShape):
    """A command's or a block's event; details (node, clip, text, …) vary with the block."""

    type: Literal["event"]
    event: str
    id: str | None
    command: str | None = None
    node: str | None = None


class TelemetryMessage(
    RootModel[Annotated[Telemetry | Subscribed | SocketError, Field(discriminator="type")]]
):
    """What /ws/telemetry sends."""


class ControlMessage(
    RootModel[Annotated[CommandAck | CommandEvent | SocketError, Field(discriminator="type")]]
):
    """What /ws/control sends."""


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
    CommandAccepted,
    PrevizInfo,
    GhostSet,
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
        "description": "Shapes of the Nutty API the editor reads (backend/api_types.py).",
        "type": "object",
        "properties": {m.__name__: refs[(m, "serialization")] for m in API_MODELS},
        "additionalProperties": False,
        **doc,
    }
