"""What /ws/telemetry sends: a client's subscription and the messages built for it.

A client subscribes to node outputs (`{node, port}`), frames on or off, and a rate (Hz, at most
TELEMETRY_MAX_HZ); it gets the latest engine frame at that rate, decimated when it reads slowly.
"""

from __future__ import annotations

import asyncio
from typing import Any

import numpy as np

from backend.engine.frames import AnimationFrame, PartialFrame
from backend.hub import jsonable

TELEMETRY_MAX_HZ = 60.0
MAX_SIGNALS = 200


def signal_json(emb: Any, value: Any) -> Any:
    """A node output as JSON: frames as their set channels, arrays as lists."""
    if isinstance(value, PartialFrame):
        idx = np.flatnonzero(value.mask)
        return {"mask": int(idx.size), "values": {emb.channel_names[i]: round(float(value.values[i]), 5) for i in idx}}
    if isinstance(value, np.ndarray):
        return [float(x) for x in value.ravel()[:16]]
    if isinstance(value, (np.floating, np.integer)):
        return float(value)
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value if jsonable(value) else str(value)


def limit_classes(emb: Any, frame: AnimationFrame) -> dict[str, int]:
    """The trajectory-helper's class of this frame per continuous channel that breaks a limit
    (1 velocity, 2 acceleration, 3 jerk), from the frame's exact finite differences; ok omitted."""
    slack = 1.0 + 1e-9
    codes = np.zeros(emb.n_channels, dtype=np.int8)
    codes[np.abs(frame.velocity) > emb.vel_limit * slack] = 1
    codes[np.abs(frame.acceleration) > emb.acc_limit * slack] = 2
    codes[np.abs(frame.jerk) > emb.jerk_limit * slack] = 3
    codes[~emb.continuous_mask] = 0
    return {emb.channel_names[i]: int(codes[i]) for i in np.flatnonzero(codes)}


def frame_channels(emb: Any, values: np.ndarray) -> dict[str, float]:
    return {name: round(float(values[i]), 5) for i, name in enumerate(emb.channel_names)}


def frame_json(emb: Any, frame: AnimationFrame) -> dict[str, Any]:
    """A frame as telemetry shows it: positions, the stage-1 pose, limit classes, corrected channels."""
    return {"position": frame_channels(emb, frame.position),
            "stage1": frame_channels(emb, frame.stage1 if frame.stage1 is not None else frame.position),
            "classes": limit_classes(emb, frame),
            # channels the engine's safety net corrected on this frame: the program relies on the
            # net there (its own output breaks the robot's limits)
            "corrected": [emb.channel_names[i] for i in np.flatnonzero(frame.corrected)]
            if frame.corrected is not None else []}


class SubscriptionError(ValueError):
    """A subscribe message that cannot be followed; `field` names the culprit."""

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message)
        self.field = field


class Subscription:
    """What one /ws/telemetry client asked for; `changed` is set when it asks for something new."""

    def __init__(self) -> None:
        self.signals: list[dict[str, str]] = []
        self.frames = True
        self.rate = 30.0  # Hz
        self.changed = asyncio.Event()

    def update(self, data: Any) -> None:
        """Follow a subscribe message, or raise SubscriptionError (changing nothing)."""
        if not isinstance(data, dict) or data.get("type") != "subscribe":
            raise SubscriptionError("send {'type': 'subscribe', 'signals': [...], 'frames': bool, 'rate': Hz}")
        signals = data.get("signals", [])
        if not isinstance(signals, list) or not all(
                isinstance(s, dict) and isinstance(s.get("node"), str) and isinstance(s.get("port"), str)
                for s in signals):
            raise SubscriptionError("signals is a list of {node: str, port: str}", "signals")
        rate = data.get("rate", 30.0)
        if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 0 < rate <= TELEMETRY_MAX_HZ:
            raise SubscriptionError(f"rate must be within (0, {TELEMETRY_MAX_HZ:g}] Hz", "rate")
        frames = data.get("frames", True)
        if not isinstance(frames, bool):
            raise SubscriptionError("frames is true or false", "frames")
        self.signals = [{"node": s["node"], "port": s["port"]} for s in signals[:MAX_SIGNALS]]
        self.frames, self.rate = frames, float(rate)
        self.changed.set()

    def message(self, session: Any, frame: AnimationFrame) -> dict[str, Any]:
        """The telemetry message for `frame`: subscribed signals, the frame, the mixers' layers."""
        apu, emb = session.engine.apu, session.embodiment
        msg: dict[str, Any] = {"type": "telemetry", "t": frame.t, "seq": frame.seq}
        if apu is not None and self.signals:
            msg["signals"] = {f"{s['node']}.{s['port']}": signal_json(emb, apu.signal_value(s["node"], s["port"]))
                              for s in self.signals}
        if self.frames:
            msg["frame"] = frame_json(emb, frame)
        if apu is not None:
            msg["layers"] = {s.node_id: s.block.layer_states() for s in apu.steps if hasattr(s.block, "layer_states")}
        return msg
