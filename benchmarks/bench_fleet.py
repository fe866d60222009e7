"""Nutty on Zenoh on this machine: frame latency over Zenoh against /ws/frames, and how many engines at
100 Hz one machine holds.

- Latency: one `nutty serve --zenoh` at 100 Hz (the bundled interactive program); this process follows
  its frames over Zenoh (through its own router, loopback) and over `/ws/frames?format=msgpack` at
  the same time, for SECONDS. Latency of a frame = arrival here - the engine's emission stamp (taken in
  the tick, carried in the Zenoh attachment; the same frame's /ws/frames copy is matched by seq).
  p50/p99/max in ms, and the ratio Zenoh / WebSocket (the peer).
- Publishing cost: encoding a nutty_desk frame (what /ws/frames pays too) and putting it on Zenoh to a
  subscriber in another session over loopback, per frame in µs, and as a share of a 100 Hz tick.
- Scaling: 1, 4 and 8 engines at 100 Hz with --zenoh, all publishing to this process, which receives
  every frame of every engine (as an operator console would). Over SECONDS: ticks reached, overruns
  and lost ticks (ticks the clock could not run in time), tick period p99, frames received here per
  tick, and each engine's CPU share (of one core). An engine count is "held" when the engines lost
  at most HELD_LOSS of their ticks. Peer, in the same window: one more engine without --zenoh (its
  lost ticks and CPU: what the machine's load does to an engine without Zenoh).

Timings depend on the machine's load (printed). Run: .venv/bin/python benchmarks/bench_fleet.py
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from results import headline, recorded

from backend.fleet import Fleet

SECONDS = 10.0
RATE = 100.0
COUNTS = (1, 4, 8)
HELD_LOSS = 0.01  # share of ticks an engine count may lose and still be "held"
LOCAL_ONLY = "{ scouting: { multicast: { enabled: false } } }\n"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Engine:
    """A `nutty serve` process (no Pre-Viz), on Zenoh as `robot_id` when `hub` (an endpoint) is given."""

    def __init__(self, robot_id: str, config: str, hub: str | None):
        self.robot_id, self.port = robot_id, free_port()
        zenoh = (
            [
                "--zenoh",
                "--robot-id",
                robot_id,
                "--zenoh-config",
                config,
                "--zenoh-connect",
                hub,
                "--zenoh-listen",
                f"tcp/127.0.0.1:{free_port()}",
            ]
            if hub
            else []
        )
        self.log = tempfile.TemporaryFile()
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "backend.cli",
                "serve",
                "--no-previz",
                "--port",
                str(self.port),
                "--rate",
                f"{RATE:g}",
                *zenoh,
            ],
            cwd=ROOT,
            stdout=self.log,
            stderr=subprocess.STDOUT,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )

    def sample(self) -> tuple[dict, float, float]:
        """(status, CPU seconds used so far, when) for rates over a window."""
        return self.status(), self.cpu_seconds(), time.monotonic()

    def cpu_seconds(self) -> float:
        fields = Path(f"/proc/{self.proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def status(self) -> dict:
        import httpx

        return httpx.get(f"http://127.0.0.1:{self.port}/api/status", timeout=5).json()

    def wait_http(self, timeout: float = 180.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                self.status()
                return
            except Exception:
                time.sleep(0.5)
        raise RuntimeError(f"engine {self.robot_id} did not start")

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGTERM)
        try:
            self.proc.wait(20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)
        self.log.close()


def pct(values, q) -> float:
    return float(np.percentile(np.asarray(values) * 1e3, q)) if len(values) else float("nan")


# --------------------------------------------------------------------------------------------------
# Latency
# --------------------------------------------------------------------------------------------------


def follow_ws(port: int, arrivals: dict, stop: threading.Event, times: dict | None = None) -> None:
    """Arrival time (Unix s) of each /ws/frames frame by seq, and its frame time `t` into `times`."""
    import msgpack
    from websockets.sync.client import connect

    with connect(f"ws://127.0.0.1:{port}/ws/frames?format=msgpack", max_size=None) as ws:
        while not stop.is_set():
            try:
                data = ws.recv(timeout=0.5)
            except TimeoutError:
                continue
            doc = msgpack.unpackb(data)
            arrivals[doc["seq"]] = time.time()
            if times is not None:
                times[doc["seq"]] = doc["t"]


def latency(config: str) -> None:
    hub = f"tcp/127.0.0.1:{free_port()}"
    with Fleet(mode="router", listen=[hub], config=config, timeout=10) as fleet:
        engine = Engine("bench-latency", config, hub)
        try:
            fleet.wait_for({"bench-latency"}, timeout=180)
            engine.wait_http()
            stamps, zenoh_at, ws_at = {}, {}, {}

            def on_frame(rid, doc, sent):
                zenoh_at[doc["seq"]] = time.time()
                stamps[doc["seq"]] = sent

            stop = threading.Event()
            ws = threading.Thread(target=follow_ws, args=(engine.port, ws_at, stop), daemon=True)
            sub = fleet.frames("bench-latency", on_frame)
            ws.start()
            time.sleep(SECONDS)
            stop.set()
            sub.undeclare()
            ws.join(5)
        finally:
            engine.stop()
    both = sorted(set(stamps) & set(ws_at))[int(RATE) :]  # the first second warms up
    z = [zenoh_at[s] - stamps[s] for s in both]
    w = [ws_at[s] - stamps[s] for s in both]
    print(f"latency over {len(both)} frames at {RATE:g} Hz (same frames, same engine, this machine):")
    for name, lat in (("Zenoh", z), ("/ws/frames", w)):
        print(
            f"  {name:11s} p50 {pct(lat, 50):6.2f} ms   p99 {pct(lat, 99):6.2f} ms   max {pct(lat, 100):7.2f} ms"
        )
    print(
        f"  ratio Zenoh / WebSocket: p50 {pct(z, 50) / pct(w, 50):.2f}x, p99 {pct(z, 99) / pct(w, 99):.2f}x"
    )
    headline(
        f"frame latency tick -> subscriber, same machine: Zenoh {pct(z, 50):.2f} ms p50 / {pct(z, 99):.2f} ms p99, "
        f"/ws/frames {pct(w, 50):.2f} / {pct(w, 99):.2f} ms"
    )


# --------------------------------------------------------------------------------------------------
# Scaling
# --------------------------------------------------------------------------------------------------


def run_engines(n: int, config: str) -> tuple[dict, dict]:
    """`n` engines with --zenoh and one peer without, side by side for SECONDS: the figures of each group."""
    hub = f"tcp/127.0.0.1:{free_port()}"
    with Fleet(mode="router", listen=[hub], config=config, timeout=10) as fleet:
        engines = [Engine(f"bench-{i}", config, hub) for i in range(1, n + 1)] + [
            Engine("peer", config, None)
        ]
        received: dict[str, int] = {}
        lock = threading.Lock()

        def on_frame(rid, doc, sent):
            with lock:
                received[rid] = received.get(rid, 0) + 1

        def snap(e: Engine) -> tuple[dict, float, float, int]:
            status, cpu, t = e.sample()
            with lock:
                return status, cpu, t, received.get(e.robot_id, 0)

        try:
            for e in engines:
                e.wait_http()
            fleet.wait_for({e.robot_id for e in engines[:n]}, timeout=120)
            time.sleep(2.0)  # let start-up settle
            sub = fleet.frames("bench-*", on_frame)
            before = [snap(e) for e in engines]
            time.sleep(SECONDS)
            after = [snap(e) for e in engines]
            sub.undeclare()
        finally:
            for e in engines:
                e.stop()
    windows = list(zip(before, after))
    return figures(windows[:n]), figures(windows[n:])


def figures(windows: list) -> dict:
    """Totals and per-engine figures over (before, after) samples of some engines."""
    ticks = [a["ticks"] - b["ticks"] for (b, *_), (a, *_) in windows]
    return {
        "ticks": ticks,
        "nominal": [RATE * (ta - tb) for (_, _, tb, _), (_, _, ta, _) in windows],
        "lost": [a["lost_ticks"] - b["lost_ticks"] for (b, *_), (a, *_) in windows],
        "overruns": [a["overruns"] - b["overruns"] for (b, *_), (a, *_) in windows],
        "period_p99": max(a["period"]["p99_ms"] for _, (a, *_) in windows),
        "cpu": [(ca - cb) / (ta - tb) for (_, cb, tb, _), (_, ca, ta, _) in windows],
        "received": [(ra - rb) / max(t, 1) for ((*_, rb), (*_, ra)), t in zip(windows, ticks)],
    }


def row(label: str, r: dict, peer: dict | None = None) -> str:
    reached = sum(r["ticks"]) / sum(r["nominal"])
    lost = sum(r["lost"]) / sum(r["nominal"])
    cpu = np.mean(r["cpu"])
    text = (
        f"  {label:18s} ticks {reached:5.0%} of nominal   overruns {sum(r['overruns']):5d}   lost ticks "
        f"{sum(r['lost']):5d} ({lost:5.1%})   period p99 {r['period_p99']:6.2f} ms   CPU/engine {cpu:4.0%}"
    )
    if peer is not None:
        text += (
            f"   frames here {np.mean(r['received']):5.0%} of ticks   CPU {cpu / max(peer['cpu'][0], 1e-9):.2f}x "
            f"the peer   {'held' if lost <= HELD_LOSS else 'NOT held'}"
        )
    return text


def scaling(config: str) -> None:
    print(
        f"engines at {RATE:g} Hz, the bundled interactive program, {SECONDS:g} s each, next to a peer engine "
        f"without Zenoh ({os.cpu_count()} cores; 'held': at most {HELD_LOSS:.0%} of ticks lost):"
    )
    held_up_to, all_held = 0, True
    for n in COUNTS:
        load = os.getloadavg()[0]
        zenoh, peer = run_engines(n, config)
        all_held = all_held and sum(zenoh["lost"]) <= HELD_LOSS * sum(zenoh["nominal"])
        held_up_to = n if all_held else held_up_to
        print(f" {n} engine{'s' if n > 1 else ''} + peer (load average {load:.2f} before):")
        print(row(f"{n} with --zenoh", zenoh, peer))
        print(row("peer, no Zenoh", peer))
    print(f"  held up to {held_up_to} of {', '.join(map(str, COUNTS))} engines")
    headline(
        f"engines with --zenoh on {os.cpu_count()} cores at {RATE:g} Hz: every tick held up to {held_up_to} engines"
    )


def publish_cost() -> None:
    """µs per frame: encoding alone (the /ws/frames share) and encoding plus a put to a subscriber."""
    import zenoh

    from backend.engine.embodiment import load_embodiment
    from backend.session import EngineSession
    from backend.zenoh_link.codec import encode_frame, stamp
    from backend.zenoh_link.session import ZenohOptions

    emb = load_embodiment("nutty_desk")
    session = EngineSession.create(emb, rate=RATE)
    session.load_program((ROOT / "robots" / "nutty_desk" / "programs" / "interactive.json").read_text())
    frames = session.engine.run_ticks(2000)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    local = {"scouting/multicast/enabled": False}
    a = ZenohOptions(listen=[endpoint], overrides=local).open()
    b = ZenohOptions(connect=[endpoint], overrides=local).open()
    got = []
    try:
        sub = b.declare_subscriber("bench/frames", lambda s: got.append(1))
        pub = a.declare_publisher(
            "bench/frames", congestion_control=zenoh.CongestionControl.DROP, express=True
        )
        time.sleep(0.5)
        best = {"encode": float("inf"), "encode + put": float("inf")}
        for _ in range(5):  # best of 5 rounds: the machine's load only ever adds
            t0 = time.perf_counter()
            for f in frames:
                encode_frame(f, emb)
            t1 = time.perf_counter()
            for f in frames:
                pub.put(encode_frame(f, emb), attachment=stamp(time.time()))
            t2 = time.perf_counter()
            best["encode"] = min(best["encode"], (t1 - t0) / len(frames))
            best["encode + put"] = min(best["encode + put"], (t2 - t1) / len(frames))
        time.sleep(0.5)
        sub.undeclare()
    finally:
        b.close()
        a.close()
    put = best["encode + put"] - best["encode"]
    print(
        f"publishing a nutty_desk frame (best of 5 x {len(frames)}; {len(got)} received by the other session):"
    )
    print(
        f"  encode (also paid by /ws/frames) {best['encode'] * 1e6:6.1f} us   Zenoh put {put * 1e6:6.1f} us "
        f"({put / best['encode']:.2f}x the encoding)   together {best['encode + put'] * RATE:.1%} of one core at "
        f"{RATE:g} Hz"
    )
    headline(
        f"publishing a frame on Zenoh: {best['encode'] * 1e6:.1f} µs to encode + {put * 1e6:.1f} µs to put, "
        f"{best['encode + put'] * RATE:.1%} of a core at {RATE:g} Hz"
    )


def main() -> None:
    # SIGTERM unwinds like Ctrl-C: the finally blocks stop the engines and close the Zenoh sessions.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(1))
    with tempfile.TemporaryDirectory() as tmp:
        config = str(Path(tmp) / "local.json5")
        Path(config).write_text(LOCAL_ONLY)
        publish_cost()
        latency(config)
        scaling(config)


if __name__ == "__main__":
    with recorded("bench_fleet", "Fleet on Zenoh: latency, publishing cost, engines per machine"):
        main()
