"""The ROS 2 options of `nutty serve` and `nutty bridge`: `--ros2`, `--ros2-namespace`,
`--ros2-controller`, `--ros2-joints`, and for serve `--ros2-read-only` and `--ros2-trajectory-hold`.

Who may move the robot: ROS 2 has no token. With `--token`, the HTTP API's token would have a back door
if anyone on the ROS domain could command the robot, so `nutty serve --token T --ros2` starts only
read-only (`--ros2-read-only`: it publishes, subscribes to nothing) unless SROS2 enforces access control
(`ROS_SECURITY_ENABLE=true`, `ROS_SECURITY_STRATEGY=Enforce`, with the keystore and permissions that
say who may publish on the input topics).
"""

from __future__ import annotations

import argparse
import math
import os
from typing import Any

from backend.ros2.node import DEFAULT_NAMESPACE, check_namespace, discovery, topic
from backend.ros2.trajectory import DEFAULT_HOLD


def _namespace(text: str) -> str:
    try:
        return check_namespace(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _joints(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError("expected joint names separated by commas, e.g. head_yaw,head_pitch")
    return names


def _hold(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not 0 <= value <= 3600 or math.isnan(value):
        raise argparse.ArgumentTypeError(f"--ros2-trajectory-hold must be within 0..3600 s, got {text}")
    return value


def add_ros2_options(parser: argparse.ArgumentParser, serve: bool = True) -> None:
    g = parser.add_argument_group("ROS 2 (docs/ros2.md; needs the [ros2] extra)")
    what = (
        "join ROS 2: publish /joint_states, /tf, NS/events and NS/status; take NS/gaze_target, "
        "NS/command and NS/joint_trajectory"
        if serve
        else "also publish the followed frames on ROS 2: /joint_states, /tf and the controller topic"
    )
    g.add_argument("--ros2", action="store_true", help=what)
    g.add_argument(
        "--ros2-namespace",
        type=_namespace,
        default=DEFAULT_NAMESPACE,
        metavar="NS",
        help=f"namespace of the engine's own topics (default {DEFAULT_NAMESPACE})",
    )
    g.add_argument(
        "--ros2-controller",
        metavar="NAME",
        default=None,
        help="also command a ros2_control controller: forward_position_controller (Float64MultiArray on "
        "/NAME/commands) or, for a name with 'trajectory' in it, joint_trajectory_controller "
        "(JointTrajectory on /NAME/joint_trajectory, one point per tick)",
    )
    g.add_argument(
        "--ros2-joints",
        type=_joints,
        default=None,
        metavar="J1,J2,...",
        help="the controller's joint order (default: the URDF's actuated joints in order)",
    )
    if serve:
        g.add_argument(
            "--ros2-read-only",
            action="store_true",
            help="publish only: subscribe to no input topic (what --token requires without SROS2)",
        )
        g.add_argument(
            "--ros2-trajectory-hold",
            type=_hold,
            default=DEFAULT_HOLD,
            metavar="SECONDS",
            help=f"hold a trajectory's last point this long before releasing it (default {DEFAULT_HOLD:g})",
        )


def sros2_enforced(environ: dict[str, str] | None = None) -> bool:
    env = os.environ if environ is None else environ
    return (
        env.get("ROS_SECURITY_ENABLE", "").lower() == "true" and env.get("ROS_SECURITY_STRATEGY") == "Enforce"
    )


def check_ros2_options(args: argparse.Namespace) -> str | None:
    """What is wrong with the ROS 2 options, or None (see the module doc for the token rule)."""
    if not args.ros2:
        given = [
            flag
            for flag, value in (
                ("--ros2-controller", args.ros2_controller),
                ("--ros2-joints", args.ros2_joints),
                ("--ros2-read-only", getattr(args, "ros2_read_only", False)),
            )
            if value
        ]
        if args.ros2_namespace != DEFAULT_NAMESPACE:
            given.append("--ros2-namespace")
        return f"{', '.join(given)} need --ros2" if given else None
    if args.ros2_joints and not args.ros2_controller:
        return "--ros2-joints orders a controller's joints: give --ros2-controller NAME too"
    token = getattr(args, "token", None)
    if token and not getattr(args, "ros2_read_only", True) and not sros2_enforced():
        return (
            "--token guards HTTP, but anyone on the ROS domain could command the robot through "
            f"{topic(args.ros2_namespace, 'command')}: add --ros2-read-only, or enforce SROS2 access control "
            "(ROS_SECURITY_ENABLE=true, ROS_SECURITY_STRATEGY=Enforce; docs/ros2.md)"
        )
    return None


def controller_of(args: argparse.Namespace, emb: Any) -> Any:
    """The ControllerOutput the options ask for, or None; ValueError saying what does not fit."""
    from backend.ros2.outputs import ControllerOutput  # lazy: a fast `nutty --help`

    if not args.ros2_controller:
        return None
    return ControllerOutput.parse(args.ros2_controller, args.ros2_joints, emb)


def banner(link: Any) -> str:
    """Where the engine is on ROS 2 (a line or two for stdout)."""
    d = discovery()
    ns = link.namespace
    inputs = (
        "read-only"
        if link.read_only
        else f"in: {topic(ns, 'gaze_target')}, {topic(ns, 'command')}, {topic(ns, 'joint_trajectory')}"
    )
    frames = link.frames
    out = "/joint_states" + (", /tf" if frames is not None and frames.publishes_tf else "")
    if link.controller is not None:
        out += f", {link.controller.topic}"
    if frames is not None and frames.tf_missing:
        out += " (not /tf: tf2_msgs is not built)"
    return (
        f"  ROS 2    domain {d['domain_id']}, discovery {d['discovery_range']}; out: {out}, "
        f"{topic(ns, 'events')}, {topic(ns, 'status')}; {inputs}"
    )
