"""A ROS 2 node for tests, in the test's own process: its own rclpy context on the test's domain (see
tests/ros_env.py), an executor thread, and messages recorded per topic."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any


class RosProbe:
    """Subscribe with `listen(topic, type)` (messages gather in `messages[topic]`), publish with
    `publisher(topic, type)`; `wait_for(topic, predicate, timeout)` waits for a message that fits."""

    def __init__(self, domain: int, name: str = "nutty_test_probe"):
        import rclpy  # lazy: ROS loads only in the tests that use it
        from rclpy.context import Context  # lazy: as above
        from rclpy.executors import SingleThreadedExecutor  # lazy: as above
        from rclpy.signals import SignalHandlerOptions  # lazy: as above

        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.messages: dict[str, list[Any]] = {}
        self.arrivals: dict[str, list[float]] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.05)

    def listen(self, topic: str, msg_type: Any, depth: int = 1000, qos: Any = None) -> list[Any]:
        got = self.messages.setdefault(topic, [])
        times = self.arrivals.setdefault(topic, [])

        def keep(msg: Any) -> None:
            with self._lock:
                got.append(msg)
                times.append(time.monotonic())

        self.node.create_subscription(msg_type, topic, keep, qos if qos is not None else depth)
        return got

    def clear(self) -> None:
        """Forget every message heard so far (the subscriptions stay)."""
        with self._lock:
            for topic in self.messages:
                self.messages[topic].clear()
                self.arrivals[topic].clear()

    def publisher(self, topic: str, msg_type: Any) -> Any:
        return self.node.create_publisher(msg_type, topic, 10)

    def wait_for(
        self, topic: str, fits: Callable[[Any], bool] = lambda m: True, timeout: float = 20.0
    ) -> Any:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                for msg in self.messages.get(topic, []):
                    if fits(msg):
                        return msg
            time.sleep(0.02)
        raise TimeoutError(f"no fitting message on {topic} within {timeout} s")

    def wait_subscribers(self, publisher: Any, timeout: float = 20.0) -> None:
        """Wait until a publisher is matched (a message sent earlier would be lost)."""
        deadline = time.monotonic() + timeout
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise TimeoutError(f"nobody subscribes to {publisher.topic_name}")
            time.sleep(0.05)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        self.executor.shutdown(timeout_sec=1)
        self.node.destroy_node()
        self.context.try_shutdown()
