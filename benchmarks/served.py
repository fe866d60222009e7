"""A real `nutty serve` under the load of a user's session, measured from /api/status.

The load (what an editor user with a robot attached produces): the 3D Pre-Viz on with its page open
(a viser client), 4 editor telemetry clients subscribed to every node output at 30 Hz, one driver on
/ws/frames at 100 Hz (decimated from the engine rate), and an AI sending a command of the scripted AI
(tests/scripted_ai.py) every 0.5 s over REST. After a warm-up, `DELETE /api/profile` opens the
measurement window; at its end /api/status gives the clock's figures (tick cost and its CPU time,
period, lateness, overruns, lost ticks) and /api/profile the cook times.

Also `startup()`: seconds from launching `nutty serve` to the engine's first frame (the clock's
`started_at`), with numba's cache in a given folder (empty: cold, every kernel compiles).
"""

from __future__ import annotations

import asyncio
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx
import websockets

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import contextlib

import scripted_ai

HOST = "127.0.0.1"
TELEMETRY_CLIENTS = 4
TELEMETRY_HZ = 30
DRIVER_HZ = 100
AI_PERIOD = 0.5  # s between two commands of the scripted AI
OPEN_TIMEOUT = 60.0  # s: a WebSocket handshake on a busy machine
ATTEMPTS = 3


def free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


class Server:
    """`nutty serve` in a subprocess on free ports (stopped by `close`, killed if it will not stop)."""

    def __init__(self, *args: str, env: dict[str, str] | None = None):
        self.port, self.previz_port = free_port(), free_port()
        self.url = f"http://{HOST}:{self.port}"
        self.launched = time.time()
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "backend.cli",
                "serve",
                "--port",
                str(self.port),
                "--previz-port",
                str(self.previz_port),
                *args,
            ],
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.STDOUT,
            env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})},
        )

    def wait_ready(self, timeout: float = 300.0) -> dict[str, Any]:
        """The first /api/status once the server answers and its clock has ticked."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"nutty serve exited with {self.proc.returncode}")
            try:
                status = httpx.get(f"{self.url}/api/status", timeout=2.0).json()
                if status.get("started_at"):
                    return status
            except (httpx.HTTPError, ValueError):
                pass
            time.sleep(0.05)
        raise RuntimeError("nutty serve did not start")

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)


def startup(cache_dir: str | None) -> float:
    """Seconds from launching `nutty serve` (bundled robot and program, Pre-Viz on) to its first frame,
    with numba's cache in `cache_dir` (None: where numba keeps it by default)."""
    server = Server(env={"NUMBA_CACHE_DIR": cache_dir} if cache_dir else None)
    try:
        return server.wait_ready()["started_at"] - server.launched
    finally:
        server.close()


async def _read(ws: Any, stop: asyncio.Event, counts: dict, key: str) -> None:
    """Read messages until `stop`, counting them under `key`."""
    while not stop.is_set():
        try:
            await asyncio.wait_for(ws.recv(), 0.5)
            counts[key] += 1
        except TimeoutError:
            pass


async def _telemetry(url: str, signals: list[dict[str, str]], stop: asyncio.Event, counts: dict) -> None:
    async with websockets.connect(f"{url}/ws/telemetry", max_size=None, open_timeout=OPEN_TIMEOUT) as ws:
        await ws.send(
            json.dumps({"type": "subscribe", "signals": signals, "frames": True, "rate": TELEMETRY_HZ})
        )
        await _read(ws, stop, counts, "telemetry")


async def _driver(url: str, decimate: int, stop: asyncio.Event, counts: dict) -> None:
    async with websockets.connect(
        f"{url}/ws/frames?decimate={decimate}", max_size=None, open_timeout=OPEN_TIMEOUT
    ) as ws:
        await _read(ws, stop, counts, "frames")


async def _previz_page(port: int, stop: asyncio.Event, counts: dict) -> None:
    """What the Pre-Viz page in a browser does to the server: hold viser's WebSocket and read it. On a
    busy machine viser's own handshake can time out: the page connects again, as a browser would."""
    import viser

    while not stop.is_set():
        try:
            async with websockets.connect(
                f"ws://{HOST}:{port}",
                max_size=None,
                open_timeout=OPEN_TIMEOUT,
                subprotocols=[f"viser-v{viser.__version__}"],
            ) as ws:
                await _read(ws, stop, counts, "previz")
        except (OSError, websockets.exceptions.WebSocketException):
            counts["previz_reconnects"] += 1
            await asyncio.sleep(0.5)


async def _ai(http: httpx.AsyncClient, stop: asyncio.Event, counts: dict) -> None:
    script = list(scripted_ai.timeline(1e6))
    k = 0
    while not stop.is_set():
        r = await http.post("/api/commands", json=script[k % len(script)][1])
        counts["commands"] += r.status_code < 300
        k += 1
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(stop.wait(), AI_PERIOD)


#: The parts of the load (all of them by default): `measure(..., clients=...)` runs a subset.
CLIENTS = ("telemetry", "previz", "driver", "ai")


async def _beside(script: str, rate: float, seconds: float) -> asyncio.subprocess.Process:
    """benchmarks/`script` for `seconds` s at the clock's period, in a process of its own: Ruckig-25 woken
    in the window (peer_beside.py), or a bare sleep loop on every CPU (machine_stalls.py)."""
    return await asyncio.create_subprocess_exec(
        sys.executable,
        str(ROOT / "benchmarks" / script),
        f"{1.0 / rate!r}",
        f"{seconds!r}",
        cwd=ROOT,
        stdout=asyncio.subprocess.PIPE,
        env={**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{ROOT / 'benchmarks'}"},
    )


async def _joined(proc: asyncio.subprocess.Process | None, what: str) -> Any:
    """The JSON line `proc` printed once it ended (None for no process)."""
    if proc is None:
        return None
    out, _ = await proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"the {what} beside the server exited with {proc.returncode}")
    return json.loads(out)


async def _load(
    server: Server,
    rate: float,
    warm_up: float,
    seconds: float,
    clients: tuple[str, ...] = CLIENTS,
    peer_beside: bool = False,
    stalls_beside: bool = False,
) -> dict[str, Any]:
    ws_url = f"ws://{HOST}:{server.port}"
    counts = {"telemetry": 0, "frames": 0, "previz": 0, "previz_reconnects": 0, "commands": 0}
    async with httpx.AsyncClient(base_url=server.url, timeout=10.0) as http:
        program = (await http.get("/api/program")).json()["program"]
        blocks = {b["type"]: b for b in (await http.get("/api/blocks")).json()}
        signals = [
            {"node": n["id"], "port": p} for n in program["nodes"] for p in blocks[n["type"]]["outputs"]
        ]
        direct = (await http.get("/api/previz")).json()["direct"]
        previz_port = int(direct.rsplit(":", 1)[1]) if direct else 0  # viser's own (none with --no-previz)
        stop = asyncio.Event()
        tasks, names = [], []
        if "telemetry" in clients:
            tasks += [
                asyncio.create_task(_telemetry(ws_url, signals, stop, counts))
                for _ in range(TELEMETRY_CLIENTS)
            ]
            names += ["telemetry"] * TELEMETRY_CLIENTS
        if "driver" in clients:
            tasks.append(asyncio.create_task(_driver(ws_url, max(1, round(rate / DRIVER_HZ)), stop, counts)))
            names.append("driver")
        if "previz" in clients and previz_port:
            tasks.append(asyncio.create_task(_previz_page(previz_port, stop, counts)))
            names.append("previz page")
        if "ai" in clients:
            tasks.append(asyncio.create_task(_ai(http, stop, counts)))
            names.append("AI")
        await asyncio.sleep(warm_up)
        await http.delete("/api/profile")  # a new window for the tick statistics and cook times
        before = (await http.get("/api/status")).json()
        t0, opened = time.monotonic(), time.time()
        peer = await _beside("peer_beside.py", rate, seconds) if peer_beside else None
        watcher = await _beside("machine_stalls.py", rate, seconds) if stalls_beside else None
        await asyncio.sleep(seconds)
        after = (await http.get("/api/status")).json()
        profile = (await http.get("/api/profile")).json()
        elapsed = time.monotonic() - t0
        # their last updates may outlast the window: the load stays on until they end
        beside, stalls = await _joined(peer, "peer"), await _joined(watcher, "stall watcher")
        stop.set()
        failed = [
            (n, r)
            for n, r in zip(names, await asyncio.gather(*tasks, return_exceptions=True))
            if isinstance(r, BaseException)
        ]
        if failed:
            raise RuntimeError(f"the {failed[0][0]} client of the load failed: {failed[0][1]!r}")
    return {
        "rate": rate,
        "seconds": elapsed,
        "status": after,
        "profile": profile,
        "counts": counts,
        "peer_beside": beside,
        "machine_stalls": stalls,
        "window_overruns": [o for o in after.get("recent_overruns", ()) if o["at"] >= opened],
        "ticks": after["ticks"] - before["ticks"],
        "overruns": after["overruns"] - before["overruns"],
        "lost_ticks": after["lost_ticks"] - before["lost_ticks"],
    }


def measure(
    rate: float,
    seconds: float,
    warm_up: float = 4.0,
    program: str | None = None,
    clients: tuple[str, ...] = CLIENTS,
    server_args: tuple[str, ...] = (),
    peer_beside: bool = False,
    stalls_beside: bool = False,
) -> dict[str, Any]:
    """Serve the bundled robot (its interactive program unless `program`) at `rate` Hz under the load
    above (only the parts named in `clients`); the figures of a `seconds` window after `warm_up` seconds.
    `peer_beside`: also time Ruckig-25 woken at the clock's period in that window, in a process of its
    own (benchmarks/peer_beside.py), as `peer_beside` in the result (None otherwise). `stalls_beside`: also
    watch the machine's own stalls in that window (benchmarks/machine_stalls.py), as `machine_stalls`.
    `window_overruns`: the server's overruns in the window (/api/status `recent_overruns`, at most its last 32)."""
    args = ["--rate", f"{rate:g}", *server_args] + (["--program", program] if program else [])
    for attempt in range(ATTEMPTS):
        server = Server(*args)
        try:
            server.wait_ready()
            return asyncio.run(_load(server, rate, warm_up, seconds, clients, peer_beside, stalls_beside))
        except RuntimeError as exc:  # a busy shared machine: a port taken meanwhile, a handshake refused
            if attempt == ATTEMPTS - 1:
                raise
            print(f"  (served run at {rate:g} Hz failed: {exc}; again)", flush=True)
        finally:
            server.close()
    raise AssertionError("unreachable")
