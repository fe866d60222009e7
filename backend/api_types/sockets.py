"""What the WebSockets send and take: telemetry (with the cook-time profile, also GET /api/profile)
and /ws/control's acks, events and errors."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, RootModel

from backend.api_types.base import OpenShape, Shape
from backend.api_types.editor import CommandStatus
from backend.api_types.server import JointReading
from backend.engine.blend import BlendMode

# --- WebSockets --------------------------------------------------------------------------------------


class SignalRef(Shape):
    node: str
    port: str


class TelemetrySubscribe(Shape):
    """Sent to /ws/telemetry."""

    type: Literal["subscribe"]
    signals: list[SignalRef]
    frames: bool
    rate: float = Field(..., gt=0, le=60)


class Subscribed(Shape):
    type: Literal["subscribed"]
    signals: int
    rate: float


class LayerState(Shape):
    name: str
    mode: BlendMode
    weight: float
    fade: float
    effective: float
    active: bool


class CookTime(Shape):
    """Cook time of one node (or of the whole APU tick) over the profile's window, in µs."""

    mean_us: float
    p50_us: float
    p99_us: float
    max_us: float


class NodeCookTime(CookTime):
    node: str
    type: str
    share: float = Field(..., description="this node's part of the mean APU tick (0..1)")


class Profile(Shape):
    """GET /api/profile (and `profile` in /ws/telemetry messages, about once a second): how long each
    node of the running program takes per tick. One tick in `every` is timed; `samples` timed ticks
    (at most `window`) are summarised. Nodes come in tick order."""

    every: int
    window: int
    samples: int
    apu: CookTime
    nodes: list[NodeCookTime]


class NetCorrection(Shape):
    """One correction of the engine's safety net on one frame, of a channel or a joint."""

    limit: Literal["velocity", "acceleration", "jerk", "position"] = Field(
        ..., description="the limit the correction enforced (the one the request would have broken most)"
    )
    requested: float | None = Field(
        ..., description="what was asked before the net (a joint: the request composed); null: not a number"
    )
    amount: float = Field(..., description="|requested - delivered| (rad or m)")


class NetFrame(Shape):
    """What the safety net changed on a frame: by channel, and by joint (joint space, what motors get)."""

    channels: dict[str, NetCorrection]
    joints: dict[str, NetCorrection]


class NetTotals(Shape):
    """The safety net's counts since the engine started (as `/api/status`'s `safety`)."""

    ticks: int = Field(..., description="ticks on which the net corrected something")
    channels: dict[str, int] = Field(..., description="channel -> ticks corrected (0 omitted)")
    joints: dict[str, int] = Field(..., description="joint -> ticks corrected by the joint stage (0 omitted)")


class TelemetryFrame(Shape):
    position: dict[str, float] = Field(..., description="channel -> delivered value (after the net)")
    stage1: dict[str, float]
    classes: dict[str, int] = Field(
        ..., description="channel -> 1 velocity, 2 acceleration, 3 jerk (ok omitted)"
    )
    corrected: list[str]
    joints: dict[str, float] = Field(
        default_factory=dict, description="actuated joint -> delivered value (what the motors get)"
    )
    net: NetFrame | None = Field(
        default=None,
        description="what the safety net changed on this frame (null: it passed the request through, "
        "so the request equals the delivered channels and joints)",
    )
    net_totals: NetTotals | None = None


class FrameEventEntry(Shape):
    """An event of a frame: speech, a sound (its payload has `url`, `t` and `duration` when it plays a
    file of the robot's sounds/), a one-shot display change."""

    seq: int = Field(..., description="the frame's sequence number")
    index: int = Field(..., description="the event's place among its frame's events")
    t: float = Field(..., description="the frame's time (s)")
    dof: str
    kind: str
    payload: dict[str, Any]


class Telemetry(Shape):
    type: Literal["telemetry"]
    t: float
    seq: int
    signals: dict[str, Any] | None = Field(
        default=None, description="'node.port' -> value (frames as {mask, values})"
    )
    frame: TelemetryFrame | None = None
    events: list[FrameEventEntry] | None = Field(
        default=None,
        description="the frames' events of the last 2 s (with frames on): speech, sounds (with `url`); "
        "several messages carry the same event, which `seq` and `index` identify",
    )
    layers: dict[str, list[LayerState]] | None = None
    profile: Profile | None = None
    measured: dict[str, JointReading] | None = Field(
        default=None,
        description="URDF joint -> commanded vs measured at the motors (with frames on, when a driver "
        "reads its motors: servos, a physics preview)",
    )


class SocketError(OpenShape):
    type: Literal["error"]
    code: str
    message: str
    field: str | None = None
    id: str | None = None


class CommandAck(Shape):
    type: Literal["ack"]
    id: str
    status: CommandStatus
    result: Any


class CommandEvent(OpenShape):
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
