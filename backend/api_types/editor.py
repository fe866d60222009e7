"""The editor's REST answers: the block catalog and wiring rules, the robot, the running program,
the library, inputs and commands, the Pre-Viz, and the error body."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import ConfigDict, Field, RootModel

from backend.api_types.base import OpenShape, Shape, ts_ref
from backend.engine.blocks.base import Role
from backend.engine.blocks.ports import PortRule, PortType
from backend.engine.embodiment import Dimension, DofType
from backend.graph.issues import ValidationReport

# --- blocks and wiring -------------------------------------------------------------------------------


class PortSpec(Shape):
    type: PortType
    doc: str
    required: bool


class BlockEntry(Shape):
    """One block type of GET /api/blocks (and generated/blocks.json)."""

    type: str
    title: str
    category: str
    role: Role
    summary: str
    doc: str
    params_schema: dict[str, Any] = ts_ref("JsonSchema")
    inputs: dict[str, PortSpec] = Field(..., description="ports without parameters (see port_rules)")
    outputs: dict[str, PortSpec]
    dynamic_ports: bool
    bypassable: bool = Field(..., description="a program node of this type may carry `bypass: true`")
    port_rules: list[PortRule] = Field(
        ..., description="ports derived from the parameters, after the fixed ones"
    )


class BlockPorts(Shape):
    """POST /api/blocks/{type}/ports."""

    inputs: dict[str, PortSpec]
    outputs: dict[str, PortSpec]


class Category(Shape):
    name: str
    title: str


class EditorRules(Shape):
    """generated/rules.json: the wiring rule and the palette's categories in order."""

    port_types: list[PortType]
    accepts: dict[str, list[PortType]] = Field(..., description="input type -> output types it accepts")
    categories: list[Category]


# --- the robot ---------------------------------------------------------------------------------------


class JointFrame(Shape):
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


class DofInfo(Shape):
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
        default=None, description="the frame and axis of `joint` (a URDF joint's DoF)"
    )


class RobotDescription(Shape):
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


class RunningProgram(Shape):
    """GET /api/program."""

    program: dict[str, Any] | None = ts_ref("Program | null")
    report: ValidationReport | None
    level: int | None


class ProgramLoaded(Shape):
    """PUT /api/program."""

    report: ValidationReport
    kept: list[str] = Field(..., description="node ids that kept their state")


class ParamsApplied(Shape):
    """PATCH /api/program/nodes/{id}/params."""

    params: dict[str, Any]


class ExposedInputs(Shape):
    """GET /api/inputs."""

    values: dict[str, Any]
    declarations: list[dict[str, Any]] = ts_ref("ExposedInput[]")


class InputSet(Shape):
    """PUT /api/inputs/{name}."""

    name: str
    value: Any


class Saved(Shape):
    """PUT /api/programs/{name} (and clips, postures, subgraphs)."""

    saved: str
    warnings: list[str] = Field(
        default_factory=list,
        description="a valid posture or clip whose DoFs add up past a joint's range (only when some)",
    )


class Deleted(Shape):
    """DELETE /api/programs/{name} (and clips, postures, subgraphs)."""

    deleted: str


# Library documents as stored: each was checked against its format when it was saved (the PUT body's
# model) and is read back as written, so the answer is an open object rather than a second check.
class StoredProgram(RootModel[dict[str, Any]]):
    """GET /api/programs/{name}: a program document (nutty-program/1, see /api/schema/program)."""

    model_config = ConfigDict(json_schema_extra={"tsType": "Program"})


class StoredClip(RootModel[dict[str, Any]]):
    """GET /api/clips/{name}: a keyframed clip (nutty-clip/1)."""


class StoredPosture(RootModel[dict[str, Any]]):
    """GET /api/postures/{name}: a posture (nutty-posture/1: name, values by DoF, `builtin` for the
    postures embodiment.yaml declares)."""


class StoredSubgraph(RootModel[dict[str, Any]]):
    """GET /api/subgraphs/{name}: a subgraph definition (nodes, edges, exposed ports)."""


class JsonSchemaDocument(RootModel[dict[str, Any]]):
    """GET /api/schema/program and /api/schema/commands: a JSON Schema (draft 2020-12)."""

    model_config = ConfigDict(json_schema_extra={"tsType": "JsonSchema"})


CommandStatus = Literal["accepted", "queued", "started", "completed", "cancelled", "failed"]


class CommandAccepted(Shape):
    """POST /api/commands."""

    id: str
    status: CommandStatus
    result: Any


class DofCorrection(Shape):
    ticks: int = Field(..., description="ticks the safety net corrected this DoF during the action")
    max_correction: float = Field(..., description="largest |requested - delivered| (rad or m)")


class NetTally(Shape):
    """What the safety net did while an action ran."""

    corrected_ticks: int
    dofs: dict[str, DofCorrection]


class ActionOutcome(Shape):
    """What became of a long action (backend/action_watch.py)."""

    reached: bool | None = Field(
        default=None, description="look_at: the gaze arrived on target (false: it stopped at its limit)"
    )
    settled: bool | None = Field(
        ..., description="its motion ended (the robot caught up) before the event; null: cancelled or failed"
    )
    settle_time: float | None = Field(..., description="s from the block's end to the motion's end")
    safety: NetTally


class CommandEntry(Shape):
    """GET /api/commands/{id}: a command of the log."""

    id: str
    type: str = Field(..., description="the command's type, e.g. play_clip")
    status: CommandStatus
    created: float = Field(..., description="when it was accepted (Unix time, s)")
    result: Any = Field(..., description="what carrying it out returned; the error message if it failed")
    outcome: ActionOutcome | None = Field(
        default=None, description="a long action that has ended: whether its motion settled, what the net did"
    )


class CommandCancelled(Shape):
    """DELETE /api/commands/{id}: the command's status after the cancel (a finished one keeps its own)."""

    id: str
    status: CommandStatus


class PrevizInfo(Shape):
    """GET /api/previz."""

    url: str | None
    direct: str | None
    token_required: bool
    ghost: bool | None


class GhostSet(Shape):
    """PUT /api/previz/ghost."""

    ghost: bool


class ThemeSet(Shape):
    """PUT /api/previz/theme."""

    theme: Literal["light", "dark"]


class ErrorDetail(OpenShape):
    code: str
    message: str
    field: str | None = None
    id: str | None = None
    report: ValidationReport | None = Field(
        default=None, description="the program's report, when a program was refused"
    )


class ErrorBody(Shape):
    """Every 4xx/5xx response."""

    detail: ErrorDetail
