"""`--foxglove PORT` (or `HOST:PORT`): a Foxglove WebSocket server, from the official foxglove SDK,
showing the robot live in Foxglove's 3D panel and its joint curves in the Plot panel.

Channels (ROS 2 message schemas `ros2msg` with CDR data, as rosbag2 records them, so one layout serves
a live server, an MCAP recording and a ROS 2 bridge alike):

- `/robot_description` (std_msgs/msg/String): the URDF text, mesh paths as `package://` URIs served by
  the asset handler (backend/foxglove/assets.py). Sent again whenever a client subscribes, so a client
  that joins late still gets it (the SDK has no latching; its Python client handle carries no sink id,
  so the repeat goes to every subscriber: the same text again, harmless).
- `/joint_states` (sensor_msgs/msg/JointState): the URDF's actuated joints, the positions the motors
  get (rad or m) and velocities (per s), stamped from the frame (backend/ros2/view.py).
- `/tf` (tf2_msgs/msg/TFMessage): every URDF joint's parent -> child link transform for the frame's joint
  values (backend/foxglove/transforms.py), after odom -> base link for a robot with spatial DoFs.
  Foxglove's 3D panel reads tf2_msgs/TFMessage as it reads its own FrameTransforms; this is the type the
  MCAP recordings and ROS 2 carry on `/tf`, so the same layout works on all three.
- `/nutty/events` (JSON): one message per frame event (`FrameView.events`).

Joint states and transforms go out at most `max_rate` times per second of frame time (default 100 Hz:
every frame at the usual engine rates, every k-th frame at higher rates); events go out on every frame
that has some. Message log times are the frames' stamps (ns since the Unix epoch).
"""

from __future__ import annotations

import logging
import time
from typing import Any

from backend.drivers.registry import DriverOption, host_port
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink
from backend.foxglove.assets import RobotAssets, robot_folder, urdf_for_viewer
from backend.foxglove.cdr_templates import JointStateTemplate
from backend.foxglove.transforms import LinkTransforms
from backend.ros2.view import FrameView

log = logging.getLogger(__name__)

DEFAULT_HOST = "127.0.0.1"
#: Joint states and transforms per second of frame time, at most (Hz).
DEFAULT_MAX_RATE = 100.0

EVENT_SCHEMA = {
    "type": "object",
    "title": "nutty.FrameEvent",
    "properties": {
        "type": {"type": "string"},
        "t": {"type": "number", "description": "frame time (s)"},
        "dof": {"type": "string"},
        "kind": {"type": "string"},
        "payload": {"type": "object"},
    },
}


def parse_address(text: str) -> tuple[str, int]:
    """`PORT` (on 127.0.0.1) or `HOST:PORT`; the port within 1..65535; an IPv6 host may be bracketed."""
    host, port = host_port(text, default_host=DEFAULT_HOST)
    return host.strip("[]") or DEFAULT_HOST, port


def _sdk() -> Any:
    try:
        import foxglove  # lazy: the optional extra, loaded only when a Foxglove server is asked for
    except ImportError as exc:
        raise ImportError(
            "the Foxglove server needs the 'foxglove' extra: pip install -e '.[foxglove]' (foxglove-sdk, rosbags)"
        ) from exc
    return foxglove


def _cdr() -> Any:
    from backend.ros2 import cdr  # lazy: rosbags (the 'mcap' extra); its ImportError names the extra

    return cdr


def _listener(on_subscribe: Any) -> Any:
    """A server listener calling `on_subscribe(topic)` when a client subscribes to a channel."""
    from foxglove.websocket import ServerListener  # lazy: the optional SDK (see _sdk)

    class _Listener(ServerListener):
        def on_subscribe(self, client: Any, channel: Any) -> None:
            on_subscribe(channel.topic)

    return _Listener()


class FoxgloveServer(Sink[AnimationFrame]):
    """A Foxglove WebSocket server publishing the robot's frames (see the module doc).

    `port` 0 picks a free port (`self.port` is the one bound). `max_rate` (Hz) bounds how often joint
    states and transforms are sent; nothing is built for a channel no client subscribes to. `stats()` adds
    `published` (frames whose joint states or transforms were sent), `publish_us` and
    `publish_cpu_us`: the mean wall and CPU time (µs) of one sent frame on the sink's thread (joint
    values, transforms, encoding, handing to the SDK); the wall time includes waiting for the interpreter
    lock other threads hold.
    """

    option = DriverOption(
        "foxglove",
        metavar="PORT",
        parse=parse_address,
        help="run a Foxglove WebSocket server on PORT or HOST:PORT (default host 127.0.0.1): joint states, "
        "transforms, the URDF and events for Foxglove's 3D and Plot panels (docs/foxglove/)",
    )

    def __init__(
        self,
        embodiment: Embodiment,
        host: str = DEFAULT_HOST,
        port: int = 8765,
        max_rate: float = DEFAULT_MAX_RATE,
        name: str = "nutty",
    ):
        if not 0 <= port < 65536:
            raise ValueError(f"foxglove port must be within 0..65535 (0: any free port), got {port}")
        if not max_rate > 0:
            raise ValueError(f"foxglove max_rate must be > 0 Hz, got {max_rate}")
        foxglove = _sdk()
        cdr = _cdr()
        self.emb = embodiment
        self.view = FrameView(embodiment)
        self.period = 1.0 / float(max_rate)
        self.transforms = (
            LinkTransforms(embodiment, self.view.base_link if self.view.has_base else None)
            if embodiment.urdf_path is not None
            else None
        )
        self.urdf = urdf_for_viewer(embodiment) if embodiment.urdf_path is not None else ""
        self.assets = RobotAssets(robot_folder(embodiment)) if embodiment.urdf_path is not None else None
        self.context = foxglove.Context()  # this server's own channels: several servers can coexist

        def ros_channel(topic: str, typename: str) -> Any:
            schema = foxglove.Schema(
                name=typename, encoding="ros2msg", data=cdr.message_definition(typename).encode()
            )
            return foxglove.Channel(topic, schema=schema, message_encoding="cdr", context=self.context)

        self.description = ros_channel("/robot_description", cdr.STRING)
        self.joint_states = ros_channel("/joint_states", cdr.JOINT_STATE)
        self.tf = ros_channel("/tf", cdr.TF_MESSAGE) if self.transforms is not None else None
        self.events = foxglove.Channel("/nutty/events", schema=EVENT_SCHEMA, context=self.context)
        self._urdf_cdr = cdr.string(self.urdf)
        self._joint_state = JointStateTemplate(self.view.joint_names)
        try:
            self.server = foxglove.start_server(
                name=f"{name} ({embodiment.name})",
                host=host,
                port=port,
                server_listener=_listener(self._on_subscribe),
                asset_handler=self.assets,
                context=self.context,
            )
        except RuntimeError as exc:  # the SDK's FoxgloveError: the port is taken, the host unknown
            raise OSError(f"the Foxglove server cannot listen on {host}:{port}: {exc}") from exc
        self.host, self.port = host, int(self.server.port)
        self._last_t: float | None = None  # the frame time of the last frame seen (s)
        self._last_sent: float | None = None
        self.published = 0
        self._publish_s = self._publish_cpu_s = 0.0
        log.info(
            "Foxglove server on ws://%s:%d (robot %s): open %s, then import docs/foxglove/nutty-layout.json",
            host,
            self.port,
            embodiment.name,
            self.server.app_url() or "Foxglove",
        )
        super().__init__(f"foxglove:{host}:{self.port}", max_queue=4)

    @classmethod
    def from_option(cls, embodiment: Embodiment, address: tuple[str, int]) -> FoxgloveServer:
        host, port = address
        return cls(embodiment, host, port)

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def _on_subscribe(self, topic: str) -> None:
        # on the SDK's thread, once the subscription is in place: this message reaches the new client
        if topic == "/robot_description":
            self.description.log(self._urdf_cdr, log_time=time.time_ns())

    def consume(self, frame: AnimationFrame) -> None:
        start, cpu = time.perf_counter(), time.thread_time()
        view = self.view
        if self._last_t is None or frame.t < self._last_t:
            # frame time 0 in wall time: stamps follow the engine's clock from here; again when frame
            # time goes back (a replay looping), so stamps keep going forward for the viewer
            view.epoch = time.time() - frame.t
            self._last_sent = None
        self._last_t = frame.t
        stamp = view.stamp(frame)
        ns = stamp.nanoseconds
        if frame.events and self.events.has_sinks():
            for event in view.events(frame):
                self.events.log(event, log_time=ns)
        last = self._last_sent
        if last is not None and frame.t < last + self.period - 1e-6:
            return  # decimated: within max_rate's period of the last frame sent
        # a channel with no subscribed client costs nothing: no message is built for it
        states = self.joint_states.has_sinks()
        tf = self.tf if self.tf is not None and self.tf.has_sinks() else None
        if not (states or tf is not None):
            return
        self._last_sent = frame.t
        q, qd = view.joints(frame)
        if states:
            self.joint_states.log(self._joint_state.message(stamp, q, qd), log_time=ns)
        if tf is not None and self.transforms is not None:
            tf.log(self.transforms.message(stamp, q, view.base(frame)), log_time=ns)
        self.published += 1
        self._publish_s += time.perf_counter() - start
        self._publish_cpu_s += time.thread_time() - cpu

    def close(self, timeout: float = 2.0) -> None:
        """Send what is queued, then stop the server (clients see the connection close)."""
        super().close(timeout)
        self.server.stop()

    def stats(self) -> dict[str, Any]:
        n = max(1, self.published)
        return {
            **super().stats(),
            "url": self.url,
            "published": self.published,
            "publish_us": round(self._publish_s / n * 1e6, 1),
            "publish_cpu_us": round(self._publish_cpu_s / n * 1e6, 1),
        }
