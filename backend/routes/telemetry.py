"""What /ws/telemetry sends: a client's subscription and the messages built for it.

A client subscribes to node outputs (`{node, port}`), frames on or off, and a rate (Hz, at most
TELEMETRY_MAX_HZ); it gets the latest engine frame at that rate, decimated when it reads slowly.
About once a second (PROFILE_PERIOD) a message also carries the program's per-node cook times
(`profile`, see backend/engine/profile.py).

Clients with the same subscription and rate share one message per period (`SharedTexts`): built and
encoded once, on the event loop, however many editors watch, so telemetry costs the server (and the
engine's clock, which needs the same interpreter lock) little.
"""

from __future__ import annotations

import asyncio
import math
import time
import weakref
from typing import Any

import numpy as np

from backend import security
from backend.drivers.readings import joint_readings
from backend.engine.blocks.mixer import LayerMixer
from backend.engine.embodiment import Embodiment
from backend.engine.frames import LIMIT_NAMES, AnimationFrame, PartialFrame
from backend.engine.safety import SafetyNet
from backend.errors import DomainError
from backend.hub import jsonable
from backend.session import EngineSession

TELEMETRY_MAX_HZ = 60.0
MAX_SIGNALS = 200
PROFILE_PERIOD = 1.0  # s between two messages with cook times, per client


def signal_json(emb: Embodiment, value: Any) -> Any:
    """A node output as JSON: frames as their set channels, arrays as lists."""
    if isinstance(value, PartialFrame):
        idx = np.asarray(value.mask).ravel().nonzero()[0]
        names = emb.channel_names
        return {
            "mask": int(idx.size),
            "values": dict(zip([names[i] for i in idx.tolist()], _rounded(np.asarray(value.values)[idx]))),
        }
    if isinstance(value, np.ndarray):
        return [float(x) for x in value.ravel()[:16]]
    if isinstance(value, (np.floating, np.integer)):
        return float(value)
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value if jsonable(value) else str(value)


def signals_json(emb: Embodiment, values: list[Any]) -> list[Any]:
    """`signal_json` of each value, the same JSON, with the frames among them (most of a program's
    outputs) selected and rounded together: a few numpy calls for all of them instead of several each
    (the interactive program's 42 signals ~320 -> ~136 µs, time the clock's interpreter lock waits)."""
    out: list[Any] = [None] * len(values)
    frames: list[int] = []
    for i, value in enumerate(values):
        kind = type(value)
        if kind is PartialFrame:
            frames.append(i)
        elif kind is bool or kind is int or (kind is float and math.isfinite(value)):
            out[i] = value  # what signal_json gives them, without its checks
        else:
            out[i] = signal_json(emb, value)
    if not frames:
        return out
    n = len(emb.channel_names)
    try:  # every frame over the embodiment's channels, flat one after the other
        flat = np.concatenate([values[i].values for i in frames]).astype(float, copy=False)
        set_ = np.concatenate([values[i].mask for i in frames]).astype(bool, copy=False)
        if flat.shape != (len(frames) * n,) or set_.shape != flat.shape:
            raise ValueError("frames over other channels")
    except ValueError:  # frames of other shapes: one at a time
        for i in frames:
            out[i] = signal_json(emb, values[i])
        return out
    where = np.flatnonzero(set_)  # each frame's set channels in channel order, frame after frame
    picked = flat[where].round(5).tolist()
    names = _channel_name_array(emb)[where % n].tolist()
    ends = set_.reshape(len(frames), n).sum(axis=1).cumsum().tolist()
    start = 0
    for i, end in zip(frames, ends):
        out[i] = {"mask": end - start, "values": dict(zip(names[start:end], picked[start:end]))}
        start = end
    return out


_NAME_ARRAYS: weakref.WeakKeyDictionary[Any, np.ndarray] = weakref.WeakKeyDictionary()


def _channel_name_array(emb: Embodiment) -> np.ndarray:
    """The embodiment's channel names as a numpy object array (for fancy indexing), made once each."""
    names = _NAME_ARRAYS.get(emb)
    if names is None or len(names) != len(emb.channel_names):
        names = _NAME_ARRAYS[emb] = np.array(list(emb.channel_names), dtype=object)
    return names


def limit_classes(emb: Embodiment, frame: AnimationFrame) -> dict[str, int]:
    """The trajectory-helper's class of this frame per continuous channel that breaks a limit
    (1 velocity, 2 acceleration, 3 jerk), from the frame's exact finite differences; ok omitted."""
    slack = 1.0 + 1e-9
    codes = np.zeros(emb.n_channels, dtype=np.int8)
    codes[np.abs(frame.velocity) > emb.vel_limit * slack] = 1
    codes[np.abs(frame.acceleration) > emb.acc_limit * slack] = 2
    codes[np.abs(frame.jerk) > emb.jerk_limit * slack] = 3
    codes[~emb.continuous_mask] = 0
    return {emb.channel_names[i]: int(codes[i]) for i in np.flatnonzero(codes)}


def _rounded(values: np.ndarray) -> list[float]:
    """Values rounded to 5 decimals for display, as Python floats (numpy's rounding: a whole vector at
    once; it can differ from `round(v, 5)` in the last digit of a value exactly halfway)."""
    return np.asarray(values, dtype=float).round(5).tolist()


def frame_channels(emb: Embodiment, values: np.ndarray) -> dict[str, float]:
    return dict(zip(emb.channel_names, _rounded(values)))


def frame_json(emb: Embodiment, frame: AnimationFrame, net: SafetyNet | None = None) -> dict[str, Any]:
    """A frame as telemetry shows it: positions, the stage-1 pose, limit classes, corrected channels,
    the joints the motors get, what the safety net changed (and, given the net, its totals)."""
    out: dict[str, Any] = {
        "position": frame_channels(emb, frame.position),
        "stage1": frame_channels(emb, frame.stage1 if frame.stage1 is not None else frame.position),
        "classes": limit_classes(emb, frame),
        # channels the engine's safety net corrected on this frame: the program relies on the
        # net there (its own output breaks the robot's limits)
        "corrected": [emb.channel_names[i] for i in np.flatnonzero(frame.corrected)]
        if frame.corrected is not None
        else [],
        "joints": dict(zip(emb.joint_names, _rounded(frame.joint_values(emb)))),
        "net": net_json(emb, frame),
    }
    if net is not None:
        out["net_totals"] = net_totals(net)
    return out


def _corrections(names: list[str], requested: np.ndarray, delivered: np.ndarray, kinds: np.ndarray) -> dict:
    """{name: {limit, requested, amount}} of the entries with a correction (kind > 0)."""
    idx = np.flatnonzero(kinds)
    asked = np.asarray(requested, dtype=float)[idx]
    amount = np.abs(asked - np.asarray(delivered, dtype=float)[idx])
    finite = np.isfinite(asked)  # a faulty block's NaN: the net held the last output
    return {
        names[i]: {"limit": LIMIT_NAMES[k], "requested": r if f else None, "amount": a if f else 0.0}
        for i, k, r, a, f in zip(
            idx.tolist(),
            kinds[idx].tolist(),
            np.where(finite, asked, 0.0).round(6).tolist(),
            np.where(finite, amount, 0.0).round(6).tolist(),
            finite.tolist(),
        )
    }


def net_json(emb: Embodiment, frame: AnimationFrame) -> dict[str, Any] | None:
    """What the safety net changed on `frame`, per channel and per joint: the limit it enforced, what
    was requested (before the net; joints: the request composed) and |requested - delivered|. None
    when the net passed the frame through."""
    net = frame.net
    if net is None:
        return None
    requested = frame.requested if frame.requested is not None else frame.position
    return {
        "channels": _corrections(emb.channel_names, requested, frame.position, net.channel_limits),
        "joints": _corrections(
            list(emb.joint_names), net.requested_joints, frame.joint_values(emb), net.joint_limits
        ),
    }


def net_totals(net: SafetyNet) -> dict[str, Any]:
    """The net's counts since the engine started: corrected ticks, and ticks per channel and per joint
    (read while the clock runs: a count may be one tick ahead of another)."""
    names, joints = net.emb.channel_names, net.joints.names
    return {
        "ticks": int(net.corrected_ticks),
        "channels": {names[i]: int(net.corrections[i]) for i in np.flatnonzero(net.corrections)},
        "joints": {joints[i]: int(net.joint_corrections[i]) for i in np.flatnonzero(net.joint_corrections)},
    }


class SubscriptionError(DomainError):
    """A subscribe message that cannot be followed (`invalid_message`); `field` names the culprit."""

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message, code="invalid_message", field=field)


class Subscription:
    """What one /ws/telemetry client asked for; `changed` is set when it asks for something new."""

    def __init__(self) -> None:
        self.signals: list[dict[str, str]] = []
        self.signal_keys: list[str] = []  # "node.port" of each signal, the message's keys
        self.frames = True
        self.rate = 30.0  # Hz
        self.changed = asyncio.Event()
        self.profile_at = 0.0  # monotonic time of the last message with cook times

    @property
    def key(self) -> tuple:
        """What makes two subscriptions' messages the same."""
        return tuple((s["node"], s["port"]) for s in self.signals), self.frames

    def update(self, data: Any) -> None:
        """Follow a subscribe message, or raise SubscriptionError (changing nothing)."""
        if not isinstance(data, dict) or data.get("type") != "subscribe":
            raise SubscriptionError(
                "send {'type': 'subscribe', 'signals': [...], 'frames': bool, 'rate': Hz}"
            )
        signals = data.get("signals", [])
        if not isinstance(signals, list) or not all(
            isinstance(s, dict) and isinstance(s.get("node"), str) and isinstance(s.get("port"), str)
            for s in signals
        ):
            raise SubscriptionError("signals is a list of {node: str, port: str}", "signals")
        rate = data.get("rate", 30.0)
        if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 0 < rate <= TELEMETRY_MAX_HZ:
            raise SubscriptionError(f"rate must be within (0, {TELEMETRY_MAX_HZ:g}] Hz", "rate")
        frames = data.get("frames", True)
        if not isinstance(frames, bool):
            raise SubscriptionError("frames is true or false", "frames")
        self.signals = [{"node": s["node"], "port": s["port"]} for s in signals[:MAX_SIGNALS]]
        self.signal_keys = [f"{s['node']}.{s['port']}" for s in self.signals]
        self.frames, self.rate = frames, float(rate)
        self.changed.set()

    def message(self, session: EngineSession, frame: AnimationFrame) -> dict[str, Any]:
        """The telemetry message for `frame`: subscribed signals, the frame, the mixers' layers."""
        apu, emb = session.engine.apu, session.embodiment
        msg: dict[str, Any] = {"type": "telemetry", "t": frame.t, "seq": frame.seq}
        if apu is not None and self.signals:
            with session.engine.tick_lock:  # between ticks: the compiled core writes its frames in place
                values = apu.signal_values([(s["node"], s["port"]) for s in self.signals])
            msg["signals"] = dict(zip(self.signal_keys, signals_json(emb, values)))
        if self.frames:
            msg["frame"] = frame_json(emb, frame, session.engine.safety)
            events = session.recent_events.recent(frame.t)
            if events:  # every event of the last seconds: the client plays each once (by seq, index)
                msg["events"] = events
            measured = joint_readings(session.engine.sinks)
            if measured:
                msg["measured"] = measured
        if apu is not None:
            msg["layers"] = {
                s.node_id: s.block.layer_states() for s in apu.steps if isinstance(s.block, LayerMixer)
            }
        return msg

    def text(self, session: EngineSession, frame: AnimationFrame, slot: Any = None) -> tuple[int, str]:
        """(seq, JSON text) of this client's message for `frame`: the same text as a client subscribed
        alike was sent in the same `slot` (any hashable: a period of a shared schedule; None: never
        shared), built once; with the cook times about once every PROFILE_PERIOD seconds."""
        shared = SharedTexts.of(session)
        now = time.monotonic()
        seq, text = shared.text(self, session, frame, slot)
        if now - self.profile_at >= PROFILE_PERIOD:
            profile = shared.profile(session, now)
            if profile is not None:
                self.profile_at = now
                text = f'{text[:-1]},"profile":{profile}}}'
        return seq, text


class SharedTexts:
    """The latest frame's telemetry texts of one session, by subscription (event loop only)."""

    _of: weakref.WeakKeyDictionary[Any, SharedTexts] = weakref.WeakKeyDictionary()

    def __init__(self) -> None:
        self.texts: dict[tuple, tuple[Any, int, str]] = {}  # subscription key -> (slot, seq, text)
        self._profile: tuple[float, Any, str] | None = None  # (when, apu, JSON text)

    @classmethod
    def of(cls, session: EngineSession) -> SharedTexts:
        shared = cls._of.get(session)
        if shared is None:
            shared = cls._of[session] = cls()
        return shared

    def text(
        self, sub: Subscription, session: EngineSession, frame: AnimationFrame, slot: Any
    ) -> tuple[int, str]:
        key = sub.key
        built = self.texts.get(key)
        if built is None or slot is None or built[0] != slot:
            built = self.texts[key] = (slot, frame.seq, security.dumps(sub.message(session, frame)))
        return built[1], built[2]

    def profile(self, session: EngineSession, now: float) -> str | None:
        """The running program's cook times as JSON (summarised at most once per PROFILE_PERIOD)."""
        apu = session.engine.apu
        if apu is None:
            return None
        cached = self._profile
        if cached is None or cached[1] is not apu or now - cached[0] >= PROFILE_PERIOD:
            cached = self._profile = (now, apu, security.dumps(apu.cook.summary()))
        return cached[2]
