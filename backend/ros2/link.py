"""An engine on ROS 2 (`nutty serve --ros2`): frames, events and status out; gaze targets, commands and
joint trajectories in.

Out (publishing runs off the clock thread: frame and event sinks, a status timer on the executor):
`/joint_states`, `/tf` (the base, when the robot has spatial DoFs) and an optional ros2_control
controller topic (backend/ros2/outputs.py); `<ns>/events` (std_msgs/String, JSON): every message the
Hub broadcasts to /ws/control clients (command events), each frame event, each trajectory event, and
the answer to each `<ns>/command`; `<ns>/status` (std_msgs/String, JSON, every second): what
`GET /api/status` says, plus this link's counters.

In (unless read-only):
- `<ns>/gaze_target` (geometry_msgs/PointStamped, m, in the robot's base frame: `header.frame_id`
  empty or the URDF's root link): sets the program's `gaze_target` input;
- `<ns>/command` (std_msgs/String, JSON): a command, run exactly as REST runs it (the same worker as
  the Zenoh link: backend/remote_commands.py); its ack or error goes out on `<ns>/events`;
- `<ns>/joint_trajectory` (trajectory_msgs/JointTrajectory): played into the puppet layer
  (backend/ros2/trajectory.py), so a planner drives through stage 2 and the safety net.
A refused message changes nothing and is answered on `<ns>/events` as `{"type": "error", "source":
<topic>, "code", "message", "field"?}`.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from typing import Any

from backend.control.errors import CommandError
from backend.control.targets import set_inputs
from backend.engine.runtime import Sink
from backend.logs import Throttle
from backend.remote_commands import CommandWorker, server_status
from backend.ros2.node import DEFAULT_NAMESPACE, RosNode, discovery, topic
from backend.ros2.outputs import ControllerOutput, FramePublisher, message_types
from backend.ros2.trajectory import DEFAULT_HOLD, TrajectoryError, TrajectoryPlayer, plan_trajectory
from backend.ros2.view import FrameView
from backend.safe_json import dumps

log = logging.getLogger(__name__)
STATUS_PERIOD = 1.0  # s between status messages
_refusals = Throttle(every=10.0)  # a misconfigured perception node refuses at 30 Hz: log once per 10 s


def text_publisher(node: Any, name: str, depth: int = 100) -> Callable[[str], None]:
    """A function publishing one text (JSON) as std_msgs/String on topic `name`."""
    from std_msgs.msg import String  # lazy: ROS message packages load with the link

    pub = node.create_publisher(String, name, depth)
    return lambda text: pub.publish(String(data=text))


def event_publisher(node: Any, namespace: str) -> Callable[[str], None]:
    """A function publishing one JSON text on `<namespace>/events`."""
    return text_publisher(node, topic(namespace, "events"))


class Ros2Link:
    """The serve-side link (module doc). `start(hub, closing)` makes the node and attaches to the engine;
    `close()` detaches and ends the node (idempotent)."""

    def __init__(
        self,
        namespace: str = DEFAULT_NAMESPACE,
        *,
        controller: ControllerOutput | None = None,
        read_only: bool = False,
        hold: float = DEFAULT_HOLD,
    ):
        self.namespace, self.controller, self.read_only, self.hold = namespace, controller, read_only, hold
        self.counts = {"gaze_targets": 0, "trajectories": 0, "refused": 0}
        self.hub: Any = None
        self.ros: RosNode | None = None
        self.frames: FramePublisher | None = None
        self.events: Sink[str] | None = None
        self.player: TrajectoryPlayer | None = None
        self.commands = CommandWorker("ros2", lambda _to, reply: self.publish_event(reply))
        self._closed = False
        self._lock = threading.Lock()

    # --- starting ---------------------------------------------------------------------------------
    def open(self) -> Ros2Link:
        """Join ROS 2 (before the clock starts: a missing package or a refusing RMW stops the server
        before the robot moves); Ros2Unavailable saying why."""
        self._join()
        return self

    def _join(self) -> RosNode:
        if self.ros is None:
            message_types()  # every message package there, or say which is missing
            self.ros = RosNode()
        return self.ros

    def start(self, hub: Any, closing: threading.Event | None = None) -> Ros2Link:
        self.hub = hub
        session = hub.session
        node = self._join().node
        self.view = FrameView(session.embodiment)
        self._status = text_publisher(node, topic(self.namespace, "status"), depth=10)
        # one thread publishes every event, whichever thread (the clock's too) produced it
        self.events = Sink("ros2-events", event_publisher(node, self.namespace), max_queue=256)
        hub.listeners.append(self.publish_event)
        self.frames = session.engine.add_sink(
            FramePublisher(
                session.embodiment,
                node,
                controller=self.controller,
                events=self.events.offer,
            )
        )
        node.create_timer(STATUS_PERIOD, self._publish_status)
        if not self.read_only:
            self._subscribe(node)
            self.commands.start(hub, closing)
        return self

    def _subscribe(self, node: Any) -> None:
        from geometry_msgs.msg import PointStamped  # lazy: ROS message packages load with the link
        from std_msgs.msg import String  # lazy: as above
        from trajectory_msgs.msg import JointTrajectory  # lazy: as above

        engine = self.hub.session.engine
        self.player = TrajectoryPlayer(engine, self.publish_event, hold=self.hold)
        engine.add_tick_hook(self._tick)
        node.create_subscription(PointStamped, topic(self.namespace, "gaze_target"), self._on_gaze, 10)
        node.create_subscription(String, topic(self.namespace, "command"), self._on_command, 100)
        node.create_subscription(
            JointTrajectory, topic(self.namespace, "joint_trajectory"), self._on_trajectory, 10
        )

    def _tick(self, t: float) -> None:
        player = self.player
        if player is not None and not self._closed:
            player.tick(t)

    # --- out --------------------------------------------------------------------------------------
    def publish_event(self, message: dict[str, Any]) -> None:
        """Queue one JSON event for `<ns>/events` (any thread, the clock's included)."""
        if self.events is not None:
            self.events.offer(dumps(message))

    def status(self) -> dict[str, Any]:
        stats = server_status(self.hub)
        stats["ros2"] = {
            **discovery(),
            "namespace": self.namespace,
            "read_only": self.read_only,
            "published": self.frames.published if self.frames is not None else 0,
            "dropped": self.frames.dropped if self.frames is not None else 0,
            **self.counts,
            **self.commands.counts,
        }
        return stats

    def _publish_status(self) -> None:
        try:
            self._status(dumps(self.status()))
        except Exception:  # closing: the next period tries again, or never comes
            log.debug("ROS 2: publishing the status failed", exc_info=True)

    def refuse(self, source: str, code: str, message: str, field: str | None = None) -> None:
        """Answer a refused message on `<ns>/events` (and log it, throttled)."""
        self.counts["refused"] += 1
        reply = {"type": "error", "source": source, "code": code, "message": message}
        if field:
            reply["field"] = field
        self.publish_event(reply)
        skipped = _refusals.due(source)
        if skipped is not None:
            log.warning("ROS 2: %s refused: %s (%d more not logged)", source, message, skipped)

    # --- in ---------------------------------------------------------------------------------------
    def _on_gaze(self, msg: Any) -> None:
        source = topic(self.namespace, "gaze_target")
        frame_id = msg.header.frame_id.lstrip("/")
        if frame_id not in ("", self.view.base_link):
            self.refuse(
                source,
                "wrong_frame",
                f"the gaze target is in frame '{frame_id}'; send it in the robot's base frame "
                f"'{self.view.base_link}' (transform it first, e.g. with tf2)",
                "header.frame_id",
            )
            return
        point = [msg.point.x, msg.point.y, msg.point.z]
        if not all(math.isfinite(v) for v in point):
            self.refuse(source, "invalid_input", "the gaze target must be finite (m)", "point")
            return
        try:
            set_inputs(self.hub.session, {"gaze_target": point})
        except CommandError as exc:
            self.refuse(source, exc.code, str(exc), exc.field)
            return
        self.counts["gaze_targets"] += 1

    def _on_command(self, msg: Any) -> None:
        self.commands.submit(msg.data.encode("utf-8"))

    def _on_trajectory(self, msg: Any) -> None:
        source = topic(self.namespace, "joint_trajectory")
        player = self.player
        if player is None:
            return
        if not msg.points:
            player.stop()
            return
        velocities = [p.velocities for p in msg.points]
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        started = self.hub.session.engine.started_at
        try:
            traj = plan_trajectory(
                self.hub.session.embodiment,
                list(msg.joint_names),
                [p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in msg.points],
                [list(p.positions) for p in msg.points],
                velocities if all(len(v) for v in velocities) else None,
                start=stamp - started if stamp > 0 and started else None,
            )
        except TrajectoryError as exc:
            self.refuse(source, "invalid_trajectory", str(exc), exc.field)
            return
        if player.puppet_block() is None:
            self.refuse(
                source, "no_target", "the running program has no puppet block to play a trajectory into"
            )
            return
        self.counts["trajectories"] += 1
        player.submit(traj)

    # --- leaving ----------------------------------------------------------------------------------
    def close(self) -> None:
        """Detach from the engine and the Hub, stop the worker, end the node (idempotent)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        hub = self.hub
        if hub is not None and self.publish_event in hub.listeners:
            hub.listeners.remove(self.publish_event)
        if self.frames is not None and hub is not None:
            hub.session.engine.remove_sink(self.frames)
        self.commands.stop()
        if self.events is not None:
            self.events.close(1.0)
        if self.ros is not None:
            self.ros.close()
