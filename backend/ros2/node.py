"""One rclpy node of our own: its own context (never rclpy's global one, never its signal handlers: the
server's shutdown parks the robot first) and an executor spinning on a thread of its own.

`require_rclpy()` imports rclpy or says which extra is missing. `discovery()` describes where this
process's ROS traffic can reach (domain id and `ROS_AUTOMATIC_DISCOVERY_RANGE`), for banners and logs.
"""

from __future__ import annotations

import logging
import os
import threading
from typing import Any

log = logging.getLogger(__name__)

NODE_NAME = "nutty"
DEFAULT_NAMESPACE = "/nutty"


class Ros2Unavailable(RuntimeError):
    """rclpy or a message package is missing, or ROS 2 could not start."""


def require_rclpy() -> Any:
    """The rclpy module, or Ros2Unavailable naming the extra that installs it."""
    try:
        import rclpy  # lazy: ROS 2's native libraries load only when a link is made
    except ImportError as exc:
        raise Ros2Unavailable(
            f"ROS 2 is not installed ({exc}): pip install -e '.[ros2]' (ROS 2 Kilted wheels: rclpy, "
            "rmw_fastrtps_cpp and the message packages)"
        ) from exc
    return rclpy


def check_namespace(namespace: str) -> str:
    """`namespace` as an absolute ROS namespace ('/nutty'); ValueError saying what is wrong."""
    ns = "/" + namespace.strip("/") if namespace.strip("/") else "/"
    parts = [p for p in ns.split("/") if p]
    for part in parts:
        if not (part[0].isalpha() or part[0] == "_") or not all(c.isalnum() or c == "_" for c in part):
            raise ValueError(
                f"ROS namespace {namespace!r}: each part must start with a letter or '_' and hold only "
                "letters, digits and '_'"
            )
    return ns


def topic(namespace: str, name: str) -> str:
    """`name` inside `namespace` ('/nutty' + 'events' -> '/nutty/events')."""
    return f"{namespace.rstrip('/')}/{name}"


def discovery() -> dict[str, Any]:
    """Where this process's ROS 2 traffic can reach: the domain id, the discovery range, the RMW."""
    return {
        "domain_id": int(os.environ.get("ROS_DOMAIN_ID") or 0),
        "discovery_range": os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE") or "SUBNET",
        "rmw": os.environ.get("RMW_IMPLEMENTATION") or "rmw_fastrtps_cpp",
    }


class RosNode:
    """A node named `name` with its own context and executor thread; `close()` ends all three."""

    def __init__(self, name: str = NODE_NAME, namespace: str = "/"):
        rclpy = require_rclpy()
        from rclpy.context import Context  # lazy: rclpy is loaded above only when a link is made
        from rclpy.executors import SingleThreadedExecutor  # lazy: as above
        from rclpy.signals import SignalHandlerOptions  # lazy: as above

        self.context = Context()
        try:
            rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
            self.node = rclpy.create_node(name, namespace=namespace, context=self.context)
        except Exception as exc:  # an RMW that cannot start (bad domain id, no network): say so
            self.context.try_shutdown()
            raise Ros2Unavailable(f"ROS 2 did not start: {exc}") from exc
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name=f"ros2-{name}", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set() and self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.1)
            except Exception:  # a callback's fault is logged there; never stop the executor for it
                log.exception("ROS 2: a callback failed")

    def close(self) -> None:
        """Stop the executor, destroy the node, shut the context down (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._thread.join(2.0)
        try:
            self.executor.shutdown(timeout_sec=1.0)
            self.node.destroy_node()
        finally:
            self.context.try_shutdown()
