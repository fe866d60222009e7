"""Soak: a real `nutty serve` at 100 Hz for N minutes under churning clients, then a SIGTERM.

Clients (all on 127.0.0.1, every loop bounded by the deadline and every operation by a timeout):
/ws/frames drivers that read a while and leave - politely, by aborting the TCP connection, or after
stalling without reading -; /ws/telemetry clients at random rates and signals; /ws/control clients
sending commands and some malformed messages; REST clients sending commands, status reads and a few
fuzzed bad requests (malformed JSON, NaN, oversized bodies, unknown types and routes).

Printed: ticks, overruns, lost ticks (from /api/status, estimated when the server has no counter),
frames lost to reading drivers (gaps in the seq numbers they received, beyond their decimation), tick cost, the server's RSS, thread and file-descriptor counts at the start and the end, the sinks
and client counts once the clients are gone (they should be back where they started), the 5xx count,
and how long the final SIGTERM took (the robot parks at rest first). Exit status 1 when the server
died, answered 5xx, leaked sinks or clients, or did not stop in time.

Run: .venv/bin/python benchmarks/soak.py [--minutes 1] [--rate 100] [--clients 8] [--seed 0]
     make soak [SOAK_MINUTES=1]
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import json
import os
import random
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import httpx
import websockets

HOST = "127.0.0.1"
OP_TIMEOUT = 10.0
CLIPS = ["wave", "nod", "shake", "happy", "sad", "surprised"]
POSTURES = ["neutral", "happy", "sad", "curious", "surprised", "sleepy"]


# --- the server process -----------------------------------------------------------------------------


def free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


def proc_stats(pid: int) -> dict[str, int]:
    """RSS (kB), threads and open file descriptors of a process (Linux /proc)."""
    out = {"rss_kb": -1, "threads": -1, "fds": -1}
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                out["rss_kb"] = int(line.split()[1])
            elif line.startswith("Threads:"):
                out["threads"] = int(line.split()[1])
        out["fds"] = len(os.listdir(f"/proc/{pid}/fd"))
    except OSError:
        pass
    return out


class Server:
    def __init__(self, args: list[str], port: int):
        self.port = port
        self.url = f"http://{HOST}:{port}"
        self.ws = f"ws://{HOST}:{port}"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "backend.cli", "serve", "--host", HOST, "--port", str(port), *args],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self.lines: list[str] = []
        threading.Thread(target=lambda: self.lines.extend(self.proc.stdout or []), daemon=True).start()

    def wait_ready(self, timeout: float = 180.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                break
            try:
                httpx.get(f"{self.url}/api/status", timeout=2.0).raise_for_status()
                return
            except httpx.HTTPError:
                time.sleep(0.3)
        self.proc.kill()
        raise SystemExit("nutty serve did not start:\n" + "".join(self.lines))

    def status(self) -> dict:
        return httpx.get(f"{self.url}/api/status", timeout=5.0).json()

    def stop(self, timeout: float) -> tuple[float | None, int | None]:
        t0 = time.monotonic()
        self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout)
            return time.monotonic() - t0, code
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)
            return None, None


# --- clients --------------------------------------------------------------------------------------------


class Tally:
    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()
        self.http: Counter[int] = Counter()
        self.errors: Counter[str] = Counter()

    def error(self, where: str, exc: BaseException) -> None:
        self.errors[f"{where}: {type(exc).__name__}"] += 1


def random_command(rng: random.Random) -> dict:
    kind = rng.choice(
        ["gaze", "gaze", "emotion", "clip", "posture", "led", "say", "input", "reset", "stop_all"]
    )
    if kind == "gaze":
        return {
            "type": "set_gaze",
            "target": [rng.uniform(0.2, 0.8), rng.uniform(-0.5, 0.5), rng.uniform(0.1, 0.6)],
        }
    if kind == "emotion":
        return {"type": "set_emotion", "valence": rng.uniform(-1, 1), "arousal": rng.uniform(-1, 1)}
    if kind == "clip":
        return {"type": "play_clip", "clip": rng.choice(CLIPS), "layer": "gesture"}
    if kind == "posture":
        return {"type": "go_posture", "posture": rng.choice(POSTURES), "duration": rng.uniform(0.3, 2.0)}
    if kind == "led":
        return {"type": "set_led", "colour": [rng.random(), rng.random(), rng.random()]}
    if kind == "say":
        return {"type": "say", "text": rng.choice(["Hello!", "Soak test.", "One more."])}
    if kind == "input":
        return {"type": "set_input", "name": "arousal", "value": rng.uniform(-1, 1)}
    if kind == "reset":
        return {"type": "reset", "fade": rng.uniform(0.0, 1.0)}
    return {"type": "stop_all"}


def bad_request(rng: random.Random) -> tuple[str, str, bytes | None]:
    """(method, path, raw body) of a request the server must refuse with a 4xx."""
    return rng.choice(
        [
            ("POST", "/api/commands", b'{"type": "set_gaze", "target": [1, 2]}'),
            ("POST", "/api/commands", b'{"type": "warp_drive"}'),
            ("POST", "/api/commands", b'{"type": "set_gaze", "target": [NaN, 0, 0]}'),
            ("POST", "/api/commands", b'{"type": "set_gaze", "target": [1e999, 0, 0]}'),
            ("POST", "/api/commands", b'{"type": '),
            ("POST", "/api/commands", b"[" * 5000 + b"]" * 5000),
            ("POST", "/api/commands", b"x" * 1_100_000),
            ("PUT", "/api/program", b'{"format": "nutty-program/1", "nodes": "many"}'),
            ("PATCH", "/api/program/nodes/no_such_node/params", b'{"gain": 1}'),
            ("PUT", "/api/inputs/arousal", b'{"value": "very"}'),
            ("GET", "/api/clips/..%2F..%2Fetc%2Fpasswd", None),
            ("DELETE", "/api/commands/not-a-command", None),
        ]
    )


async def rest_client(srv: Server, deadline: float, rng: random.Random, tally: Tally) -> None:
    async with httpx.AsyncClient(base_url=srv.url, timeout=OP_TIMEOUT) as http:
        while time.monotonic() < deadline:
            try:
                roll = rng.random()
                if roll < 0.5:
                    r = await http.post("/api/commands", json=random_command(rng))
                elif roll < 0.7:
                    r = await http.get("/api/status")
                else:
                    method, path, body = bad_request(rng)
                    r = await http.request(
                        method,
                        path,
                        content=body,
                        headers={"content-type": "application/json"} if body else None,
                    )
                    tally.counts["fuzzed requests"] += 1
                tally.http[r.status_code] += 1
            except (httpx.HTTPError, OSError) as exc:
                tally.error("rest", exc)
            await asyncio.sleep(rng.uniform(0.02, 0.2))


async def frames_client(srv: Server, deadline: float, rng: random.Random, tally: Tally) -> None:
    while time.monotonic() < deadline:
        style = rng.choice(["read", "read", "abort", "stall", "rst"])
        fmt = rng.choice(["json", "msgpack"])
        decimate = rng.randint(1, 5)
        url = f"{srv.ws}/ws/frames?format={fmt}&decimate={decimate}"
        try:
            if style == "rst":  # handshake on a bare socket, then a TCP reset: a crashed driver
                await asyncio.wait_for(asyncio.to_thread(raw_reset, srv.port, "/ws/frames"), OP_TIMEOUT)
            else:
                async with asyncio.timeout(OP_TIMEOUT + 3):
                    ws = await websockets.connect(
                        url, open_timeout=OP_TIMEOUT, close_timeout=1, max_size=None, max_queue=4
                    )
                    if style == "stall":  # stops reading for a while, then leaves
                        await asyncio.sleep(rng.uniform(0.5, 2.0))
                    else:
                        last = None
                        for _ in range(rng.randint(5, 200)):
                            seq = frame_seq(await ws.recv())
                            tally.counts["frames received"] += 1
                            if last is not None and seq - last > decimate:
                                tally.counts["frames lost to drivers"] += (seq - last) // decimate - 1
                            last = seq
                    if style == "abort":
                        ws.transport.abort()
                    else:
                        await ws.close()
            tally.counts[f"frames clients ({style})"] += 1
        except (TimeoutError, OSError, websockets.WebSocketException) as exc:
            tally.error(f"frames/{style}", exc)
        await asyncio.sleep(rng.uniform(0.0, 0.3))


def frame_seq(message: str | bytes) -> int:
    """The seq of a /ws/frames message (JSON text or msgpack bytes)."""
    if isinstance(message, bytes):
        import msgpack

        return int(msgpack.unpackb(message)["seq"])
    return int(json.loads(message)["seq"])


def raw_reset(port: int, path: str) -> None:
    s = socket.create_connection((HOST, port), timeout=OP_TIMEOUT)
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall(
        (
            f"GET {path} HTTP/1.1\r\nHost: {HOST}:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    s.recv(4096)
    time.sleep(0.1)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    s.close()


async def telemetry_client(
    srv: Server, deadline: float, rng: random.Random, tally: Tally, nodes: list[str]
) -> None:
    while time.monotonic() < deadline:
        try:
            async with asyncio.timeout(OP_TIMEOUT + 3):
                async with websockets.connect(
                    f"{srv.ws}/ws/telemetry", open_timeout=OP_TIMEOUT, close_timeout=1, max_size=None
                ) as ws:
                    picked = rng.sample(nodes, min(len(nodes), rng.randint(0, 4)))
                    signals = [{"node": n, "port": "out"} for n in picked]
                    rate = rng.choice([0.5, 5.0, 30.0, 60.0])
                    await ws.send(
                        json.dumps(
                            {
                                "type": "subscribe",
                                "signals": signals,
                                "frames": rng.random() < 0.7,
                                "rate": rate,
                            }
                        )
                    )
                    if rng.random() < 0.2:
                        await ws.send("{not json")
                    until = time.monotonic() + rng.uniform(0.3, 3.0)
                    while time.monotonic() < min(until, deadline):
                        try:
                            await asyncio.wait_for(ws.recv(), 2.5)
                            tally.counts["telemetry messages"] += 1
                        except TimeoutError:
                            break  # a very low rate: leave
            tally.counts["telemetry clients"] += 1
        except (TimeoutError, OSError, websockets.WebSocketException) as exc:
            tally.error("telemetry", exc)
        await asyncio.sleep(rng.uniform(0.0, 0.3))


async def control_client(srv: Server, deadline: float, rng: random.Random, tally: Tally) -> None:
    while time.monotonic() < deadline:
        try:
            async with asyncio.timeout(OP_TIMEOUT + 3):
                async with websockets.connect(
                    f"{srv.ws}/ws/control", open_timeout=OP_TIMEOUT, close_timeout=1
                ) as ws:
                    for _ in range(rng.randint(1, 15)):
                        if time.monotonic() >= deadline:
                            break
                        roll = rng.random()
                        if roll < 0.8:
                            await ws.send(json.dumps(random_command(rng)))
                        elif roll < 0.9:
                            await ws.send(
                                rng.choice(
                                    [
                                        '{"type": "set_gaze", "target": [NaN, 1, 2]}',
                                        "{oops",
                                        json.dumps({"type": "say", "text": "x" * 70_000}),
                                    ]
                                )
                            )
                            tally.counts["fuzzed messages"] += 1
                        else:
                            await ws.send(b"\x00\x01binary")
                            tally.counts["fuzzed messages"] += 1
                        await asyncio.wait_for(ws.recv(), OP_TIMEOUT)  # ack, error or event
                        tally.counts["control messages"] += 1
                        await asyncio.sleep(rng.uniform(0.01, 0.2))
            tally.counts["control clients"] += 1
        except (TimeoutError, OSError, websockets.WebSocketException) as exc:
            tally.error("control", exc)
        await asyncio.sleep(rng.uniform(0.0, 0.3))


async def churn(srv: Server, seconds: float, n: int, seed: int, tally: Tally, nodes: list[str]) -> None:
    deadline = time.monotonic() + seconds
    makers = [
        lambda r: frames_client(srv, deadline, r, tally),
        lambda r: telemetry_client(srv, deadline, r, tally, nodes),
        lambda r: control_client(srv, deadline, r, tally),
        lambda r: rest_client(srv, deadline, r, tally),
    ]
    tasks = [
        asyncio.create_task(makers[i % len(makers)](random.Random(seed * 1000 + i))) for i in range(max(4, n))
    ]
    done, pending = await asyncio.wait(tasks, timeout=seconds + 2 * OP_TIMEOUT)
    for t in pending:  # bounded: a client stuck past its timeouts is abandoned
        t.cancel()
        tally.errors["client task stuck"] += 1
    await asyncio.gather(*pending, return_exceptions=True)
    for t in done:
        if t.exception() is not None:
            tally.error("client task", t.exception())


# --- report -----------------------------------------------------------------------------------------------


def sink_names(status: dict) -> list[str]:
    return sorted(s.get("name", "?") for s in status.get("sinks", []))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=1.0, help="how long the clients churn (default 1)")
    ap.add_argument("--rate", type=float, default=100.0, help="engine rate in Hz (default 100)")
    ap.add_argument("--clients", type=int, default=8, help="concurrent client loops, at least 4 (default 8)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--shutdown-timeout", type=float, default=3.0)
    args = ap.parse_args()
    if not 0 < args.minutes <= 24 * 60:
        ap.error("--minutes must be within (0, 1440]")

    srv = Server(
        ["--no-previz", "--rate", f"{args.rate:g}", "--shutdown-timeout", f"{args.shutdown_timeout:g}"],
        free_port(),
    )
    srv.wait_ready()
    time.sleep(2.0)  # warm-up: kernels compiled, first clients' costs excluded
    s0, p0, t0 = srv.status(), proc_stats(srv.proc.pid), time.monotonic()
    try:
        prog = httpx.get(f"{srv.url}/api/program", timeout=5.0).json().get("program") or {}
        nodes = [n["id"] for n in prog.get("nodes", [])] or ["breathe"]
    except (httpx.HTTPError, ValueError):
        nodes = ["breathe"]
    print(
        f"soak: nutty serve pid {srv.proc.pid} at {args.rate:g} Hz, {args.clients} client loops, "
        f"{args.minutes:g} min (seed {args.seed})",
        flush=True,
    )

    tally = Tally()
    asyncio.run(churn(srv, args.minutes * 60.0, args.clients, args.seed, tally, nodes))
    alive = srv.proc.poll() is None
    time.sleep(2.0)  # let the server notice the last departures
    s1 = srv.status() if alive else {}
    elapsed = time.monotonic() - t0
    p1 = proc_stats(srv.proc.pid)

    ticks = s1.get("ticks", 0) - s0.get("ticks", 0)
    expected = elapsed * args.rate
    if "lost_ticks" in s1:
        lost, how = s1["lost_ticks"] - s0.get("lost_ticks", 0), "counted"
    else:
        lost, how = max(0, round(expected - ticks)), "estimated"
    print(
        f"\nengine  ticks {ticks} in {elapsed:.1f} s ({ticks / max(elapsed, 1e-9):.1f} Hz), "
        f"overruns {s1.get('overruns', 0) - s0.get('overruns', 0)}, lost ticks {lost} ({how})"
    )
    cost = s1.get("tick_cost", {})
    print(
        f"        tick cost p50 {cost.get('p50_ms', 0):.3f} ms, p99 {cost.get('p99_ms', 0):.3f} ms, "
        f"max {cost.get('max_ms', 0):.3f} ms; period p99 {s1.get('period', {}).get('p99_ms', 0):.2f} ms"
    )
    print(
        f"process RSS {p0['rss_kb'] / 1024:.1f} -> {p1['rss_kb'] / 1024:.1f} MB, threads {p0['threads']} -> "
        f"{p1['threads']}, fds {p0['fds']} -> {p1['fds']}"
    )
    sinks0, sinks1 = sink_names(s0), sink_names(s1)
    print(f"sinks   start {len(sinks0)} {sinks0}\n        end   {len(sinks1)} {sinks1}")
    print(f"clients start {s0.get('clients')}\n        end   {s1.get('clients')}")
    print("traffic " + ", ".join(f"{k} {v}" for k, v in sorted(tally.counts.items())))
    got, lost_frames = tally.counts["frames received"], tally.counts["frames lost to drivers"]
    print(
        f"drivers lost {lost_frames} frames next to {got} received ({lost_frames / max(got + lost_frames, 1):.1%}; "
        "the process test once allowed 20 %)"
    )
    print("http    " + ", ".join(f"{k}: {v}" for k, v in sorted(tally.http.items())))
    if tally.errors:
        print("client-side errors " + ", ".join(f"{k} x{v}" for k, v in sorted(tally.errors.items())))

    took, code = srv.stop(args.shutdown_timeout + 10) if alive else (None, srv.proc.returncode)
    said = [ln.rstrip() for ln in srv.lines if ln.startswith("nutty:")]
    print(
        f"SIGTERM exit {f'{took:.2f} s' if took is not None else 'TIMED OUT'}, status {code}"
        + (f"  ({said[-1]})" if said else "")
    )

    problems = []
    if not alive:
        problems.append(f"the server died during the soak (status {srv.proc.returncode})")
    if sum(v for k, v in tally.http.items() if k >= 500):
        problems.append("5xx answers")
    if len(sinks1) > len(sinks0) or any(n.startswith("ws-") for n in sinks1):
        problems.append("sinks outlived their clients")
    if alive and any(v for v in (s1.get("clients") or {}).values()):
        problems.append("client counts did not return to zero")
    if took is None or took > args.shutdown_timeout + 5:
        problems.append("shutdown took too long")
    if problems:
        print("\nsoak: FAIL: " + "; ".join(problems))
        tail = "".join(srv.lines[-30:])
        if tail:
            print("server output (tail):\n" + tail)
        return 1
    print("\nsoak: ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
