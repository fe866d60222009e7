"""ROS 2 messages as CDR bytes without ROS: the message definitions and serialisation of `rosbags`
(pure Python), for MCAP recordings and Foxglove channels. A live ROS 2 link uses rclpy's own types
(backend/ros2/link.py); these bytes are what rclpy would put on the wire for the same message.

Each builder takes plain values (backend/ros2/view.py) and returns the little-endian CDR encoding
with its 4-byte encapsulation header, as rosbag2 stores it.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache
from typing import Any

import numpy as np

from backend.ros2.view import BasePose, Stamp

try:
    from rosbags.typesys import Stores, get_typestore
except ImportError as exc:  # the optional extra: say how to get it
    raise ImportError(
        "ROS 2 message encoding needs the 'mcap' extra: pip install -e '.[mcap]' (rosbags)"
    ) from exc

JOINT_STATE = "sensor_msgs/msg/JointState"
STRING = "std_msgs/msg/String"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
FLOAT64_MULTI_ARRAY = "std_msgs/msg/Float64MultiArray"
JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
POINT_STAMPED = "geometry_msgs/msg/PointStamped"


@cache
def typestore() -> Any:
    """The ROS 2 Kilted message types (the distribution whose wheels `[ros2]` installs)."""
    return get_typestore(Stores.ROS2_KILTED)


@cache
def message_definition(typename: str) -> str:
    """The `ros2msg` schema text of a type, with its dependencies after `====` separators, as rosbag2
    writes it into an MCAP schema record."""
    # ros_version=2: ROS 2 names (builtin_interfaces/Time), not ROS 1's `time`, which ROS 2 readers refuse.
    return typestore().generate_msgdef(typename, ros_version=2)[0]


def schema_name(typename: str) -> str:
    """`sensor_msgs/msg/JointState`: the name rosbag2 and Foxglove give the schema."""
    return typename


def _time(stamp: Stamp) -> Any:
    return typestore().types["builtin_interfaces/msg/Time"](sec=stamp.sec, nanosec=stamp.nanosec)


def _header(stamp: Stamp, frame_id: str = "") -> Any:
    return typestore().types["std_msgs/msg/Header"](stamp=_time(stamp), frame_id=frame_id)


def _bytes(message: Any, typename: str) -> bytes:
    return bytes(typestore().serialize_cdr(message, typename))


def joint_state(stamp: Stamp, names: Sequence[str], position: np.ndarray, velocity: np.ndarray) -> bytes:
    """sensor_msgs/JointState: the joints' positions (rad or m) and velocities (per s); no effort."""
    types = typestore().types
    message = types[JOINT_STATE](
        header=_header(stamp),
        name=list(names),
        position=np.asarray(position, dtype=np.float64),
        velocity=np.asarray(velocity, dtype=np.float64),
        effort=np.zeros(0, dtype=np.float64),
    )
    return _bytes(message, JOINT_STATE)


def string(text: str) -> bytes:
    """std_msgs/String."""
    return _bytes(typestore().types[STRING](data=text), STRING)


def tf_message(stamp: Stamp, poses: Sequence[BasePose]) -> bytes:
    """tf2_msgs/TFMessage with one geometry_msgs/TransformStamped per pose."""
    types = typestore().types
    transforms = [
        types["geometry_msgs/msg/TransformStamped"](
            header=_header(stamp, p.parent),
            child_frame_id=p.child,
            transform=types["geometry_msgs/msg/Transform"](
                translation=types["geometry_msgs/msg/Vector3"](*p.translation),
                rotation=types["geometry_msgs/msg/Quaternion"](*p.rotation),
            ),
        )
        for p in poses
    ]
    return _bytes(types[TF_MESSAGE](transforms=transforms), TF_MESSAGE)


def float64_multi_array(values: np.ndarray, label: str = "", labels: Sequence[str] = ()) -> bytes:
    """std_msgs/Float64MultiArray: one dimension (`label`, its size), or, with `labels`, one dimension
    per value named after it (size 1): how a channel vector keeps its names in a ROS message."""
    types = typestore().types
    dim = types["std_msgs/msg/MultiArrayDimension"]
    data = np.asarray(values, dtype=np.float64)
    dims = (
        [dim(label=name, size=1, stride=1) for name in labels]
        if labels
        else [dim(label=label, size=len(data), stride=len(data))]
    )
    layout = types["std_msgs/msg/MultiArrayLayout"](dim=dims, data_offset=0)
    return _bytes(types[FLOAT64_MULTI_ARRAY](layout=layout, data=data), FLOAT64_MULTI_ARRAY)


def decode(data: bytes, typename: str) -> Any:
    """A CDR message back as rosbags' message object (tests and `nutty play`)."""
    return typestore().deserialize_cdr(data, typename)
