"""CDR messages whose layout is fixed per robot, written per frame into a byte template.

A robot's JointState always names the same joints and its TFMessage the same frames, so only the stamp
and the numbers change from frame to frame. The bytes are laid out once (CDR: little-endian, each
primitive aligned to its size counted from the end of the 4-byte encapsulation header; a string is its
uint32 length including the NUL, the bytes, the NUL); a frame then writes its stamp and numbers into a
copy with numpy fancy-index assignments: no message objects, no per-joint Python loop. The bytes are the
ones rosbags writes for the same message (`tests/test_foxglove.py` compares them), about a third of
its time for a JointState.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np

from backend.ros2.view import Stamp

#: The CDR encapsulation header rosbag2 and Foxglove expect: plain CDR, little-endian.
CDR_LE = b"\x00\x01\x00\x00"


class _Body:
    """A CDR message body being laid out (offsets count from the end of the encapsulation header)."""

    def __init__(self) -> None:
        self.data = bytearray()

    def align(self, size: int) -> None:
        self.data.extend(b"\x00" * (-len(self.data) % size))

    def uint32(self, value: int) -> None:
        self.align(4)
        self.data.extend(struct.pack("<I", value))

    def string(self, text: str) -> None:
        raw = text.encode() + b"\x00"
        self.uint32(len(raw))
        self.data.extend(raw)

    def reserve(self, n_bytes: int, align: int) -> int:
        """Room for `n_bytes` zero bytes aligned to `align`; returns their offset in the message."""
        self.align(align)
        at = len(self.data)
        self.data.extend(bytes(n_bytes))
        return len(CDR_LE) + at

    def template(self) -> np.ndarray:
        return np.frombuffer(CDR_LE + bytes(self.data), dtype=np.uint8).copy()


def _indices(offsets: Sequence[int], n_bytes: int) -> np.ndarray:
    """(len(offsets), n_bytes) byte indices of blocks of `n_bytes` starting at `offsets`."""
    return np.asarray(offsets, dtype=np.intp).reshape(-1, 1) + np.arange(n_bytes)


def _stamp_bytes(stamp: Stamp) -> np.ndarray:
    return np.frombuffer(struct.pack("<iI", stamp.sec, stamp.nanosec), dtype=np.uint8)


class TfTemplate:
    """tf2_msgs/TFMessage with one TransformStamped per (parent, child) in `frames`, all stamped alike.
    `message(stamp, values)` takes (n, 7): translation (m) and rotation (x, y, z, w) per transform."""

    VALUES = 7

    def __init__(self, frames: Sequence[tuple[str, str]]):
        body = _Body()
        body.uint32(len(frames))
        stamps, values = [], []
        for parent, child in frames:  # once per robot, not per frame
            stamps.append(body.reserve(8, 4))  # builtin_interfaces/Time: int32 sec, uint32 nanosec
            body.string(parent)
            body.string(child)
            values.append(body.reserve(8 * self.VALUES, 8))
        self._template = body.template()
        self._stamp_at = _indices(stamps, 8)
        self._value_at = _indices(values, 8 * self.VALUES)

    def message(self, stamp: Stamp, values: np.ndarray) -> bytes:
        buf = self._template.copy()
        buf[self._stamp_at] = _stamp_bytes(stamp)
        buf[self._value_at] = np.ascontiguousarray(values, dtype="<f8").view(np.uint8)
        return buf.tobytes()


class JointStateTemplate:
    """sensor_msgs/JointState naming `names` (no frame id, no effort). `message(stamp, position,
    velocity)` takes the joints' positions (rad or m) and velocities (per s) in `names` order."""

    def __init__(self, names: Sequence[str]):
        n = len(names)
        body = _Body()
        self._stamp_at = _indices([body.reserve(8, 4)], 8)[0]
        body.string("")  # header.frame_id
        body.uint32(n)
        for name in names:  # once per robot, not per frame
            body.string(name)
        aligned = 8 if n else 1  # an empty float64 sequence is not padded (as rosbags writes it)
        body.uint32(n)
        position = body.reserve(8 * n, aligned)
        body.uint32(n)
        velocity = body.reserve(8 * n, aligned)
        body.uint32(0)  # effort: none
        self._template = body.template()
        self._position_at = np.arange(position, position + 8 * n)
        self._velocity_at = np.arange(velocity, velocity + 8 * n)
        self.size = n

    def message(self, stamp: Stamp, position: np.ndarray, velocity: np.ndarray) -> bytes:
        buf = self._template.copy()
        buf[self._stamp_at] = _stamp_bytes(stamp)
        buf[self._position_at] = np.ascontiguousarray(position, dtype="<f8").view(np.uint8)
        buf[self._velocity_at] = np.ascontiguousarray(velocity, dtype="<f8").view(np.uint8)
        return buf.tobytes()
