"""Answers about the server and for other clients than the editor: status, the trajectory-helper and
the ghost (DCC tools), and the tools for AIs."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, RootModel

from backend.api_types.base import OpenShape, Shape
from backend.api_types.editor import CommandEntry, CommandStatus
from backend.api_types.physics import PhysicsReport

# --- how the server is doing ---------------------------------------------------------------------------


class TimingSummary(Shape):
    """Figures of a duration over the engine's recent ticks, in ms."""

    p50_ms: float
    p99_ms: float
    max_ms: float
    samples: int


class ClockPriority(Shape):
    switch_interval_ms: float = Field(
        ..., description="the interpreter's switch interval while the clock runs"
    )
    nice: int | None = Field(..., description="the clock thread's nice value (null: unchanged)")
    realtime: int | None = Field(..., description="its SCHED_FIFO priority (null: not real-time)")


class ClockCpu(Shape):
    """The clock's own CPU (`nutty serve --clock-cpu`)."""

    cpu: int = Field(..., description="the CPU the clock thread runs on")
    pinned: bool = Field(..., description="whether the clock thread runs on that CPU only")
    isolated: bool = Field(..., description="whether the server's other threads were moved off it")
    kept_awake: bool = Field(
        ..., description="whether the CPU is kept out of idle states (its PM QoS limit is n/a)"
    )
    note: str | None = Field(..., description="why something above did not happen (null: all did)")


class SafetyStats(OpenShape):
    """The engine's safety net: how often it corrected the program's output, and where. Open: the net
    may report more figures than these."""

    enabled: bool
    corrected_ticks: int
    corrections: dict[str, int] = Field(..., description="channel -> ticks corrected")
    correcting: list[str] = Field(..., description="channels corrected on the last tick")
    joint_corrections: dict[str, int] = Field(..., description="URDF joint -> ticks corrected")
    joints_correcting: list[str] = Field(..., description="joints corrected on the last tick")
    joints_governed: list[str] = Field(..., description="joints whose limits the net keeps")


class SinkStats(OpenShape):
    """One frame consumer of the engine (a driver, a socket, the Pre-Viz). Open: a driver adds its own
    figures (e.g. a simulated servo's tracking error)."""

    name: str
    offered: int
    delivered: int
    dropped: int
    errors: int
    last_error: str | None
    decimate: int


class ClientCounts(Shape):
    """Connected clients per socket."""

    control: int
    telemetry: int
    frames: int
    previz: int


class PrevizStatus(Shape):
    url: str
    direct: str | None
    token_required: bool
    frames_shown: int
    ghost: bool


class JointReading(Shape):
    """One joint as a driver that reads its motors sees it (servos, a physics preview)."""

    commanded: float = Field(..., description="the goal last sent (rad or m)")
    measured: float | None = Field(..., description="the joint's read position (rad or m; null: not read)")
    error: float | None = Field(..., description="commanded - measured (rad or m; null: not read)")
    effort: float | None = Field(
        ...,
        description="the load: a fraction of the motor's maximum torque (-1..1; null: unknown), for servos "
        "and the physics preview alike",
    )
    saturated: bool = Field(..., description="the motor is at its torque (or speed) limit")
    torque: float | None = Field(
        default=None, description="the motor's torque (N·m; N for a slide), where known: the physics preview"
    )


class ServoFault(Shape):
    joint: str
    servo: int = Field(..., description="the servo's bus id (PWM: its channel)")
    bus: str = Field(..., description="where the bus is (its port)")
    fault: Literal["overload", "overheat", "voltage", "encoder", "electrical", "no_answer"]
    t: float = Field(..., description="engine time of the fault (s)")


class BusStatus(OpenShape):
    driver: str = Field(..., description="the bus kind: dynamixel, feetech, pca9685, ...")
    port: str
    joints: list[str]
    writes: int = Field(..., description="goal transactions sent since the start")
    reads: int = Field(..., description="position reads completed since the start")
    read_hz: float = Field(..., description="position reads per second over the last second")
    missed_reads: int = Field(..., description="servo replies missing or corrupt since the start")


class HardwareStatus(OpenShape):
    file: str | None = Field(..., description="the hardware.yaml in use")
    state: Literal["starting", "running", "faulted", "parking", "stopped"]
    buses: list[BusStatus]
    faults: list[ServoFault] = Field(..., description="the servo faults since the start (the joints held)")
    torque_on_exit: bool


class SimContact(Shape):
    """Two links touching in the physics preview (not parent and child), or a link and a plane."""

    links: list[str] = Field(..., description="the two links, sorted ('floor' or 'table' for a plane)")
    t: float | None = Field(default=None, description="engine time the contact began (s)")
    depth: float = Field(..., description="the deepest penetration (m)")
    position: list[float] | None = Field(default=None, description="where, in the world frame (m)")


class SimulationStatus(OpenShape):
    engine: Literal["mujoco"]
    state: Literal["waiting", "running"]
    rate: float = Field(..., description="physics steps per second (Hz)")
    time: float = Field(..., description="simulated time (s)")
    steps: int
    gains: str = Field(..., description="where the motors' gains came from: a hardware.yaml, or 'urdf'")
    cpu_per_frame_ms: float = Field(..., description="median CPU time to follow one frame (ms)")
    cpu_share: float = Field(..., description="mean CPU time over the frame period: a share of one core")
    contacts: list[SimContact] = Field(..., description="the contacts now")
    recent_contacts: list[SimContact] = Field(..., description="the last contacts that began (oldest first)")
    contacts_total: int
    stop_on_contact: bool
    stops: int = Field(..., description="how often a contact stopped the program")
    floor_z: float = Field(..., description="the floor's height in the world frame (m)")
    table_z: float | None
    notes: list[str] = Field(..., description="what the model assumed where the URDF is silent")


class Overrun(Shape):
    """One overrun of the clock: a tick that ended more than a whole period after its deadline."""

    at: float = Field(..., description="when the tick ended (Unix time, s)")
    late_ms: float = Field(
        ..., description="how late the clock woke for it (ms); long with a short tick: a stalled wake"
    )
    tick_ms: float = Field(..., description="how long the tick ran (ms)")
    lost: int = Field(..., description="whole periods skipped after it (the clock re-anchors, never bursts)")


class ServerStatus(OpenShape):
    """GET /api/status: the engine's statistics (tick, APU level, safety net, sinks with drop counts),
    the clients and the Pre-Viz. Open: the engine's statistics are a diagnostic document that grows;
    the figures named here are the ones clients read."""

    rate: float = Field(..., description="ticks per second (Hz)")
    ticks: int
    t: float = Field(..., description="engine time (s)")
    level: int | None = Field(..., description="the running program's APU level (null: none runs)")
    max_level: int
    running: bool
    overruns: int
    lost_ticks: int
    recent_overruns: list[Overrun] = Field(..., description="the last overruns (at most 32, oldest first)")
    swaps: int
    safety: SafetyStats
    tick_cost: TimingSummary
    tick_cpu: TimingSummary
    period: TimingSummary
    jitter: TimingSummary
    started_at: float | None = Field(..., description="when the clock started (Unix time, s)")
    clock_priority: ClockPriority | None
    clock_cpu: ClockCpu | None = Field(
        default=None, description="the clock's own CPU (null: the clock runs where the OS puts it)"
    )
    sinks: list[SinkStats]
    fan_out: SinkStats | None = Field(
        default=None,
        description="the thread that hands each frame to every sink (null: no sink yet); its `dropped` "
        "are frames no sink got, its `errors` offers that failed",
    )
    clients: ClientCounts
    program: str | None = Field(..., description="the running program's name")
    previz: PrevizStatus | None
    joints: dict[str, JointReading] | None = Field(
        default=None,
        description="URDF joint -> commanded vs measured, from the drivers that read their motors "
        "(null: none does)",
    )
    hardware: HardwareStatus | None = Field(
        default=None, description="the real servos (`--hardware`; null: none configured)"
    )
    simulation: SimulationStatus | None = Field(
        default=None, description="the physics preview (`--sim mujoco`; null: not simulated)"
    )


# --- the trajectory-helper and the ghost -----------------------------------------------------------------


class LimitRange(Shape):
    """A run of samples of one DoF over a limit."""

    dof: str
    kind: Literal["velocity", "acceleration", "jerk", "position"] = Field(
        ...,
        description="the limit that breaks: for posted tracks each sample's class; for a clip position, "
        "else the lowest-order derivative over its limit",
    )
    start: int = Field(..., description="first sample (scene frame from the start frame) of the run")
    end: int = Field(..., description="last sample of the run (inclusive)")
    worst_ratio: float = Field(..., description="the worst sample's value over the `kind` limit")
    worst_sample: int
    t_start: float = Field(..., description="clip time of the run's first sample (s)")
    t_end: float = Field(..., description="clip time of the run's last sample (s)")
    limits: dict[str, float] = Field(..., description="every limit broken in the run -> its worst ratio")


class TrackLimits(Shape):
    """A DoF's limits: position (rad or m), velocity (/s), acceleration (/s²), jerk (/s³)."""

    min: float
    max: float
    velocity: float
    acceleration: float
    jerk: float


class TrackSummary(Shape):
    max_velocity: float
    max_acceleration: float
    max_jerk: float
    counts: dict[str, int] = Field(..., description="class (ok, velocity, ...) -> samples")
    limits: TrackLimits


class TrackAnalysis(Shape):
    """POST /api/analyze: where posted tracks break the robot's limits."""

    rate: float = Field(..., description="samples per second (Hz) of `samples` and the ranges' indices")
    engine_rate: float = Field(..., description="the rate the verdict was computed at (Hz)")
    samples: int
    ok: bool = Field(..., description="no sample breaks a limit")
    fit_scale: float | None = Field(
        default=None, description="clips: the uniform slow-down that fits every limit (null: none does)"
    )
    max_scale: float | None = Field(default=None, description="clips: the largest slow-down searched")
    suggestion: str | None = Field(default=None, description="clips: what would fit, in one line")
    ranges: list[LimitRange] = Field(..., description="by first sample, then DoF")
    dofs: dict[str, TrackSummary]
    colours: dict[str, str] = Field(..., description="class -> the editor's colour (#rrggbb)")
    physics: PhysicsReport | None = Field(
        default=None,
        description="with `physics: true`: the clip raw and filtered in MuJoCo (docs/simulation.md)",
    )


class FilteredTracks(Shape):
    """POST /api/filter: posted tracks through the stage-2 motion filter."""

    rate: float = Field(..., description="samples per second (Hz)")
    engine_rate: float = Field(..., description="the rate the filter ran at (Hz)")
    preset: str = Field(..., description="the preset used (W, A, ..., E), or `program` for its own filter")
    params: dict[str, Any] = Field(..., description="the filter's parameters (nmf_stage2's)")
    tracks: dict[str, list[float]] = Field(..., description="DoF name -> filtered values (rad or m)")


# --- tools for AIs -------------------------------------------------------------------------------------


class ToolDefinition(Shape):
    name: str
    description: str
    parameters: dict[str, Any] = Field(..., description="JSON Schema of the arguments (type: object)")
    command: str | None = Field(..., description="the command the tool sends (null: it only reads)")
    long_action: bool


class ClipChoice(Shape):
    name: str
    description: str
    duration: float | None = Field(..., description="the clip's length (s)")


class PostureChoice(Shape):
    name: str
    description: str


class BehaviourChoice(Shape):
    name: str
    description: str
    duration: float | None = Field(..., description="s with the default parameters")
    params: dict[str, Any] = Field(..., description="parameter name -> declaration (type, default, ...)")


class ToolLibrary(Shape):
    clips: list[ClipChoice]
    postures: list[PostureChoice]
    behaviours: list[BehaviourChoice] = Field(default_factory=list)
    sounds: list[str] = Field(default_factory=list)


class ToolSet(Shape):
    """GET /api/tools (format=plain): the tools of the running robot and program (nutty-tools/1)."""

    format: Literal["nutty-tools/1"]
    robot: str
    program: str | None
    revision: str = Field(..., description="changes exactly when a tool, an argument or a choice does")
    tools: list[ToolDefinition]
    library: ToolLibrary


class OpenAIFunction(Shape):
    name: str
    description: str
    parameters: dict[str, Any]


class OpenAIStrictFunction(OpenAIFunction):
    strict: Literal[True] = Field(..., description="OpenAI's strict function calling (strict=true)")


class OpenAITool(Shape):
    """One tool of GET /api/tools?format=openai (Chat Completions `tools`)."""

    type: Literal["function"]
    function: OpenAIStrictFunction | OpenAIFunction


class OpenAIFlatTool(OpenAIFunction):
    """One tool of format=openai&api=responses|realtime (the Responses / Realtime APIs' `tools`)."""

    type: Literal["function"]


class OpenAIFlatStrictTool(OpenAIStrictFunction):
    """One tool of format=openai&api=responses&strict=true."""

    type: Literal["function"]


class AnthropicTool(Shape):
    """One tool of GET /api/tools?format=anthropic (Messages API `tools`)."""

    name: str
    description: str
    input_schema: dict[str, Any]


class GeminiFunction(Shape):
    name: str
    description: str
    parameters: dict[str, Any] = Field(..., description="Gemini's Schema (an OpenAPI 3.0 subset)")


class GeminiTool(Shape):
    """The one entry of GET /api/tools?format=gemini (a Gemini `tools` entry)."""

    functionDeclarations: list[GeminiFunction]  # Gemini spells its fields in camelCase


class McpAnnotations(Shape):
    """MCP's tool annotations: hints for a client deciding how to treat a call."""

    title: str
    readOnlyHint: bool  # MCP spells its fields in camelCase
    destructiveHint: bool
    idempotentHint: bool
    openWorldHint: bool


class McpTool(Shape):
    """One tool of GET /api/tools?format=mcp (MCP's `tools/list`)."""

    name: str
    title: str
    description: str
    inputSchema: dict[str, Any]  # MCP spells its fields in camelCase
    annotations: McpAnnotations


class Tools(
    RootModel[
        ToolSet
        | list[OpenAITool]
        | list[OpenAIFlatStrictTool]
        | list[OpenAIFlatTool]
        | list[AnthropicTool]
        | list[GeminiTool]
        | list[McpTool]
    ]
):
    """GET /api/tools: the tools in the dialect asked for."""


class ToolCalled(Shape):
    """POST /api/tools/{name} for a tool that sends a command."""

    tool: str
    command: str = Field(..., description="the command's type")
    id: str = Field(..., description="the command's id (GET /api/commands/{id})")
    status: CommandStatus
    result: Any
    waited: bool = Field(..., description="the answer came when the action had ended (or timed out)")
    timed_out: bool
    request_id: str | None = Field(default=None, description="the caller's id for the call, when given")
    outcome: dict[str, Any] | None = Field(
        default=None, description="once the action has ended: whether its motion settled, what the net did"
    )
    replayed: bool = Field(
        default=False, description="a repeat of an earlier call with this request_id: it did not act again"
    )


class RobotStatusAnswer(OpenShape):
    """POST /api/tools/get_status: what the robot is doing (layers, clips, postures, gaze, mood,
    inputs, health). Open: the status document is written for a model to read, and grows with what
    the robot can do; `command` is the log entry of the command asked about."""

    tool: Literal["get_status"]
    command: CommandEntry | None
    timed_out: bool


class FrameAnswer(Shape):
    """POST /api/tools/get_frame: the last frame the robot got, compactly."""

    tool: Literal["get_frame"]
    t: float | None = Field(..., description="engine time of the frame (s); null before the first")
    seq: int | None
    dofs: dict[str, Any] = Field(..., description="DoF -> value: rad or m, an option name, or [r, g, b]")
    joints: dict[str, float] = Field(..., description="URDF joint -> the position its motor gets (rad or m)")
    corrected: list[str] = Field(..., description="channels the safety net corrected on this frame")


class ToolAnswer(RootModel[ToolCalled | FrameAnswer | RobotStatusAnswer]):
    """POST /api/tools/{name}."""
