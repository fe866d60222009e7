"""One robot's engine, followed over Zenoh by a robot-side bridge (`nutty bridge`): its description,
its tick rate and its frames."""

from __future__ import annotations

import threading
import time
from typing import Any, Callable

from backend.engine.embodiment import Embodiment
from backend.zenoh_link import keys
from backend.zenoh_link.codec import embodiment_from_dict, frame_of, json_of


def ask_one(session: Any, robot_id: str, leaf: str, timeout: float = 2.0) -> Any:
    """The JSON answer of `robot_id` on `leaf`, or None when it did not answer within `timeout` s."""
    for reply in session.get(keys.key(robot_id, leaf), timeout=timeout):
        if reply.ok is not None:
            try:
                answer = json_of(reply.ok)
            except ValueError:
                continue
            if not (isinstance(answer, dict) and answer.get("type") == "error"):
                return answer
    return None


def wait_for_engine(session: Any, robot_id: str, *, robot: Embodiment | None, rate: float | None, wait: float,
                    log: Callable[[str], None], stop: threading.Event | None = None) -> tuple[Embodiment, float]:
    """The robot (asked of the engine unless given) and its tick rate (asked unless given), waiting up to
    `wait` s for the engine to answer (or until `stop` is set); TimeoutError naming what is missing."""
    deadline = time.monotonic() + wait
    told = False
    stop = stop or threading.Event()
    while (robot is None or rate is None) and not stop.is_set():
        if robot is None and (doc := ask_one(session, robot_id, keys.ROBOT)) is not None:
            robot = embodiment_from_dict(doc)
        if rate is None and isinstance(status := ask_one(session, robot_id, keys.STATUS), dict):
            rate = float(status["rate"]) if isinstance(status.get("rate"), (int, float)) else None
        if robot is not None and rate is not None:
            break
        if time.monotonic() > deadline:
            missing = " and ".join(x for x, v in (("its robot description", robot), ("its tick rate", rate))
                                   if v is None)
            raise TimeoutError(f"robot '{robot_id}' did not give {missing} within {wait:g} s: is its engine running "
                               f"with --zenoh --robot-id {robot_id}, and reachable (see `nutty fleet list`)?")
        if not told:
            log(f"nutty bridge: waiting for robot '{robot_id}' on Zenoh ({keys.key(robot_id, keys.ROBOT)})")
            told = True
        stop.wait(0.5)
    return robot, rate  # type: ignore[return-value]  # (None only when stopped, which the caller checks)


def follow_frames(session: Any, robot_id: str, receive: Callable[[dict[str, Any], float | None], None],
                  reject: Callable[[str], None]) -> Any:
    """Subscribe to the robot's frames: `receive(document, emission stamp)` for each, `reject(why)` for a
    message that is not a frame. Returns the subscriber (undeclare it when done)."""

    def on_sample(sample: Any) -> None:
        try:
            doc, sent = frame_of(sample)
        except ValueError as exc:
            reject(str(exc))
            return
        receive(doc, sent)

    return session.declare_subscriber(keys.key(robot_id, keys.FRAMES), on_sample)
