"""Which block classes the compiled core compiles, and with which op (backend/engine/core/ops.py and
its siblings)."""

from __future__ import annotations

from backend.engine.blocks.base import Block
from backend.engine.blocks.blink import Blink
from backend.engine.blocks.clip_player import ClipPlayer
from backend.engine.blocks.core import GainOffset, Output, RestPose, SafetyLimiter, Sine
from backend.engine.blocks.display import Led
from backend.engine.blocks.gaze import Gaze
from backend.engine.blocks.idle import Breathe, Noise, WeightShift
from backend.engine.blocks.ik import InverseKinematics
from backend.engine.blocks.mixer import LayerMixer
from backend.engine.blocks.motion_filter import MotionFilterBlock, MotionFilterStage2
from backend.engine.blocks.signals import Emotion, Math
from backend.engine.core.chain_ops import GazeOp, IkOp
from backend.engine.core.clip_ops import ClipPlayerOp
from backend.engine.core.display_ops import LedOp
from backend.engine.core.idle_ops import BlinkOp, BreatheOp, NoiseOp, SineOp, WeightShiftOp
from backend.engine.core.ops import (
    FilterOp,
    GainOffsetOp,
    LimiterOp,
    MixerOp,
    Op,
    OutputOp,
    RestOp,
)
from backend.engine.core.signal_ops import EmotionOp, MathOp

#: The block classes the core compiles (exact classes: a subclass may tick differently) and their ops.
OPS: dict[type, type[Op]] = {
    RestPose: RestOp,
    Breathe: BreatheOp,
    Noise: NoiseOp,
    Sine: SineOp,
    WeightShift: WeightShiftOp,
    GainOffset: GainOffsetOp,
    MotionFilterBlock: FilterOp,
    MotionFilterStage2: FilterOp,
    SafetyLimiter: LimiterOp,
    Output: OutputOp,
    LayerMixer: MixerOp,
    InverseKinematics: IkOp,
    Gaze: GazeOp,
    Led: LedOp,
    Blink: BlinkOp,
    Emotion: EmotionOp,
    Math: MathOp,
    ClipPlayer: ClipPlayerOp,
}


def op_class(block: Block) -> type[Op] | None:
    """The op that compiles `block`, or None when it runs as Python (its type has none, it runs its
    numpy reference, it is bypassed, its tick was replaced on the instance (a probe, a test's fault),
    or it has nothing the kernel could run)."""
    cls = OPS.get(type(block))
    if cls is None or not block.ctx.compiled or "tick" in vars(block):
        return None
    if cls.needs_kernel and getattr(block, "_kernel", None) is None:
        return None
    if (
        cls is FilterOp and getattr(block, "filter", None) is None
    ):  # no channel selected: the frame passes as it is
        return None
    return cls
