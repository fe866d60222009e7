"""A recorder that writes frames to an MCAP file as rosbag2 writes one (`--record FILE.mcap`).

Profile `ros2`, schemas `ros2msg` (backend/ros2/cdr.py), messages CDR, each channel's
`offered_qos_profiles` in rosbag2's YAML form, so `ros2 bag play`, Foxglove and rosbags read it. Topics:

- `/robot_description` (std_msgs/String): the URDF text, the first message, latched (transient local);
- `/joint_states` (sensor_msgs/JointState): the joints the motors get, every frame;
- `/tf` (tf2_msgs/TFMessage): odom -> base link, every frame of a robot with spatial DoFs;
- `/nutty/events` (std_msgs/String): one JSON object per frame event;
- `/nutty/channels` (std_msgs/Float64MultiArray): every channel, one dimension per channel labelled
  with its name: what `nutty play` rebuilds frames from (displays, LEDs and symbolic DoFs included).

A message's log and publish times are its frame's stamp: `epoch + frame.t` (ns since the Unix epoch),
`epoch` being the engine's start wall time when the caller knows it. A `nutty` metadata record names
the robot, its rate and the channels. The file is chunked (zstd), with its index and summary on close.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink

try:
    from mcap.writer import CompressionType, Writer

    from backend.ros2 import cdr
    from backend.ros2.view import FrameView
except ImportError as exc:  # the optional extra: say how to get it
    raise ImportError(
        "MCAP recording needs the 'mcap' extra: pip install -e '.[mcap]' (mcap, rosbags)"
    ) from exc

ROBOT_DESCRIPTION = "/robot_description"
JOINT_STATES = "/joint_states"
TF = "/tf"
EVENTS = "/nutty/events"
CHANNELS = "/nutty/channels"
#: Name of the MCAP metadata record that says which robot (and rate, channels) a recording is of.
METADATA = "nutty"
CHUNK_BYTES = 1 << 20

# rmw's "infinite" duration, as rosbag2 writes it for a publisher's default deadline and lifespan.
_INFINITE = {"sec": 9223372036, "nsec": 854775807}


def offered_qos(latched: bool) -> str:
    """`offered_qos_profiles` of one publisher as rosbag2 (Jazzy and later) writes it: a YAML list.
    Latched: transient local with depth 1 (a late subscriber still gets the URDF); otherwise volatile."""
    profile = {
        "history": "keep_last",
        "depth": 1 if latched else 10,
        "reliability": "reliable",
        "durability": "transient_local" if latched else "volatile",
        "deadline": dict(_INFINITE),
        "lifespan": dict(_INFINITE),
        "liveliness": "automatic",
        "liveliness_lease_duration": dict(_INFINITE),
        "avoid_ros_namespace_conventions": False,
    }
    return yaml.safe_dump([profile], sort_keys=False).strip()


class ChannelsEncoder:
    """std_msgs/Float64MultiArray CDR of a channel vector labelled with the channel names.

    The layout (the labels) is the same on every frame, so its bytes are made once and each frame
    appends only its values: one `tobytes` per frame instead of a message object per channel."""

    def __init__(self, names: list[str]):
        self.n = len(names)
        template = cdr.float64_multi_array(np.zeros(self.n), labels=names)
        self._prefix = template[: len(template) - 8 * self.n]

    def encode(self, values: np.ndarray) -> bytes:
        """The message of `values` (C,), little-endian float64 as the encapsulation header says."""
        data = np.asarray(values, dtype="<f8")
        if data.shape != (self.n,):
            raise ValueError(f"values: expected {self.n} channels, got shape {data.shape}")
        return self._prefix + data.tobytes()


class McapRecorder(Sink[AnimationFrame]):
    """Records every frame to a rosbag2-compatible MCAP file on its own sink thread.

    `epoch` (Unix s): the wall time of frame time 0, the engine's start when the caller knows it;
    otherwise the recorder's start time less the first frame's time (the engine's start as seen from
    here: equal to the recorder's start when it was attached before the clock started). `frames`
    counts the frames written.
    """

    def __init__(
        self, embodiment: Embodiment, path: str | Path, epoch: float | None = None, decimate: int = 1
    ):
        self.emb = embodiment
        self.path = Path(path)
        self.view = FrameView(embodiment, 0.0 if epoch is None else epoch)
        self._epoch_given = epoch is not None
        self.started = time.time()
        self.frames = 0
        self.closed = False
        self._first_t: float | None = None
        self._last_t: float | None = None
        self._dt: float | None = None
        self._channels = ChannelsEncoder(list(embodiment.channel_names))
        self._fh = self.path.open("wb")
        self._writer = Writer(self._fh, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(profile="ros2", library="nutty")
        self._ids: dict[str, int] = {}
        self._seq: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        for topic, typename in (
            (ROBOT_DESCRIPTION, cdr.STRING),
            (JOINT_STATES, cdr.JOINT_STATE),
            (TF, cdr.TF_MESSAGE),
            (EVENTS, cdr.STRING),
            (CHANNELS, cdr.FLOAT64_MULTI_ARRAY),
        ):
            if topic == TF and not self.view.has_base:
                continue
            self._ids[topic] = self._channel(topic, typename)
        self._described = False
        super().__init__(f"recorder:{self.path.name}", max_queue=1024, decimate=decimate, batch=0.01)

    def _channel(self, topic: str, typename: str) -> int:
        schemas = self._schemas
        if typename not in schemas:
            schemas[typename] = self._writer.register_schema(
                name=cdr.schema_name(typename),
                encoding="ros2msg",
                data=cdr.message_definition(typename).encode(),
            )
        self._seq[topic] = 0
        return self._writer.register_channel(
            topic=topic,
            message_encoding="cdr",
            schema_id=schemas[typename],
            metadata={"offered_qos_profiles": offered_qos(latched=topic == ROBOT_DESCRIPTION)},
        )

    def _write(self, topic: str, ns: int, data: bytes) -> None:
        self._seq[topic] += 1
        self._writer.add_message(
            self._ids[topic], log_time=ns, data=data, publish_time=ns, sequence=self._seq[topic]
        )

    def _describe(self, ns: int) -> None:
        """The URDF on /robot_description, once, before any other message (at `ns` or earlier)."""
        if self._described:
            return
        self._described = True
        urdf = self.emb.urdf_path.read_text() if self.emb.urdf_path is not None else ""
        self._write(ROBOT_DESCRIPTION, ns, cdr.string(urdf))

    def consume(self, frame: AnimationFrame) -> None:
        if self._first_t is None:
            self._first_t = frame.t
            if not self._epoch_given:
                self.view.epoch = self.started - frame.t
        stamp = self.view.stamp(frame)
        ns = stamp.nanoseconds
        self._describe(min(ns, round(self.started * 1e9)))
        q, qd = self.view.joints(frame)
        self._write(JOINT_STATES, ns, cdr.joint_state(stamp, self.view.joint_names, q, qd))
        base = self.view.base(frame)
        if base is not None:
            self._write(TF, ns, cdr.tf_message(stamp, [base]))
        for event in self.view.events(frame):
            self._write(EVENTS, ns, cdr.string(json.dumps(event)))
        self._write(CHANNELS, ns, self._channels.encode(frame.position))
        self._dt, self._last_t = frame.dt, frame.t
        self.frames += 1

    def metadata(self) -> dict[str, str]:
        """The `nutty` metadata record: robot, rate (Hz), frames, channel names (JSON), epoch (Unix s)."""
        return {
            "embodiment": self.emb.name,
            "rate": f"{1.0 / self._dt:.17g}" if self._dt else "",
            "frames": str(self.frames),
            "channels": json.dumps(list(self.emb.channel_names)),
            "epoch": f"{self.view.epoch:.17g}",
        }

    def close(self, timeout: float = 2.0) -> None:
        """Write what is queued, then the metadata, index and summary; the file is complete after this."""
        super().close(timeout)
        if self.closed:
            return
        self.closed = True
        try:
            self._describe(round(self.started * 1e9))  # a recording without frames still has the robot
            self._writer.add_metadata(METADATA, self.metadata())
            self._writer.finish()
        finally:
            self._fh.close()

    def stats(self) -> dict[str, Any]:
        return {**super().stats(), "frames": self.frames, "path": str(self.path)}
