"""Keep ROS 2 on this machine in tests: discovery stays on localhost, and each test that uses ROS gets
a ROS domain of its own, so two tests (or two pytest workers) never hear each other.

`ros_domain()` hands out domain ids 1..100, disjoint per pytest-xdist worker; `ros_environ(domain)`
is the environment a ROS process of that test runs with (also applied to this process by the
`ros_domain_env` fixture, for rclpy used in-process).
"""

from __future__ import annotations

import itertools
import os

#: Domain ids a worker may use: 1..100 split between workers (ids above 101 clash with ephemeral ports).
_SPAN = 100
_counter = itertools.count()


def _worker_index() -> int:
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    digits = "".join(ch for ch in worker if ch.isdigit())
    return int(digits or 0)


def ros_domain() -> int:
    """A ROS domain id no other test of this run uses at the same time."""
    workers = max(1, int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")))
    per_worker = max(1, _SPAN // workers)
    return 1 + _worker_index() * per_worker + next(_counter) % per_worker


def ros_environ(domain: int, base: dict[str, str] | None = None) -> dict[str, str]:
    """The environment for a ROS process in this test: localhost discovery, its own domain."""
    env = dict(os.environ if base is None else base)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_DOMAIN_ID"] = str(domain)
    env.pop("ROS_STATIC_PEERS", None)
    env.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    return env
