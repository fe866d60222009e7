"""Animation Frames from a safety net stepped outside the engine (the robot-side bridge, `nutty play`):
each step's output becomes one frame of one tick, with its velocity, acceleration and jerk as finite
differences of the delivered positions (zero on the first frame), and what the net changed."""

from __future__ import annotations

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame, FrameEvent
from backend.engine.safety import SafetyNet


class NetFrames:
    """The delivered state (`pos`, `vel`, `acc`: channels, per s, per s²) of one robot's frame stream,
    starting at rest and standing still."""

    def __init__(self, emb: Embodiment):
        n = emb.n_channels
        self.emb = emb
        self.pos, self.vel, self.acc = emb.rest.copy(), np.zeros(n), np.zeros(n)

    def frame(
        self,
        net: SafetyNet,
        out: np.ndarray,
        *,
        t: float,
        dt: float,
        seq: int,
        first: bool,
        events: list[FrameEvent],
        program: np.ndarray,
    ) -> AnimationFrame:
        """The frame of `out` (the net's output this step, dt s after the previous frame)."""
        vel = np.zeros_like(out) if first else (out - self.pos) / dt
        acc = np.zeros_like(out) if first else (vel - self.vel) / dt
        jerk = np.zeros_like(out) if first else (acc - self.acc) / dt
        self.pos, self.vel, self.acc = out, vel, acc
        return AnimationFrame(
            embodiment=self.emb.name,
            t=t,
            dt=dt,
            seq=seq,
            position=out,
            velocity=vel,
            acceleration=acc,
            jerk=jerk,
            events=list(events),
            corrected=net.corrected.copy() if net.corrected_any else None,
            program=np.array(program, dtype=float),
            joints=net.joint_out.copy(),
        )

    def at_rest(self) -> bool:
        """Whether the last frame is the rest pose exactly, standing still."""
        return bool(np.array_equal(self.pos, self.emb.rest)) and not np.any(self.vel) and not np.any(self.acc)
