"""The HTTP and WebSocket API (FastAPI): AIs and the editor drive a running engine through it.

`create_app(session, ...)` builds the app around an EngineSession (tests use it without ports);
`nutty serve` runs it with uvicorn next to the engine clock and the viser Pre-Viz. The contract the
editor relies on is docs/api-contract.md; OpenAPI is served at /docs.

Safety: every request body and WebSocket message has a size limit; NaN/inf are rejected; a bad
request gets a 4xx naming the field and changes nothing; with a token, every mutating route and
every WebSocket needs it.
"""

from __future__ import annotations

import asyncio
import json
import math
import secrets
import threading
import time
import uuid
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np
from fastapi import APIRouter, Body, Depends, FastAPI, HTTPException, Request, WebSocket, WebSocketDisconnect
from fastapi.middleware.cors import CORSMiddleware
from fastapi.responses import HTMLResponse, JSONResponse, PlainTextResponse
from pydantic import BaseModel

from backend import control
from backend.engine.blocks import BLOCKS, block_catalog
from backend.engine.frames import AnimationFrame, PartialFrame
from backend.engine.library import LibraryError, NotFound
from backend.engine.runtime import Sink
from backend.graph.schema import program_json_schema
from backend.session import EngineSession, SessionError

MAX_BODY = 1_000_000  # bytes per request
MAX_WS_MESSAGE = 64_000  # bytes per WebSocket message
TELEMETRY_MAX_HZ = 60.0
FRONTEND_DIST = Path(__file__).resolve().parents[1] / "frontend" / "dist"


def _error(status: int, code: str, message: str, **extra: Any) -> HTTPException:
    return HTTPException(status_code=status, detail={"code": code, "message": message, **extra})


def _finite(value: Any, path: str = "") -> None:
    if isinstance(value, float) and not math.isfinite(value):
        raise _error(422, "non_finite", f"{path or 'value'}: NaN and infinity are not allowed", field=path or None)
    if isinstance(value, dict):
        for k, v in value.items():
            _finite(v, f"{path}.{k}" if path else str(k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _finite(v, f"{path}[{i}]")


def _loads(raw: bytes | str) -> Any:
    """JSON with NaN/Infinity refused (Python's json accepts them by default)."""

    def bad_constant(name: str) -> Any:
        raise ValueError(f"{name} is not allowed")

    return json.loads(raw, parse_constant=bad_constant)


class InputValue(BaseModel):
    """Body of PUT /api/inputs/{name}."""

    value: Any


class GhostToggle(BaseModel):
    """Body of PUT /api/previz/ghost."""

    visible: bool


class CommandLog:
    """Commands by id with their status, for GET /api/commands/{id} and cancellation."""

    def __init__(self, size: int = 500):
        self._items: dict[str, dict[str, Any]] = {}
        self._order: deque[str] = deque()
        self._size = size
        self._lock = threading.Lock()

    def add(self, cid: str, command: Any) -> dict[str, Any]:
        entry = {"id": cid, "type": command.type, "status": "accepted", "created": time.time(), "result": None}
        with self._lock:
            self._items[cid] = entry
            self._order.append(cid)
            while len(self._order) > self._size:
                self._items.pop(self._order.popleft(), None)
        return entry

    def get(self, cid: str) -> dict[str, Any] | None:
        return self._items.get(cid)

    def update(self, cid: str | None, **fields: Any) -> None:
        if cid and cid in self._items:
            self._items[cid].update(fields)


class Hub:
    """Shared server state: the session, connected clients, the event fan-out to /ws/control."""

    def __init__(self, session: EngineSession, token: str | None, previz: Any = None):
        self.session = session
        self.token = token
        self.previz = previz
        self.commands = CommandLog()
        self.clients = {"control": 0, "telemetry": 0, "frames": 0}
        self._control_queues: set[asyncio.Queue] = set()
        self.loop: asyncio.AbstractEventLoop | None = None
        session.on_note(self._on_note)

    def _on_note(self, note: dict[str, Any]) -> None:
        """Block notifications arrive on the clock thread: record them and hand them to the event loop."""
        cid = note.get("command_id")
        event = note.get("event")
        if event in ("started", "completed", "cancelled", "failed"):
            self.commands.update(cid, status=event)
        self.broadcast({"type": "event", **{k: v for k, v in note.items() if _jsonable(v)}})

    def broadcast(self, message: dict[str, Any]) -> None:
        loop = self.loop
        if loop is None or loop.is_closed():
            return
        for q in list(self._control_queues):
            loop.call_soon_threadsafe(_put_drop_oldest, q, message)

    def run_command(self, data: Any) -> dict[str, Any]:
        """Validate and execute one command; returns the ack. Raises HTTPException (4xx) on error."""
        try:
            cmd = control.parse_command(data)
        except control.CommandError as exc:
            raise _error(422, exc.code, str(exc), field=exc.field) from exc
        cid = cmd.id or uuid.uuid4().hex[:12]
        if cmd.type == "cancel":
            entry = self.commands.get(cmd.target)
            if entry is None:
                raise _error(404, "unknown_command", f"no command with id '{cmd.target}'", field="target")
            return self.cancel(cmd.target)
        entry = self.commands.add(cid, cmd)
        try:
            result = control.execute(self.session, cmd, cid)
        except control.CommandError as exc:
            self.commands.update(cid, status="failed", result=str(exc))
            status = 404 if exc.code == "no_target" else 422
            raise _error(status, exc.code, str(exc), field=exc.field, id=cid) from exc
        except (ValueError, TimeoutError) as exc:
            self.commands.update(cid, status="failed", result=str(exc))
            raise _error(422, "rejected", str(exc), id=cid) from exc
        done = isinstance(result, dict) and result.get("done")
        status = "started" if cmd.type in control.LONG_ACTIONS and not done else "completed"
        if entry["status"] == "accepted":
            entry["status"] = status
        entry["result"] = result if _jsonable(result) else None
        self.broadcast({"type": "event", "event": entry["status"], "id": cid, "command": cmd.type})
        return {"id": cid, "status": entry["status"], "result": entry["result"]}

    def cancel(self, cid: str) -> dict[str, Any]:
        entry = self.commands.get(cid)
        if entry is None:
            raise _error(404, "unknown_command", f"no command with id '{cid}'")
        if entry["status"] in ("completed", "cancelled", "failed"):
            return {"id": cid, "status": entry["status"]}
        kinds = {"play_clip": ("clip_player",), "go_posture": ("posture",), "say": ("say",)}.get(entry["type"], ())
        if kinds:
            for block in control._blocks(self.session, kinds):
                try:
                    self.session.engine.call(lambda b=block: b.handle("stop", {"command_id": cid}))
                except Exception:  # a block that cannot stop is reported through its status
                    pass
        entry["status"] = "cancelled"
        self.broadcast({"type": "event", "event": "cancelled", "id": cid, "command": entry["type"]})
        return {"id": cid, "status": "cancelled"}


def _put_drop_oldest(q: asyncio.Queue, item: Any) -> None:
    if q.full():
        try:
            q.get_nowait()
        except asyncio.QueueEmpty:
            pass
    q.put_nowait(item)


def _jsonable(v: Any) -> bool:
    return isinstance(v, (str, int, float, bool, type(None), list, dict))


def _signal_json(emb, value: Any) -> Any:
    """A node output as JSON: frames as their set channels, arrays as lists."""
    if isinstance(value, PartialFrame):
        idx = np.flatnonzero(value.mask)
        return {"mask": int(idx.size), "values": {emb.channel_names[i]: round(float(value.values[i]), 5) for i in idx}}
    if isinstance(value, np.ndarray):
        return [float(x) for x in value.ravel()[:16]]
    if isinstance(value, (np.floating, np.integer)):
        return float(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value if _jsonable(value) else str(value)


def _limit_classes(emb, frame: AnimationFrame) -> dict[str, int]:
    """The trajectory-helper's class of this frame per continuous channel that breaks a limit
    (1 velocity, 2 acceleration, 3 jerk), from the frame's exact finite differences; ok omitted."""
    slack = 1.0 + 1e-9
    codes = np.zeros(emb.n_channels, dtype=np.int8)
    codes[np.abs(frame.velocity) > emb.vel_limit * slack] = 1
    codes[np.abs(frame.acceleration) > emb.acc_limit * slack] = 2
    codes[np.abs(frame.jerk) > emb.jerk_limit * slack] = 3
    codes[~emb.continuous_mask] = 0
    return {emb.channel_names[i]: int(codes[i]) for i in np.flatnonzero(codes)}


def _frame_channels(emb, values: np.ndarray) -> dict[str, float]:
    return {name: round(float(values[i]), 5) for i, name in enumerate(emb.channel_names)}


# --------------------------------------------------------------------------------------------------


def create_app(session: EngineSession, *, token: str | None = None, previz: Any = None,
               origins: list[str] | None = None, frontend_dir: Path | None = FRONTEND_DIST) -> FastAPI:
    app = FastAPI(title="Nutty", version="0.1.0",
                  description="Robot animation engine: Animation Programs, commands, telemetry and frames.")
    hub = Hub(session, token, previz)
    app.state.hub = hub
    if origins:
        app.add_middleware(CORSMiddleware, allow_origins=origins, allow_methods=["*"], allow_headers=["*"])

    @app.middleware("http")
    async def limit_body(request: Request, call_next):
        length = request.headers.get("content-length")
        if length is not None and length.isdigit() and int(length) > MAX_BODY:
            return JSONResponse({"detail": {"code": "too_large", "message": f"request body over {MAX_BODY} bytes"}},
                                status_code=413)
        return await call_next(request)

    def authorise(request: Request) -> None:
        if hub.token is None:
            return
        header = request.headers.get("authorization", "")
        supplied = header[7:] if header.lower().startswith("bearer ") else request.query_params.get("token", "")
        if not secrets.compare_digest(supplied.encode(), hub.token.encode()):
            raise _error(401, "unauthorized", "this server needs 'Authorization: Bearer <token>'")

    async def json_body(request: Request) -> Any:
        raw = await request.body()
        if len(raw) > MAX_BODY:
            raise _error(413, "too_large", f"request body over {MAX_BODY} bytes")
        try:
            return _loads(raw or b"null")
        except ValueError as exc:
            raise _error(400, "malformed_json", f"malformed JSON: {exc}") from exc

    mutating = [Depends(authorise)]
    api = APIRouter(prefix="/api")

    # --- robot and blocks ------------------------------------------------------------------------------
    @api.get("/robot", summary="The robot's embodiment and kinematronics table")
    def robot() -> dict[str, Any]:
        return {**session.embodiment.to_dict(), "urdf": "/api/robot/urdf"}

    @api.get("/robot/urdf", response_class=PlainTextResponse, summary="The robot's URDF")
    def robot_urdf() -> str:
        if session.embodiment.urdf_path is None:
            raise _error(404, "no_urdf", "this robot has no URDF file")
        return session.embodiment.urdf_path.read_text()

    @api.get("/blocks", summary="Every block type with its parameter JSON Schema, ports, category and doc")
    def blocks() -> list[dict[str, Any]]:
        return block_catalog()

    @api.post("/blocks/{type_name}/ports", summary="Ports of a block for given parameters (dynamic ports)")
    async def block_ports(type_name: str, request: Request) -> dict[str, Any]:
        cls = BLOCKS.get(type_name)
        if cls is None:
            raise _error(404, "unknown_block_type", f"unknown block type '{type_name}'")
        body = await json_body(request)
        params = (body or {}).get("params", {}) if isinstance(body, dict) else {}
        try:
            p = cls.Params.model_validate(params)
        except Exception as exc:
            raise _error(422, "invalid_param", str(exc)) from exc
        ins, outs = cls.ports(p)
        return {"inputs": {k: v.to_dict() for k, v in ins.items()}, "outputs": {k: v.to_dict() for k, v in outs.items()}}

    @api.get("/schema/program", summary="JSON Schema of the program document")
    def schema_program() -> dict[str, Any]:
        return program_json_schema()

    @api.get("/schema/commands", summary="JSON Schema of the command union")
    def schema_commands() -> dict[str, Any]:
        return control.command_json_schema()

    # --- the running program -----------------------------------------------------------------------------
    @api.get("/program", summary="The running program, its validation report and APU level")
    def get_program() -> dict[str, Any]:
        from backend.graph.roundtrip import apu_to_program

        prog = None
        if session.engine.apu is not None and session.program is not None:
            prog = apu_to_program(session.engine.apu).to_json_dict()
        return {"program": prog, "report": session.report.model_dump() if session.report else None,
                "level": session.engine.apu.level if session.engine.apu else None}

    @api.post("/program/validate", summary="Validate a program (200 with the report, valid or not)")
    async def validate_program(request: Request) -> dict[str, Any]:
        return session.validate(await json_body(request)).model_dump()

    @api.put("/program", dependencies=mutating, summary="Validate and hot-swap a program (atomic)")
    async def put_program(request: Request) -> dict[str, Any]:
        doc = await json_body(request)
        try:
            report, kept = await asyncio.to_thread(session.load_program, doc)
        except SessionError as exc:
            raise _error(422, "invalid_program", str(exc),
                         report=exc.report.model_dump() if exc.report else None) from exc
        return {"report": report.model_dump(), "kept": kept}

    @api.patch("/program/nodes/{node_id}/params", dependencies=mutating,
               summary="Change one node's parameters live, without rebuilding the program")
    async def patch_params(node_id: str, request: Request) -> dict[str, Any]:
        body = await json_body(request)
        if not isinstance(body, dict):
            raise _error(422, "invalid_param", "the body is an object of parameter name -> value")
        _finite(body)
        try:
            params = await asyncio.to_thread(session.update_params, node_id, body)
        except SessionError as exc:
            status = 404 if exc.code in ("unknown_node", "no_program") else 422
            raise _error(status, exc.code, str(exc),
                         report=exc.report.model_dump() if exc.report else None) from exc
        return {"params": params}

    # --- library: programs, clips, postures ---------------------------------------------------------------
    def library_routes(kind: str, validate_program: bool = False) -> None:
        @api.get(f"/{kind}", summary=f"Names of the robot's {kind}")
        def list_items() -> list[str]:
            return session.library.list(kind)

        @api.get(f"/{kind}/{{name}}", summary=f"One of the robot's {kind}")
        def get_item(name: str) -> dict[str, Any]:
            try:
                return session.library.get(kind, name)
            except NotFound as exc:
                raise _error(404, "not_found", str(exc)) from exc
            except LibraryError as exc:
                raise _error(422, "invalid_name", str(exc)) from exc

        @api.put(f"/{kind}/{{name}}", dependencies=mutating, summary=f"Save one of the robot's {kind}")
        async def put_item(name: str, request: Request) -> dict[str, Any]:
            doc = await json_body(request)
            if not isinstance(doc, dict):
                raise _error(422, "invalid_document", f"a {kind[:-1]} is a JSON object")
            _finite(doc)
            if validate_program:
                report = session.validate(doc)
                if not report.valid:
                    raise _error(422, "invalid_program", "program is invalid", report=report.model_dump())
            try:
                session.library.save(kind, name, doc)
            except LibraryError as exc:
                raise _error(422, "invalid_document", str(exc)) from exc
            return {"saved": name}

        @api.delete(f"/{kind}/{{name}}", dependencies=mutating, summary=f"Delete one of the robot's {kind}")
        def delete_item(name: str) -> dict[str, Any]:
            try:
                session.library.delete(kind, name)
            except NotFound as exc:
                raise _error(404, "not_found", str(exc)) from exc
            except LibraryError as exc:
                raise _error(422, "invalid_name", str(exc)) from exc
            return {"deleted": name}

    library_routes("programs", validate_program=True)
    library_routes("clips")
    library_routes("postures")

    # --- inputs and commands ----------------------------------------------------------------------------------
    @api.get("/inputs", summary="Exposed inputs of the running program: values and declarations")
    def get_inputs() -> dict[str, Any]:
        decls = [i.model_dump() for i in session.program.inputs] if session.program else []
        return {"values": {k: _signal_json(session.embodiment, v) for k, v in session.inputs().items()},
                "declarations": decls}

    @api.put("/inputs/{name}", dependencies=mutating, summary="Set one exposed input")
    def put_input(name: str, body: InputValue = Body(...)) -> dict[str, Any]:
        _finite(body.value, name)
        try:
            return {"name": name, "value": session.set_input(name, body.value)}
        except ValueError as exc:
            raise _error(422, "invalid_input", str(exc), field=name) from exc

    @api.post("/commands", dependencies=mutating, summary="Run a command (one typed union; see /api/schema/commands)")
    async def post_command(request: Request) -> dict[str, Any]:
        data = await json_body(request)
        return await asyncio.to_thread(hub.run_command, data)

    @api.get("/commands/{cid}", summary="A command's status")
    def get_command(cid: str) -> dict[str, Any]:
        entry = hub.commands.get(cid)
        if entry is None:
            raise _error(404, "unknown_command", f"no command with id '{cid}'")
        return entry

    @api.delete("/commands/{cid}", dependencies=mutating, summary="Cancel a long action")
    def cancel_command(cid: str) -> dict[str, Any]:
        return hub.cancel(cid)

    # --- status and pre-viz -------------------------------------------------------------------------------------
    @api.get("/status", summary="Tick statistics, APU level, drivers with drop counts, clients")
    def status() -> dict[str, Any]:
        stats = session.engine.stats()
        stats["clients"] = dict(hub.clients)
        stats["program"] = session.program.name if session.program else None
        stats["previz"] = {"url": hub.previz.url(), "frames_shown": hub.previz.frames_shown,
                           "ghost": hub.previz.ghost_visible} if hub.previz else None
        return stats

    @api.get("/previz", summary="Where the 3D Pre-Viz is served")
    def previz_info(request: Request) -> dict[str, Any]:
        if hub.previz is None:
            return {"url": None, "ghost": None}
        host = request.url.hostname or hub.previz.host
        return {"url": hub.previz.url(host), "ghost": hub.previz.ghost_visible}

    @api.put("/previz/ghost", dependencies=mutating, summary="Show or hide the ghost (stage-1 pose)")
    def previz_ghost(body: GhostToggle) -> dict[str, Any]:
        if hub.previz is None:
            raise _error(404, "no_previz", "this server runs without a Pre-Viz")
        hub.previz.set_ghost(body.visible)
        return {"ghost": body.visible}

    app.include_router(api)

    # --- WebSockets ------------------------------------------------------------------------------------------------
    async def ws_accept(ws: WebSocket, kind: str) -> bool:
        if hub.token is not None and not secrets.compare_digest(
                ws.query_params.get("token", "").encode(), hub.token.encode()):
            await ws.close(code=4401, reason="unauthorized: add ?token=<token>")
            return False
        await ws.accept()
        hub.clients[kind] += 1
        hub.loop = asyncio.get_running_loop()
        return True

    async def ws_messages(ws: WebSocket):
        """Parsed JSON messages of a client; malformed or oversized ones are answered with an error."""
        while True:
            raw = await ws.receive_text()
            try:
                if len(raw) > MAX_WS_MESSAGE:
                    raise ValueError(f"message over {MAX_WS_MESSAGE} bytes")
                data = _loads(raw)
            except ValueError as exc:
                await ws.send_json({"type": "error", "code": "malformed_json", "message": str(exc)})
                continue
            yield data

    @app.websocket("/ws/control")
    async def ws_control(ws: WebSocket) -> None:
        if not await ws_accept(ws, "control"):
            return
        queue: asyncio.Queue = asyncio.Queue(maxsize=256)
        hub._control_queues.add(queue)

        async def pump() -> None:
            while True:
                await ws.send_json(await queue.get())

        sender = asyncio.create_task(pump())
        try:
            async for data in ws_messages(ws):
                cid = data.get("id") if isinstance(data, dict) else None
                try:
                    ack = await asyncio.to_thread(hub.run_command, data)
                    await ws.send_json({"type": "ack", **ack})
                except HTTPException as exc:
                    await ws.send_json({"type": "error", "id": cid, **exc.detail})
        except WebSocketDisconnect:
            pass
        finally:
            sender.cancel()
            hub._control_queues.discard(queue)
            hub.clients["control"] -= 1

    @app.websocket("/ws/telemetry")
    async def ws_telemetry(ws: WebSocket) -> None:
        if not await ws_accept(ws, "telemetry"):
            return
        sub = {"signals": [], "frames": True, "rate": 30.0}
        emb = session.embodiment

        async def receive() -> None:
            async for data in ws_messages(ws):
                if not isinstance(data, dict) or data.get("type") != "subscribe":
                    await ws.send_json({"type": "error", "code": "invalid_message",
                                        "message": "send {'type': 'subscribe', 'signals': [...], 'frames': bool, 'rate': Hz}"})
                    continue
                signals = data.get("signals", [])
                if not isinstance(signals, list) or not all(isinstance(s, dict) and "node" in s and "port" in s
                                                            for s in signals):
                    await ws.send_json({"type": "error", "code": "invalid_message", "field": "signals",
                                        "message": "signals is a list of {node, port}"})
                    continue
                rate = data.get("rate", 30.0)
                if not isinstance(rate, (int, float)) or not 0 < rate <= TELEMETRY_MAX_HZ:
                    await ws.send_json({"type": "error", "code": "invalid_message", "field": "rate",
                                        "message": f"rate must be within (0, {TELEMETRY_MAX_HZ:g}] Hz"})
                    continue
                sub.update(signals=signals[:200], frames=bool(data.get("frames", True)), rate=float(rate))
                await ws.send_json({"type": "subscribed", "signals": len(sub["signals"]), "rate": sub["rate"]})

        receiver = asyncio.create_task(receive())
        last_seq = -1
        try:
            while not receiver.done():
                await asyncio.sleep(1.0 / sub["rate"])
                frame = session.engine.last_frame
                if frame is None or frame.seq == last_seq:
                    continue
                last_seq = frame.seq
                apu = session.engine.apu
                msg: dict[str, Any] = {"type": "telemetry", "t": frame.t, "seq": frame.seq}
                if apu is not None and sub["signals"]:
                    msg["signals"] = {f"{s['node']}.{s['port']}": _signal_json(emb, apu.signal_value(s["node"], s["port"]))
                                      for s in sub["signals"]}
                if sub["frames"]:
                    msg["frame"] = {"position": _frame_channels(emb, frame.position),
                                    "stage1": _frame_channels(emb, frame.stage1 if frame.stage1 is not None else frame.position),
                                    "classes": _limit_classes(emb, frame)}
                if apu is not None:
                    msg["layers"] = {s.node_id: s.block.layer_states() for s in apu.steps
                                     if hasattr(s.block, "layer_states")}
                await ws.send_json(msg)  # a slow client only slows its own loop: it is decimated
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            receiver.cancel()
            hub.clients["telemetry"] -= 1

    @app.websocket("/ws/frames")
    async def ws_frames(ws: WebSocket) -> None:
        fmt = ws.query_params.get("format", "json")
        try:
            decimate = int(ws.query_params.get("decimate", "1"))
        except ValueError:
            decimate = 0
        if fmt not in ("json", "msgpack") or decimate < 1:
            await ws.close(code=4400, reason="format must be json|msgpack and decimate a positive integer")
            return
        if not await ws_accept(ws, "frames"):
            return
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue = asyncio.Queue(maxsize=64)
        emb = session.embodiment
        sink = Sink(f"ws-frames-{id(ws):x}", lambda f: loop.call_soon_threadsafe(_put_drop_oldest, queue, f),
                    max_queue=64, decimate=decimate)
        session.engine.add_sink(sink)
        try:
            import msgpack

            while True:
                frame: AnimationFrame = await queue.get()
                doc = frame.to_dict(emb)
                if fmt == "json":
                    await ws.send_json(doc)
                else:
                    await ws.send_bytes(msgpack.packb(doc))
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            session.engine.remove_sink(sink)
            hub.clients["frames"] -= 1

    # --- the editor ------------------------------------------------------------------------------------------------------
    if frontend_dir is not None and (frontend_dir / "index.html").exists():
        from fastapi.staticfiles import StaticFiles

        app.mount("/", StaticFiles(directory=str(frontend_dir), html=True), name="editor")
    else:
        @app.get("/", response_class=HTMLResponse, include_in_schema=False)
        def index() -> str:
            previz = hub.previz.url() if hub.previz else None
            link = f'<li><a href="{previz}">3D Pre-Viz</a></li>' if previz else ""
            return (f"<!doctype html><title>Nutty</title><h1>Nutty is running</h1>"
                    f"<p>Robot <b>{session.embodiment.name}</b>, program <b>{session.program.name if session.program else '-'}</b>."
                    f" The editor is not built (run <code>make run</code>).</p>"
                    f"<ul><li><a href='/docs'>API (OpenAPI)</a></li>{link}</ul>")

    return app
