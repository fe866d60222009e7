"""Signal blocks: scalar math, low-frequency oscillators and the emotion mapper (valence/arousal ->
speed, amplitude, posture), for driving block parameters through their signal inputs."""

from __future__ import annotations

import math
import random
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import Field, model_validator

from backend.engine.blocks.base import BlockParams, Port, PortType, SignalBlock, drivable, soft_range
from backend.engine.blocks.quiet import QuietWhenIdle

# --------------------------------------------------------------------------------------------------
# Math
# --------------------------------------------------------------------------------------------------

MathOp = Literal[
    "add", "subtract", "multiply", "divide", "min", "max", "map_range", "clamp", "abs", "smoothstep"
]


class MathParams(BlockParams):
    op: MathOp = Field(
        default="add",
        description="operation on a (and b): add, subtract, multiply, divide, min, max, "
        "map_range, clamp, abs, smoothstep",
    )
    a: float = drivable(
        Field(default=0.0, description="value of a when its input is not connected"),
        "first operand (overrides parameter a)",
    )
    b: float = drivable(
        Field(default=0.0, description="value of b when its input is not connected"),
        "second operand (overrides parameter b)",
    )
    in_min: float = Field(
        default=0.0, description="map_range/smoothstep: input value mapped to out_min (lower edge)"
    )
    in_max: float = Field(
        default=1.0, description="map_range/smoothstep: input value mapped to out_max (upper edge)"
    )
    out_min: float = Field(default=0.0, description="map_range: output at in_min")
    out_max: float = Field(default=1.0, description="map_range: output at in_max")
    clamped: bool = Field(default=True, description="map_range: keep the output within [out_min, out_max]")
    min: float = Field(default=0.0, description="clamp: lower bound")
    max: float = Field(default=1.0, description="clamp: upper bound")

    @model_validator(mode="after")
    def _check(self) -> MathParams:
        if self.op in ("map_range", "smoothstep") and self.in_min == self.in_max:
            raise ValueError(f"{self.op}: in_min and in_max must differ (both are {self.in_min})")
        if self.op == "clamp" and self.min > self.max:
            raise ValueError(f"clamp: min ({self.min}) must not exceed max ({self.max})")
        return self


class Math(QuietWhenIdle, SignalBlock[MathParams]):
    """Scalar math on signals: arithmetic, min/max, map range, clamp, abs and smoothstep.

    Inputs `a` and `b` override the parameters of the same name. Unary operations (map_range, clamp,
    abs, smoothstep) act on `a`. Division by zero and any other non-finite result hold the last finite
    output, so a bad value upstream never reaches the robot.
    """

    type_name = "math"
    title = "Math"
    outputs = {"value": Port(PortType.float, "result")}

    @dataclass
    class State:
        last: float = 0.0  # the last finite output

    def compute(self, a: float, b: float) -> float:
        p = self.params
        op = p.op
        if op == "add":
            return a + b
        if op == "subtract":
            return a - b
        if op == "multiply":
            return a * b
        if op == "divide":
            return a / b if b != 0.0 else math.nan
        if op == "min":
            return min(a, b)
        if op == "max":
            return max(a, b)
        if op == "abs":
            return abs(a)
        if op == "clamp":
            return min(max(a, p.min), p.max)
        u = (a - p.in_min) / (p.in_max - p.in_min)
        if op == "smoothstep":
            u = min(max(u, 0.0), 1.0)
            return u * u * (3.0 - 2.0 * u)
        # map_range
        if p.clamped:
            u = min(max(u, 0.0), 1.0)
        return p.out_min + u * (p.out_max - p.out_min)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        self.quiet = True  # a function of its inputs and parameters; `last` only holds it (quiet.py)
        try:
            d = self.driven(inputs)
        except (OverflowError, TypeError, ValueError):
            d = None
        seen = self.__dict__.get("_computed")
        if d is not None and seen is not None and seen[0] is d and seen[1] is self.state:
            # The same resolved inputs as last tick (and so the same parameters) on the same state: the same
            # result, which left `last` as it is now if it was not finite.
            return {"value": self.state.last}
        try:
            value = math.nan if d is None else self.compute(d.a, d.b)
        except (OverflowError, TypeError, ValueError):
            value = math.nan
        if math.isfinite(value):
            self.state.last = float(value)
        self._computed = (d, self.state)
        return {"value": self.state.last}


# --------------------------------------------------------------------------------------------------
# LFO
# --------------------------------------------------------------------------------------------------

Waveform = Literal["sine", "triangle", "square", "saw", "random_smooth"]


def waveform(shape: str, u: float, knots: tuple[float, float] = (0.0, 0.0)) -> float:
    """Value in [-1, 1] of a waveform at phase u in [0, 1) (cycles). random_smooth eases between knots."""
    if shape == "sine":
        return math.sin(2.0 * math.pi * u)
    if shape == "triangle":  # starts at 0 going up, like the sine
        return 4.0 * u if u < 0.25 else (2.0 - 4.0 * u if u < 0.75 else 4.0 * u - 4.0)
    if shape == "square":
        return 1.0 if u < 0.5 else -1.0
    if shape == "saw":
        return 2.0 * u - 1.0
    k = 0.5 - 0.5 * math.cos(math.pi * u)  # random_smooth: cosine ease from one random knot to the next
    return knots[0] + k * (knots[1] - knots[0])


class LfoParams(BlockParams):
    waveform: Waveform = Field(
        default="sine", description="sine, triangle, square, saw or random_smooth (smooth noise)"
    )
    frequency: float = drivable(
        Field(
            default=0.5,
            ge=0.0,
            le=50.0,
            description="cycles per second (Hz)",
            json_schema_extra=soft_range(0, 5, 0.01),
        ),
        "overrides the frequency (Hz)",
        clamp="floor",
    )
    amplitude: float = drivable(
        Field(
            default=1.0,
            ge=0.0,
            le=100.0,
            description="peak deviation from the offset",
            json_schema_extra=soft_range(0, 1, 0.01),
        ),
        "overrides the amplitude",
    )
    offset: float = drivable(
        Field(
            default=0.0,
            ge=-100.0,
            le=100.0,
            description="centre value",
            json_schema_extra=soft_range(-1, 1, 0.01),
        ),
        "overrides the offset",
    )
    phase: float = Field(default=0.0, ge=0.0, le=1.0, description="phase at start (cycles, 0..1)")


class Lfo(SignalBlock[LfoParams]):
    """A low-frequency oscillator: `offset + amplitude * wave(phase)` as a signal.

    Waveforms sine, triangle, square, saw, or random_smooth (a new random level every cycle, eased
    in between). The phase is integrated, so changing the frequency live never jumps. Frequency and
    amplitude can be driven by signals (e.g. the emotion block's speed).
    """

    type_name = "lfo"
    title = "LFO"
    outputs = {"value": Port(PortType.float, "current value")}

    @dataclass
    class State:
        cycles: float  # phase (cycles)
        knots: tuple[float, float]  # random_smooth: the levels this cycle eases between
        rng: random.Random

    def reset(self) -> None:
        rng = random.Random(f"{self.ctx.seed}:{self.node_id}")
        knots = (rng.uniform(-1, 1), rng.uniform(-1, 1))
        self.state = self.State(cycles=float(self.params.phase), knots=knots, rng=rng)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        d, s = self.driven(inputs), self.state
        u = s.cycles % 1.0
        value = d.offset + d.amplitude * waveform(self.params.waveform, u, s.knots)
        advanced = s.cycles + d.frequency * dt
        for _ in range(min(int(advanced) - int(s.cycles), 2)):  # a new cycle: a new random knot
            s.knots = (s.knots[1], s.rng.uniform(-1, 1))
        s.cycles = advanced % 1.0
        if not math.isfinite(value):
            value = d.offset
        return {"value": value}


# --------------------------------------------------------------------------------------------------
# Emotion
# --------------------------------------------------------------------------------------------------

DEFAULT_POSTURES: dict[str, tuple[float, float]] = {
    "neutral": (0.0, 0.0),
    "happy": (0.7, 0.45),
    "surprised": (0.05, 0.9),
    "sad": (-0.7, -0.35),
    "sleepy": (0.1, -0.85),
}


class EmotionParams(BlockParams):
    valence: float = drivable(
        Field(
            default=0.0, ge=-1.0, le=1.0, description="unpleasant (-1) to pleasant (+1), when not connected"
        ),
        "valence -1..1 (overrides the parameter)",
        clamp="range",
    )
    arousal: float = drivable(
        Field(default=0.0, ge=-1.0, le=1.0, description="calm (-1) to excited (+1), when not connected"),
        "arousal -1..1 (overrides the parameter)",
        clamp="range",
    )
    speed_min: float = Field(
        default=0.6, gt=0.0, le=1.0, description="speed multiplier at arousal -1 (1 at arousal 0)"
    )
    speed_max: float = Field(default=1.6, ge=1.0, le=4.0, description="speed multiplier at arousal +1")
    amplitude_min: float = Field(
        default=0.5, ge=0.0, le=1.0, description="amplitude gain at arousal -1 (1 at arousal 0)"
    )
    amplitude_max: float = Field(default=1.5, ge=1.0, le=3.0, description="amplitude gain at arousal +1")
    valence_amplitude: float = Field(
        default=0.2,
        ge=0.0,
        le=1.0,
        description="extra amplitude gain at |valence| = 1 (strong feelings show)",
    )
    droop: float = Field(
        default=0.2, ge=0.0, le=1.0, description="posture offset at valence -1 (rad, + = head down)"
    )
    arousal_lift: float = Field(
        default=0.05, ge=0.0, le=0.5, description="posture lift at arousal +1 (rad, head up)"
    )
    postures: dict[str, tuple[float, float]] = Field(
        default_factory=lambda: dict(DEFAULT_POSTURES),
        description="posture name -> its (valence, arousal); the nearest one is output",
    )
    smoothing: float = Field(
        default=0.5,
        ge=0.0,
        le=10.0,
        description="time constant of the valence/arousal smoothing (s)",
        json_schema_extra=soft_range(0, 3, 0.01),
    )
    hysteresis: float = Field(
        default=0.05,
        ge=0.0,
        le=0.5,
        description="how much nearer a new posture must be before switching to it",
    )

    @model_validator(mode="after")
    def _check(self) -> EmotionParams:
        if not self.postures:
            raise ValueError("postures needs at least one name -> (valence, arousal) entry")
        return self


#: How near the smoothed valence or arousal (range -1..1) may come to its target before it lands on it.
#: The smoothing approaches its target for ever: left alone it stops moving only when its steps vanish
#: in floating point, ~19 s after a step at the default 0.5 s time constant, and until then the emotion
#: and every block it drives tick again each tick. Landing at 1e-6 moves an output by at most ~2e-7 rad
#: of posture or 1e-6 of a gain, far below a servo's resolution (~1.5e-3 rad), and settles in ~7 s.
SETTLE = 1e-6


def _landed(value: float, target: float) -> float:
    """`value`, or `target` itself once within SETTLE of it."""
    return float(target) if abs(target - value) <= SETTLE else value


def _same_floats(last: tuple[float, float], v: float, a: float) -> bool:
    """Whether (v, a) are the numbers `last` holds, a zero's sign included (-0.0 changes the offset's sign)."""
    lv, la = last
    return (
        lv == v
        and la == a
        and math.copysign(1.0, lv) == math.copysign(1.0, v)
        and math.copysign(1.0, la) == math.copysign(1.0, a)
    )


class Emotion(QuietWhenIdle, SignalBlock[EmotionParams]):
    """Maps valence and arousal to animation parameters: speed, amplitude, posture offset and posture.

    Arousal changes timing (speed multiplier from `speed_min` to `speed_max`) and, with the strength
    of the feeling |valence|, the amplitude of idle motion and gestures. Low valence droops the head
    (a positive pitch offset), high valence and arousal lift it. `posture` names the nearest of the
    emotional postures (happy, sad, surprised, sleepy, neutral). Inputs are smoothed, so outputs never
    jump when the emotion is set abruptly.
    """

    type_name = "emotion"
    title = "Emotion"
    outputs = {
        "speed": Port(PortType.float, "timing multiplier (1 = neutral)"),
        "amplitude": Port(PortType.float, "gain for idle motion and gestures (1 = neutral)"),
        "posture_offset": Port(PortType.float, "pitch offset for head/neck (rad, + = down)"),
        "posture": Port(PortType.string, "name of the nearest emotional posture"),
        "valence": Port(PortType.float, "smoothed valence"),
        "arousal": Port(PortType.float, "smoothed arousal"),
    }

    @dataclass
    class State:
        v: float = 0.0  # smoothed valence
        a: float = 0.0  # smoothed arousal
        posture: str = ""  # the posture output last
        primed: bool = False

    def _nearest(self, v: float, a: float) -> str:
        best, best_d, current = next(iter(self.params.postures)), math.inf, None
        for name, (pv, pa) in self.params.postures.items():
            d = math.hypot(v - pv, a - pa)
            if d < best_d:  # the first of equally near postures, as min() picks it
                best, best_d = name, d
            if name == self.state.posture:
                current = d
        if current is not None and best_d > current - self.params.hysteresis:
            return self.state.posture
        return best

    def outputs_for(self, v: float, a: float) -> dict[str, Any]:
        p = self.params
        speed = 1.0 + a * ((p.speed_max - 1.0) if a > 0 else (1.0 - p.speed_min))
        amp_a = 1.0 + a * ((p.amplitude_max - 1.0) if a > 0 else (1.0 - p.amplitude_min))
        amplitude = amp_a + p.valence_amplitude * abs(v)
        offset = -v * p.droop - max(a, 0.0) * p.arousal_lift
        return {"speed": speed, "amplitude": amplitude, "posture_offset": offset, "valence": v, "arousal": a}

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        p, d, s = self.params, self.driven(inputs), self.state
        self.quiet = False
        if not s.primed:
            s.v, s.a, s.primed = d.valence, d.arousal, True
        else:
            k = 1.0 if p.smoothing <= 0.0 else 1.0 - math.exp(-dt / p.smoothing)
            s.v = _landed(s.v + k * (d.valence - s.v), d.valence)
            s.a = _landed(s.a + k * (d.arousal - s.a), d.arousal)
        last = self.__dict__.get("_last_out")
        if last is not None and last[0] is s and last[1] is p and _same_floats(last[2], s.v, s.a):
            # Settled (the smoothing no longer moves, the most ticks): the same outputs, the same objects,
            # which lets the blocks they drive see at once that nothing changed. The smoothing's step
            # changed nothing: on the same inputs the next changes nothing either (quiet.py).
            self.quiet = True
            return last[3]
        key = (s.v, s.a, s.posture, p)  # equal numbers (-0.0 == 0.0 too) are equally near every posture
        seen = self.__dict__.get("_nearest_seen")
        if seen is None or seen[0] != key or seen[0][3] is not p:
            seen = self._nearest_seen = (key, self._nearest(s.v, s.a))
        s.posture = seen[1]
        out = self.outputs_for(s.v, s.a)
        out["posture"] = s.posture
        self._last_out = (s, p, (s.v, s.a), out)
        return out
