"""What travels on Zenoh and how: JSON for commands, events, status and answers; msgpack for frames.

- JSON is read with the server's own rules (`backend.safe_json.loads`: finite numbers, valid UTF-8,
  bounded depth) and a size limit per message, and written with `dumps`, which never fails.
- A frame is `msgpack(AnimationFrame.to_dict(embodiment))`, byte for byte what `/ws/frames?format=msgpack`
  sends; the Zenoh attachment carries when the engine emitted it (`STAMP`: Unix time in s, little-endian
  float64), from which receivers measure latency (on one machine, or on machines with synchronised clocks),
  then the engine's session id (16 bytes, new at each start; the same id as its `session/<sid>` liveliness
  token), by which a bridge follows one running engine and nobody else.
- A robot-side bridge turns frame documents back into channel vectors (`FrameDoc`) for the robot it
  loaded from its own files (a description from the network would let anyone set the limits).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Any

import msgpack
import numpy as np

from backend.engine.dofs import DofType
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame, FrameEvent
from backend.safe_json import decode_message, dumps

MAX_FRAME = 1_000_000  # bytes per frame message
REPLY_LIMIT = 1_000_000  # bytes of one answer to a query (a program can be large)
STAMP = struct.Struct("<d")
SESSION_BYTES = 16


def payload_bytes(payload: Any) -> bytes:
    """The bytes of a Zenoh payload (a query may have none: b"")."""
    return b"" if payload is None else bytes(payload.to_bytes())


def encode_json(value: Any) -> bytes:
    return dumps(value).encode("utf-8")


def encode_frame(frame: AnimationFrame, embodiment: Embodiment) -> bytes:
    packed = msgpack.packb(frame.to_dict(embodiment))
    if packed is None:  # only with a stream to write to, which is never given here
        raise ValueError("msgpack returned no bytes")
    return packed


def decode_frame(payload: bytes) -> dict[str, Any]:
    """A frame document; ValueError when the message is not one (too large, not msgpack, not a map)."""
    if len(payload) > MAX_FRAME:
        raise ValueError(f"frame message over {MAX_FRAME} bytes")
    try:
        doc = msgpack.unpackb(payload, raw=False, strict_map_key=True)
    except (ValueError, TypeError, msgpack.UnpackException) as exc:  # msgpack's errors for bad input
        raise ValueError(f"not a msgpack frame: {type(exc).__name__}") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("dofs"), dict):
        raise ValueError("not a frame: expected a map with 'dofs'")
    return doc


def json_of(sample: Any) -> Any:
    """The JSON value a Zenoh sample (an answer, an event, a status) carries; ValueError if it carries none."""
    return decode_message(payload_bytes(sample.payload), max_bytes=REPLY_LIMIT)


def frame_of(sample: Any) -> tuple[dict[str, Any], float | None]:
    """(frame document, emission stamp or None) of a sample on a `frames` key; ValueError if not a frame."""
    return decode_frame(payload_bytes(sample.payload)), read_stamp(sample.attachment)


def stamp(t: float, session: bytes | None = None) -> bytes:
    """A frame's attachment: the emission time, then the engine's session id when given."""
    return STAMP.pack(t) + (session or b"")


def _attachment_bytes(attachment: Any) -> bytes:
    if attachment is None:
        return b""
    return bytes(attachment.to_bytes() if hasattr(attachment, "to_bytes") else attachment)


def read_stamp(attachment: Any) -> float | None:
    """The emission time carried by a frame's attachment, or None."""
    raw = _attachment_bytes(attachment)
    if len(raw) not in (STAMP.size, STAMP.size + SESSION_BYTES):
        return None
    (t,) = STAMP.unpack(raw[: STAMP.size])
    return t if math.isfinite(t) else None


def read_session(attachment: Any) -> str | None:
    """The engine session id (hex) a frame's attachment carries, or None."""
    raw = _attachment_bytes(attachment)
    return raw[STAMP.size :].hex() if len(raw) == STAMP.size + SESSION_BYTES else None


# --------------------------------------------------------------------------------------------------
# Frames, back to vectors
# --------------------------------------------------------------------------------------------------


@dataclass
class FrameDoc:
    """A received frame as the bridge uses it: seq, engine time and tick (s), positions (C,), events."""

    seq: int
    t: float
    dt: float
    position: np.ndarray
    events: list[FrameEvent]

    @classmethod
    def parse(cls, doc: dict[str, Any], emb: Embodiment, base: np.ndarray) -> FrameDoc:
        """Read a frame document for `emb`; channels it lacks keep `base`'s values. ValueError when the
        frame is another robot's or malformed (non-finite numbers included)."""
        if doc.get("embodiment") != emb.name:
            raise ValueError(f"frame of robot '{doc.get('embodiment')}', expected '{emb.name}'")
        seq, t, dt = doc.get("seq"), doc.get("t"), doc.get("dt")
        if not isinstance(seq, int) or not isinstance(t, (int, float)) or not isinstance(dt, (int, float)):
            raise ValueError("frame without a valid seq, t and dt")
        if not dt > 0:
            raise ValueError("frame without a valid seq, t and dt")
        pos = np.array(base, dtype=float)
        dofs = doc["dofs"]
        for d in emb.dofs:
            entry = dofs.get(d.name)
            if not isinstance(entry, dict):
                continue
            sl = d.channels
            if d.type is DofType.continuous and "position" in entry:
                pos[sl.start] = float(entry["position"])
            elif d.type is DofType.enum and "index" in entry:
                pos[sl.start] = float(entry["index"])
            elif d.type is DofType.colour and isinstance(entry.get("rgb"), list) and len(entry["rgb"]) == 3:
                pos[sl] = [float(x) for x in entry["rgb"]]
        if not np.all(np.isfinite(pos)) or not math.isfinite(t):
            raise ValueError("frame with non-finite values")
        events = []
        for e in doc.get("events") or []:
            if isinstance(e, dict) and isinstance(e.get("dof"), str) and isinstance(e.get("kind"), str):
                payload = e.get("payload")
                events.append(
                    FrameEvent(e["dof"], e["kind"], dict(payload) if isinstance(payload, dict) else {})
                )
        return cls(seq, float(t), float(dt), pos, events)
