"""Frames out to ROS 2, on a sink thread (never the clock's): `/joint_states`, the base on `/tf`, the
frames' events, and optionally a ros2_control controller's command topic.

- `/joint_states` (sensor_msgs/JointState): the URDF's actuated joints, the positions the motors get
  and their velocities, stamped from the frame (`FrameView.stamp`), every frame;
- `/tf` (tf2_msgs/TFMessage): odom -> base link, every frame, when the robot has spatial DoFs (the
  joints' own transforms are robot_state_publisher's job, from `/joint_states`);
- events (std_msgs/String, JSON): each frame event, on `<namespace>/events`;
- `controller`: `forward_position_controller` style (std_msgs/Float64MultiArray on
  `/<name>/commands`, the joints in a configured order) or `joint_trajectory_controller` style
  (trajectory_msgs/JointTrajectory on `/<name>/joint_trajectory`, one point per tick, due one tick
  ahead, with velocities).
"""

from __future__ import annotations

import array
import importlib
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink
from backend.ros2.node import Ros2Unavailable
from backend.ros2.view import FrameView
from backend.safe_json import dumps

log = logging.getLogger(__name__)

FORWARD, TRAJECTORY = "forward", "trajectory"
FRAME_QUEUE = 64  # frames the publisher may fall behind before the oldest is dropped (counted)


@dataclass(frozen=True)
class ControllerOutput:
    """A ros2_control controller to command: its name, its kind (FORWARD or TRAJECTORY) and the joint
    order of its `joints` parameter."""

    name: str
    kind: str
    joints: tuple[str, ...]

    @property
    def topic(self) -> str:
        return f"/{self.name}/commands" if self.kind == FORWARD else f"/{self.name}/joint_trajectory"

    @classmethod
    def parse(cls, name: str, joints: Sequence[str] | None, emb: Embodiment) -> ControllerOutput:
        """A controller from `--ros2-controller NAME` and `--ros2-joints a,b,c` (default: the URDF's
        actuated joints in order); ValueError naming what does not fit. A name with 'trajectory' in it
        is a joint_trajectory_controller, any other a forward command controller."""
        if not name or not all(c.isalnum() or c == "_" for c in name) or name[0].isdigit():
            raise ValueError(f"--ros2-controller {name!r}: a controller name is letters, digits and '_'")
        order = tuple(joints) if joints else tuple(emb.joint_names)
        unknown = [j for j in order if j not in emb.joint_names]
        if unknown:
            raise ValueError(
                f"--ros2-joints: robot '{emb.name}' has no actuated joint {', '.join(map(repr, unknown))} "
                f"(it has {', '.join(emb.joint_names)})"
            )
        if len(set(order)) != len(order):
            raise ValueError("--ros2-joints: a joint is named twice")
        return cls(name, TRAJECTORY if "trajectory" in name else FORWARD, order)


def message_types() -> dict[str, Any]:
    """The rclpy message classes the outputs use; Ros2Unavailable naming what is missing."""
    try:
        from builtin_interfaces.msg import Duration  # lazy: ROS message packages load with the link
        from sensor_msgs.msg import JointState  # lazy: as above
        from std_msgs.msg import Float64MultiArray, String  # lazy: as above
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # lazy: as above
    except ImportError as exc:
        raise Ros2Unavailable(
            f"a ROS 2 message package is missing ({exc}): pip install -e '.[ros2]'"
        ) from exc
    types: dict[str, Any] = {
        "Duration": Duration,
        "JointState": JointState,
        "Float64MultiArray": Float64MultiArray,
        "String": String,
        "JointTrajectory": JointTrajectory,
        "JointTrajectoryPoint": JointTrajectoryPoint,
    }
    from geometry_msgs.msg import TransformStamped  # lazy: as above

    types["TransformStamped"] = TransformStamped
    try:  # no wheel ships tf2_msgs: `python -m backend.ros2.interfaces build` makes it (by name: optional)
        types["TFMessage"] = importlib.import_module("tf2_msgs.msg").TFMessage
    except ImportError:
        types["TFMessage"] = None
    return types


def _doubles(values: np.ndarray) -> array.array:
    # array('d') is what rclpy stores for float64[]: handing it one skips a per-element check
    return array.array("d", np.ascontiguousarray(values, dtype=np.float64).tobytes())


class FramePublisher(Sink[Any]):  # offered frames, queued with the time they were made
    """Publishes each frame (module doc) from its own thread. `node` is an rclpy node; `events` a
    callable given each frame event's JSON text (the link's events publisher), or None."""

    def __init__(
        self,
        emb: Embodiment,
        node: Any,
        *,
        epoch: float = 0.0,
        controller: ControllerOutput | None = None,
        events: Callable[[str], None] | None = None,
        name: str = "ros2",
    ):
        self.view = FrameView(emb, epoch)
        self.types = types = message_types()
        self.controller = controller
        self.events = events
        self.published = 0
        self._joint_state = node.create_publisher(types["JointState"], "/joint_states", 10)
        self._js = types["JointState"]()
        self._js.name = list(self.view.joint_names)
        self.tf_missing = self.view.has_base and types["TFMessage"] is None
        if self.tf_missing:
            log.warning(
                "ROS 2: tf2_msgs is not installed, so the base's pose is not published on /tf "
                "(build it: python -m backend.ros2.interfaces build)"
            )
        self._tf = (
            node.create_publisher(types["TFMessage"], "/tf", 100)
            if self.view.has_base and types["TFMessage"] is not None
            else None
        )
        self._controller = self._controller_publisher(node, emb) if controller is not None else None
        self._tf_msg: Any = None
        self._ctl_msg: Any = None
        super().__init__(name, max_queue=FRAME_QUEUE)

    def topics(self) -> list[str]:
        """The topics this publisher writes frames to."""
        names = ["/joint_states"] + (["/tf"] if self._tf is not None else [])
        return names + ([self.controller.topic] if self.controller is not None else [])

    @property
    def publishes_tf(self) -> bool:
        return self._tf is not None

    def _controller_publisher(self, node: Any, emb: Embodiment) -> Any:
        ctl = self.controller
        if ctl is None:
            return None
        index = {n: i for i, n in enumerate(emb.joint_names)}
        self._order = np.array([index[j] for j in ctl.joints], dtype=np.intp)
        kind = self.types["Float64MultiArray"] if ctl.kind == FORWARD else self.types["JointTrajectory"]
        return node.create_publisher(kind, ctl.topic, 10)

    def offer(self, frame: AnimationFrame) -> None:
        # the time the frame is made (in the tick) travels with it: the stamps follow the wall clock
        super().offer((frame, time.time() if frame.made is None else frame.made))

    def consume(self, frame: Any) -> None:  # (AnimationFrame, the wall time it was made), from offer()
        made: float
        f: AnimationFrame
        f, made = frame
        view, js = self.view, self._js
        view.follow_wall(f, made)
        q, qd = view.joints(f)
        stamp = view.stamp(f)
        js.header.stamp.sec, js.header.stamp.nanosec = stamp.sec, stamp.nanosec
        js.position, js.velocity = _doubles(q), _doubles(qd)
        self._joint_state.publish(js)
        if self._tf is not None:
            self._tf.publish(self._tf_message(f, stamp))
        if self._controller is not None:
            self._controller.publish(self._controller_message(f, q, qd))
        if self.events is not None and f.events:
            for event in view.events(f):
                self.events(dumps(event))
        self.published += 1

    def _tf_message(self, frame: AnimationFrame, stamp: Any) -> Any:
        # one message, refilled each frame: building rclpy messages costs more than publishing them
        msg = self._tf_msg
        if msg is None:
            msg = self._tf_msg = self.types["TFMessage"](transforms=[self.types["TransformStamped"]()])
        pose = self.view.base(frame)
        t = msg.transforms[0]
        t.header.stamp.sec, t.header.stamp.nanosec = stamp.sec, stamp.nanosec
        if pose is not None:
            t.header.frame_id, t.child_frame_id = pose.parent, pose.child
            v, r = t.transform.translation, t.transform.rotation
            v.x, v.y, v.z = pose.translation
            r.x, r.y, r.z, r.w = pose.rotation
        return msg

    def _controller_message(self, frame: AnimationFrame, q: np.ndarray, qd: np.ndarray) -> Any:
        ctl, msg = self.controller, self._ctl_msg
        if ctl is None:
            return None
        if ctl.kind == FORWARD:
            if msg is None:
                msg = self._ctl_msg = self.types["Float64MultiArray"]()
            msg.data = _doubles(q[self._order])
            return msg
        if msg is None:
            msg = self._ctl_msg = self.types["JointTrajectory"]()
            msg.joint_names = list(ctl.joints)
            msg.points = [self.types["JointTrajectoryPoint"]()]
        point = msg.points[0]
        point.positions, point.velocities = _doubles(q[self._order]), _doubles(qd[self._order])
        ns = round(frame.dt * 1e9)  # due one tick from now: the controller interpolates to it
        point.time_from_start.sec, point.time_from_start.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
        return msg
