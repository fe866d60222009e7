"""Nutty on ROS 2 on this machine: what publishing a frame costs, and how late a tick reaches an rclpy
subscriber, against the engine's own /ws/frames measured in the same run.

- Publishing cost: `FramePublisher.consume` (a JointState, the base's TFMessage and a forward
  controller's Float64MultiArray for nutty_desk) with a subscriber in another context matched, per frame
  in µs and as a share of a 100 Hz tick; peer: encoding the same frame for /ws/frames (msgpack). This
  work runs on the publisher's sink thread, never the clock's.
- Latency: `nutty serve --ros2 --no-previz` at 100 Hz (the bundled interactive program); this process
  subscribes to /joint_states with rclpy and follows /ws/frames?format=msgpack at the same time, for
  SECONDS. Latency of a frame = arrival here - its nominal time (the clock's start + the frame's time:
  a JointState's header stamp; a /ws/frames document's `t`), so the tick's own lateness is included.
  p50/p99/max in ms, and the ratio ROS 2 / WebSocket (the peer).

ROS stays on this machine (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, a domain id of its own).
Run: .venv/bin/python benchmarks/bench_ros2.py
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", "117")

from bench_fleet import follow_ws, free_port
from results import headline, recorded

from backend.engine.embodiment import load_embodiment
from backend.session import EngineSession

SECONDS = 10.0
RATE = 100.0
FRAMES = 3000


# A subscriber in its own process (so it never competes with the publisher for the interpreter lock):
# it counts the JointStates it gets and prints the count when its stdin closes.
LISTENER = """
import sys, threading, rclpy
from sensor_msgs.msg import JointState
rclpy.init()
node = rclpy.create_node("bench_listener")
got = [0]
node.create_subscription(JointState, "/joint_states", lambda m: got.__setitem__(0, got[0] + 1), 5000)
threading.Thread(target=rclpy.spin, args=(node,), daemon=True).start()
print("ready", flush=True)
sys.stdin.read()
print(got[0], flush=True)
"""


def publishing_cost() -> None:
    from backend.ros2.node import RosNode  # lazy: as above
    from backend.ros2.outputs import ControllerOutput, FramePublisher
    from backend.zenoh_link.codec import encode_frame

    emb = load_embodiment("nutty_desk")
    session = EngineSession.create(emb, rate=RATE)
    session.load_program((ROOT / "robots/nutty_desk/programs/interactive.json").read_text())
    frames = [session.engine.tick() for _ in range(FRAMES)]
    listener = subprocess.Popen(
        [sys.executable, "-c", LISTENER], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    if listener.stdout is None or listener.stdin is None or listener.stdout.readline().strip() != "ready":
        raise RuntimeError("the listener process did not start")
    node = RosNode("bench_publisher")
    controller = ControllerOutput.parse("forward_position_controller", None, emb)
    pub = FramePublisher(emb, node.node, controller=controller)
    pub.close(0.1)  # its thread is not needed: consume() is timed here, on this thread
    deadline = time.time() + 10
    while pub._joint_state.get_subscription_count() == 0 and time.time() < deadline:
        time.sleep(0.05)
    costs, peer = [], []
    for frame in frames:
        t0 = time.perf_counter()
        pub.consume((frame, time.time()))
        t1 = time.perf_counter()
        encode_frame(frame, emb)
        peer.append(time.perf_counter() - t1)
        costs.append(t1 - t0)
        time.sleep(0.0005)  # a frame stream, not a burst (the subscriber's queue would overflow)
    time.sleep(1.0)
    got, _ = listener.communicate("", timeout=20)
    node.close()
    c, w = np.array(costs[100:]) * 1e6, np.array(peer[100:]) * 1e6
    print(f"publishing a nutty_desk frame on ROS 2 ({FRAMES - 100} frames, a subscriber in another process):")
    print(
        f"  ROS 2 (JointState + /tf + controller): p50 {np.median(c):.1f} µs, "
        f"p99 {float(np.percentile(c, 99)):.1f} µs; {np.median(c) / (1e6 / RATE):.2%} of a {RATE:g} Hz "
        "tick, on the sink's thread"
    )
    print(
        f"  peer /ws/frames msgpack encoding: p50 {np.median(w):.1f} µs -> ratio {np.median(c) / np.median(w):.2f}"
    )
    print(f"  the subscriber received {got.strip()} of {FRAMES} JointStates")
    headline(
        f"publishing a frame on ROS 2 (JointState, /tf, a controller command): {np.median(c):.0f} µs p50 on the "
        f"sink's thread = {np.median(c) / np.median(w):.2f}× encoding it for /ws/frames"
    )


def latency() -> None:
    import rclpy  # lazy: as above
    from sensor_msgs.msg import JointState  # lazy: as above

    from backend.client import NuttyClient
    from backend.ros2.node import RosNode  # lazy: as above

    port = free_port()
    log = tempfile.TemporaryFile()
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "backend.cli",
            "serve",
            "--port",
            str(port),
            "--no-previz",
            "--ros2",
            "--rate",
            f"{RATE:g}",
        ],
        stdout=log,
        stderr=subprocess.STDOUT,
        cwd=ROOT,
    )
    listener = RosNode("bench_latency")
    ros_at: dict[float, float] = {}
    listener.node.create_subscription(
        JointState,
        "/joint_states",
        lambda m: ros_at.__setitem__(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, time.time()),
        1000,
    )
    try:
        client = NuttyClient(f"http://127.0.0.1:{port}", timeout=2.0)
        deadline = time.time() + 180
        while True:
            try:
                status = client.status()
                break
            except Exception:
                if time.time() > deadline or proc.poll() is not None:
                    raise RuntimeError("nutty serve --ros2 did not start") from None
                time.sleep(0.3)
        started = status["started_at"]
        ws_at: dict[int, float] = {}
        ws_t: dict[int, float] = {}
        stop = threading.Event()
        t = threading.Thread(target=follow_ws, args=(port, ws_at, stop, ws_t), daemon=True)
        t.start()
        time.sleep(1.0)
        ros_at.clear()
        time.sleep(SECONDS)
        stop.set()
        t.join(3)
    finally:
        listener.close()
        proc.terminate()
        proc.wait(30)
    r = np.array([arrival - stamp for stamp, arrival in ros_at.items()]) * 1e3
    w = np.array([ws_at[s] - (started + ws_t[s]) for s in ws_at if s in ws_t]) * 1e3
    print(
        f"tick -> subscriber latency at {RATE:g} Hz over {SECONDS:g} s ({rclpy.get_rmw_implementation_identifier()}):"
    )
    for name, lat in (("ROS 2 /joint_states", r), ("peer /ws/frames", w)):
        print(
            f"  {name}: {len(lat)} frames, p50 {np.median(lat):.2f} ms, p99 {float(np.percentile(lat, 99)):.2f} ms, max {lat.max():.2f} ms"
        )
    print(
        f"  ratio ROS 2 / WebSocket: p50 {np.median(r) / np.median(w):.2f}, p99 {np.percentile(r, 99) / np.percentile(w, 99):.2f}"
    )
    headline(
        f"tick -> rclpy subscriber: {np.median(r):.2f} ms p50 / {float(np.percentile(r, 99)):.2f} ms p99, "
        f"/ws/frames {np.median(w):.2f} / {float(np.percentile(w, 99)):.2f} ms"
    )


def main() -> None:
    publishing_cost()
    latency()


if __name__ == "__main__":
    with recorded("bench_ros2", "ROS 2: publishing cost and tick -> subscriber latency"):
        main()
