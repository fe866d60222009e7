"""The HTTP and WebSocket API (FastAPI): AIs and the editor drive a running engine through it.

`create_app(session, ...)` builds the app around an EngineSession (tests use it without ports);
`nutty serve` runs it with uvicorn next to the engine clock and the viser Pre-Viz. The contract the
editor relies on is docs/api-contract.md; OpenAPI is served at /docs.

Safety (the rules live in `backend.security`, enforced once by its ASGI `Guard`): mutating routes and
WebSocket handshakes need an allowed Origin (when a browser sends one) and Host, and the token when
there is one; JSON bodies must be declared `application/json`, are counted as they stream in and
parsed with depth, size, NaN/inf and Unicode limits; a bad request gets a 4xx naming the field and
changes nothing; an unexpected error is a JSON 500 without a traceback and never closes a socket.
Every WebSocket handler races its send loop against the client's disconnect and the app's shutdown,
so no thread, sink or client count outlives its client. The Pre-Viz is proxied at /previz/ behind
the same guard and token.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
import uuid
from collections import deque
from pathlib import Path
from typing import Any, Awaitable, Callable

import numpy as np
from fastapi import APIRouter, FastAPI, HTTPException, Request, WebSocket
from fastapi.exceptions import RequestValidationError
from fastapi.middleware.cors import CORSMiddleware
from fastapi.responses import HTMLResponse, JSONResponse, PlainTextResponse, RedirectResponse, Response
from pydantic import BaseModel, ValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException

from backend import control, security
from backend.engine.blocks import BLOCKS, block_catalog
from backend.engine.frames import AnimationFrame, PartialFrame
from backend.engine.library import LibraryError, NotFound
from backend.engine.runtime import Sink
from backend.graph.schema import program_json_schema
from backend.security import MAX_BODY, MAX_WS_MESSAGE, JsonSafetyError
from backend.security import cancel_all as _cancel_all
from backend.session import EngineSession, SessionError

TELEMETRY_MAX_HZ = 60.0
FRONTEND_DIST = Path(__file__).resolve().parents[1] / "frontend" / "dist"
TERMINAL = ("completed", "cancelled", "failed")
CANCELLABLE = {"play_clip": ("clip_player",), "go_posture": ("posture",), "say": ("say",)}


def _error(status: int, code: str, message: str, **extra: Any) -> HTTPException:
    return HTTPException(status_code=status, detail={"code": code, "message": security.safe_text(message), **extra})


class SafeJSONResponse(JSONResponse):
    """JSON that always renders: NaN and lone surrogates are sanitised instead of raising (a 500)."""

    def render(self, content: Any) -> bytes:
        return security.dumps(content).encode("utf-8")


class InputValue(BaseModel):
    """Body of PUT /api/inputs/{name}."""

    value: Any


class GhostToggle(BaseModel):
    """Body of PUT /api/previz/ghost."""

    visible: bool


def _validate_model(model: type[BaseModel], body: Any) -> Any:
    """A body checked against a small model: 422 naming the field, never echoing the input."""
    try:
        return model.model_validate(body)
    except ValidationError as exc:
        err = exc.errors()[0]
        field = ".".join(str(x) for x in err["loc"]) or None
        raise _error(422, "invalid_body", f"{field or 'body'}: {err['msg']}", field=field) from exc


def _body_doc(schema: dict[str, Any]) -> dict[str, Any]:
    return {"requestBody": {"required": True, "content": {"application/json": {"schema": schema}}}}


class CommandLog:
    """Commands by id with their status, for GET /api/commands/{id}, cancellation and the event
    stream: each command gets at most one `started` and one terminal event (completed, cancelled
    or failed), and nothing after its terminal event."""

    def __init__(self, size: int = 500):
        self._items: dict[str, dict[str, Any]] = {}
        self._flags: dict[str, list[bool]] = {}  # id -> [started sent, terminal sent]
        self._order: deque[str] = deque()
        self._size = size
        self._lock = threading.Lock()

    def add(self, cid: str, command: Any) -> dict[str, Any]:
        """Log a new command; a live command with the same id is a conflict (409)."""
        entry = {"id": cid, "type": command.type, "status": "accepted", "created": time.time(), "result": None}
        with self._lock:
            old = self._items.get(cid)
            if old is not None and old["status"] not in TERMINAL:
                raise _error(409, "duplicate_id", f"command '{cid}' is still {old['status']}: choose another id",
                             field="id", id=cid)
            if old is not None:
                self._order.remove(cid)
            self._items[cid] = entry
            self._flags[cid] = [False, False]
            self._order.append(cid)
            while len(self._order) > self._size:
                gone = self._order.popleft()
                self._items.pop(gone, None)
                self._flags.pop(gone, None)
        return entry

    def get(self, cid: Any) -> dict[str, Any] | None:
        return self._items.get(cid) if isinstance(cid, str) else None

    def update(self, cid: str | None, **fields: Any) -> None:
        with self._lock:
            if cid and cid in self._items:
                self._items[cid].update(fields)

    def transition(self, cid: str | None, event: str | None) -> tuple[bool, str | None]:
        """Whether an event for command `cid` may go out, and the command's type (None if unknown)."""
        with self._lock:
            entry = self._items.get(cid) if cid else None
            if entry is None:
                return True, None
            flags = self._flags[cid]
            if event == "started":
                if flags[0] or flags[1]:
                    return False, entry["type"]
                flags[0] = True
                if entry["status"] == "accepted":
                    entry["status"] = "started"
                return True, entry["type"]
            if event in TERMINAL:
                if flags[1]:
                    return False, entry["type"]
                flags[1] = True
                entry["status"] = event
                return True, entry["type"]
            return not flags[1], entry["type"]


class Hub:
    """Shared server state: the session, connected clients, the event fan-out to /ws/control."""

    def __init__(self, session: EngineSession, token: str | None, previz: Any = None):
        self.session = session
        self.token = token
        self.previz = previz
        self.commands = CommandLog()
        self.clients = {"control": 0, "telemetry": 0, "frames": 0, "previz": 0}
        self._control_queues: set[asyncio.Queue] = set()
        self.loop: asyncio.AbstractEventLoop | None = None
        self.stopping: asyncio.Event | None = None  # set when the app shuts down (lifespan)
        session.on_note(self._on_note)

    def shutdown(self) -> None:
        """Tell every WebSocket handler to finish (thread-safe)."""
        loop, ev = self.loop, self.stopping
        if loop is not None and ev is not None and not loop.is_closed():
            loop.call_soon_threadsafe(ev.set)

    def _on_note(self, note: dict[str, Any]) -> None:
        """Block notifications arrive on the clock thread: record them and hand them to the event loop."""
        cid = note.get("command_id")
        event = note.get("event")
        ok, ctype = self.commands.transition(cid, event)
        if not ok:
            return
        details = {k: v for k, v in note.items() if k not in ("command_id", "event", "id", "type") and _jsonable(v)}
        message = {"type": "event", "event": event, "id": cid, **details}
        if ctype is not None:
            message["command"] = ctype
        self.broadcast(message)

    def _emit(self, cid: str, event: str, **details: Any) -> None:
        ok, ctype = self.commands.transition(cid, event)
        if ok:
            self.broadcast({"type": "event", "event": event, "id": cid, "command": ctype, **details})

    def broadcast(self, message: dict[str, Any]) -> None:
        loop = self.loop
        if loop is None or loop.is_closed():
            return
        for q in list(self._control_queues):
            try:
                loop.call_soon_threadsafe(_put_drop_oldest, q, message)
            except RuntimeError:  # the loop closed meanwhile
                return

    def run_command(self, data: Any) -> dict[str, Any]:
        """Validate and execute one command; returns the ack. Raises HTTPException (4xx) on error."""
        try:
            cmd = control.parse_command(data)
        except control.CommandError as exc:
            raise _error(422, exc.code, str(exc), field=exc.field) from exc
        cid = cmd.id or uuid.uuid4().hex[:12]
        entry = self.commands.add(cid, cmd)
        if cmd.type == "cancel":
            return self._run_cancel(cid, cmd.target)
        try:
            result = control.execute(self.session, cmd, cid)
        except control.CommandError as exc:
            self.commands.update(cid, result=str(exc))
            self.commands.transition(cid, "failed")
            status = 404 if exc.code == "no_target" else 422
            raise _error(status, exc.code, str(exc), field=exc.field, id=cid) from exc
        except (ValueError, TypeError, KeyError, TimeoutError) as exc:
            self.commands.update(cid, result=str(exc))
            self.commands.transition(cid, "failed")
            raise _error(422, "rejected", str(exc), id=cid) from exc
        done = isinstance(result, dict) and result.get("done")
        entry["result"] = result if _jsonable(result) else None
        if cmd.type in control.LONG_ACTIONS | {"play_sound"} and not done:
            # Handed to a block: it reports started/completed/cancelled itself (see _on_note).
            with self.commands._lock:
                if entry["status"] == "accepted":
                    entry["status"] = "started"
        else:
            self._emit(cid, "completed")
        return {"id": cid, "status": entry["status"], "result": entry["result"]}

    def _run_cancel(self, cid: str, target: str) -> dict[str, Any]:
        """The `cancel` command: acked under its own id; the target gets its `cancelled` event."""
        if self.commands.get(target) is None:
            self.commands.update(cid, result=f"no command with id '{target}'")
            self.commands.transition(cid, "failed")
            raise _error(404, "unknown_command", f"no command with id '{target}'", field="target", id=cid)
        outcome = self.cancel(target)
        result = {"target": target, "status": outcome["status"]}
        self.commands.update(cid, result=result)
        self._emit(cid, "completed")
        return {"id": cid, "status": "completed", "result": result}

    def cancel(self, cid: str) -> dict[str, Any]:
        """Cancel a long action by id (DELETE /api/commands/{id}); a finished one keeps its status."""
        entry = self.commands.get(cid)
        if entry is None:
            raise _error(404, "unknown_command", f"no command with id '{cid}'")
        if entry["status"] in TERMINAL:
            return {"id": cid, "status": entry["status"]}
        for block in control._blocks(self.session, CANCELLABLE.get(entry["type"], ())):
            try:
                self.session.engine.call(lambda b=block: _stop_if_owner(b, cid))
            except Exception:  # a block that cannot stop is reported through its status
                pass
        self._emit(cid, "cancelled")
        return {"id": cid, "status": self.commands.get(cid)["status"] if self.commands.get(cid) else "cancelled"}


def _stop_if_owner(block: Any, cid: str) -> None:
    """Stop what `block` does for command `cid` only (in the clock thread); other commands go on."""
    if getattr(block, "command_id", None) == cid:
        block.handle("stop", {"command_id": cid})
        return
    pending, current = getattr(block, "pending", None), getattr(block, "current", None)
    if isinstance(pending, dict) and pending.get("command_id") == cid:
        block.pending = None  # not started yet: drop it
    elif isinstance(current, dict) and current.get("command_id") == cid:
        block.handle("stop", {"command_id": cid})  # cancels the running one (and clears the queue) ...
        block.pending = pending  # ... so put back what another command queued


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
    if isinstance(value, float) and not np.isfinite(value):
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


class _Socket:
    """One accepted WebSocket: serialised, never-failing sends and the disconnect/shutdown race."""

    def __init__(self, ws: WebSocket, stopping: asyncio.Event | None):
        self.ws = ws
        self.stopping = stopping
        self._lock = asyncio.Lock()

    async def send(self, message: dict[str, Any]) -> None:
        async with self._lock:
            await self.ws.send_text(security.dumps(message))

    async def send_bytes(self, data: bytes) -> None:
        async with self._lock:
            await self.ws.send_bytes(data)

    async def error(self, code: str, message: str, **extra: Any) -> None:
        await self.send({"type": "error", "code": code, "message": security.safe_text(message), **extra})

    async def messages(self, handle: Callable[[Any], Awaitable[None]]) -> None:
        """Receive until the client leaves: each JSON message goes to `handle`; a binary, oversized,
        malformed or unsafe one, or one whose handling fails, is answered with an error instead."""
        while True:
            message = await self.ws.receive()
            if message["type"] == "websocket.disconnect":
                return
            text = message.get("text")
            if text is None:
                await self.error("binary_message", "this socket takes JSON text messages, not binary ones")
                continue
            if len(text) > MAX_WS_MESSAGE:
                await self.error("too_large", f"message over {MAX_WS_MESSAGE} bytes")
                continue
            try:
                data = security.loads(text, max_bytes=None)
            except JsonSafetyError as exc:
                await self.error(exc.code, str(exc), field=exc.field)
                continue
            try:
                await handle(data)
            except Exception:  # never let one message take the socket down
                await self.error("internal_error", "the server could not handle this message")

    async def run(self, receiver: Awaitable[None], sender: Awaitable[None] | None = None) -> None:
        """Race the receive loop, the send loop and the app's shutdown; the first to end ends all."""
        tasks = [asyncio.ensure_future(receiver)]
        if sender is not None:
            tasks.append(asyncio.ensure_future(sender))
        if self.stopping is not None:
            tasks.append(asyncio.ensure_future(self.stopping.wait()))
        try:
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            await _cancel_all(tasks)
        if self.stopping is not None and self.stopping.is_set():
            with contextlib.suppress(Exception):
                await self.ws.close(code=1001, reason="server shutting down")

# --------------------------------------------------------------------------------------------------


def create_app(session: EngineSession, *, token: str | None = None, previz: Any = None,
               allowed_origins: list[str] | None = None, port: int | None = None, host: str = "127.0.0.1",
               origins: list[str] | None = None, frontend_dir: Path | None = FRONTEND_DIST) -> FastAPI:
    """The API around `session`.

    `allowed_origins`: origins besides the server's own (http://localhost|127.0.0.1|[::1]:`port`, and
    `host` when it is a specific address) that may change the robot from a browser; they also get
    CORS. `port` None (tests, embedding) accepts any port. `origins` is the old name of
    `allowed_origins`. Raises ValueError for a malformed origin.
    """
    extra_origins = [*(allowed_origins or []), *(origins or [])]
    policy = security.AccessPolicy(token=token, port=port, bind_host=host, allowed_origins=extra_origins)
    hub = Hub(session, token, previz)

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI):
        hub.loop = asyncio.get_running_loop()
        hub.stopping = asyncio.Event()
        try:
            yield
        finally:
            hub.stopping.set()

    app = FastAPI(title="Nutty", version="0.1.0", lifespan=lifespan, default_response_class=SafeJSONResponse,
                  description="Robot animation engine: Animation Programs, commands, telemetry and frames.")
    app.state.hub = hub
    app.state.policy = policy
    if extra_origins:
        app.add_middleware(CORSMiddleware, allow_origins=extra_origins, allow_methods=["*"], allow_headers=["*"])
    app.add_middleware(security.Guard, policy=policy, max_body=MAX_BODY)

    # --- errors: always JSON in the contract's shape, never a traceback -----------------------------------
    @app.exception_handler(StarletteHTTPException)
    async def http_error(_: Request, exc: StarletteHTTPException) -> Response:
        detail = exc.detail if isinstance(exc.detail, dict) else {
            "code": str(exc.detail or "error").lower().replace(" ", "_"), "message": str(exc.detail)}
        return SafeJSONResponse({"detail": detail}, status_code=exc.status_code, headers=exc.headers)

    @app.exception_handler(RequestValidationError)
    async def request_error(_: Request, exc: RequestValidationError) -> Response:
        errors = [{"loc": [security.safe_text(x) for x in e.get("loc", ())], "msg": security.safe_text(e.get("msg", "")),
                   "type": e.get("type")} for e in exc.errors()]
        first = errors[0] if errors else {"loc": [], "msg": "invalid request"}
        field = ".".join(str(x) for x in first["loc"][1:]) or None
        return SafeJSONResponse({"detail": {"code": "invalid_request", "message": f"{field or 'request'}: {first['msg']}",
                                            "field": field, "errors": errors}}, status_code=422)

    @app.exception_handler(Exception)
    async def unexpected_error(_: Request, exc: Exception) -> Response:
        return SafeJSONResponse(security.error_body("internal_error", "the server could not handle this request"),
                                status_code=500)

    async def json_body(request: Request) -> Any:
        """The request's JSON: declared application/json, streamed under the size limit, parsed safely."""
        problem = security.content_type_problem(request.headers.get("content-type"))
        if problem is not None:
            raise _error(415, "unsupported_media_type", problem)
        chunks, size = [], 0
        try:
            async for chunk in request.stream():
                size += len(chunk)
                if size > MAX_BODY:
                    raise _error(413, "too_large", f"request body over {MAX_BODY} bytes")
                chunks.append(chunk)
        except security.BodyTooLarge:
            raise _error(413, "too_large", f"request body over {MAX_BODY} bytes") from None
        raw = b"".join(chunks)
        if not raw.strip():
            raise _error(400, "malformed_json", "the body is empty: send a JSON document")
        try:
            return security.loads(raw)
        except JsonSafetyError as exc:
            raise _error(exc.status, exc.code, str(exc), field=exc.field) from exc

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
            ins, outs = cls.ports(p)
        except (ValidationError, ValueError, TypeError) as exc:
            raise _error(422, "invalid_param", str(exc)) from exc
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
        doc = await json_body(request)
        return (await asyncio.to_thread(session.validate, doc)).model_dump()

    @api.put("/program", summary="Validate and hot-swap a program (atomic)")
    async def put_program(request: Request) -> dict[str, Any]:
        doc = await json_body(request)
        try:
            report, kept = await asyncio.to_thread(session.load_program, doc)
        except SessionError as exc:
            raise _error(422, "invalid_program", str(exc),
                         report=exc.report.model_dump() if exc.report else None) from exc
        return {"report": report.model_dump(), "kept": kept}

    @api.patch("/program/nodes/{node_id}/params",
               summary="Change one node's parameters live, without rebuilding the program")
    async def patch_params(node_id: str, request: Request) -> dict[str, Any]:
        body = await json_body(request)
        if not isinstance(body, dict):
            raise _error(422, "invalid_param", "the body is an object of parameter name -> value")
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

        @api.put(f"/{kind}/{{name}}", summary=f"Save one of the robot's {kind} (validated against its format)")
        async def put_item(name: str, request: Request) -> dict[str, Any]:
            doc = await json_body(request)
            if not isinstance(doc, dict):
                raise _error(422, "invalid_document", f"a {kind[:-1]} is a JSON object")
            try:
                session.library.check_name(name)
            except LibraryError as exc:
                raise _error(422, "invalid_name", str(exc)) from exc
            if validate_program:
                report = await asyncio.to_thread(session.validate, doc)
                if not report.valid:
                    raise _error(422, "invalid_program", "program is invalid", report=report.model_dump())
            try:
                await asyncio.to_thread(session.library.save, kind, name, doc)
            except LibraryError as exc:
                raise _error(422, "invalid_document", str(exc)) from exc
            return {"saved": name}

        @api.delete(f"/{kind}/{{name}}", summary=f"Delete one of the robot's {kind}")
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

    @api.put("/inputs/{name}", summary="Set one exposed input",
             openapi_extra=_body_doc({"type": "object", "properties": {"value": {}}, "required": ["value"]}))
    async def put_input(name: str, request: Request) -> dict[str, Any]:
        body = _validate_model(InputValue, await json_body(request))
        try:
            result = await asyncio.to_thread(control.execute, session,
                                             control.parse_command({"type": "set_input", "name": name,
                                                                    "value": body.value}))
        except control.CommandError as exc:
            raise _error(422, "invalid_input", str(exc), field=name) from exc
        return {"name": name, "value": result[name]}

    @api.post("/commands", summary="Run a command (one typed union; see /api/schema/commands)")
    async def post_command(request: Request) -> dict[str, Any]:
        data = await json_body(request)
        return await asyncio.to_thread(hub.run_command, data)

    @api.get("/commands/{cid}", summary="A command's status")
    def get_command(cid: str) -> dict[str, Any]:
        entry = hub.commands.get(cid)
        if entry is None:
            raise _error(404, "unknown_command", f"no command with id '{cid}'")
        return entry

    @api.delete("/commands/{cid}", summary="Cancel a long action")
    async def cancel_command(cid: str) -> dict[str, Any]:
        return await asyncio.to_thread(hub.cancel, cid)

    # --- status and pre-viz -------------------------------------------------------------------------------------
    def previz_urls(request: Request) -> dict[str, Any]:
        base = str(request.base_url).rstrip("/")
        return {"url": f"{base}/previz/", "direct": hub.previz.url("127.0.0.1"),
                "token_required": token is not None}

    @api.get("/status", summary="Tick statistics, APU level, drivers with drop counts, clients")
    def status(request: Request) -> dict[str, Any]:
        stats = session.engine.stats()
        stats["clients"] = dict(hub.clients)
        stats["program"] = session.program.name if session.program else None
        stats["previz"] = {**previz_urls(request), "frames_shown": hub.previz.frames_shown,
                           "ghost": hub.previz.ghost_visible} if hub.previz else None
        return stats

    @api.get("/previz", summary="Where the 3D Pre-Viz is served (the URL a client should open)")
    def previz_info(request: Request) -> dict[str, Any]:
        if hub.previz is None:
            return {"url": None, "direct": None, "token_required": token is not None, "ghost": None}
        return {**previz_urls(request), "ghost": hub.previz.ghost_visible}

    @api.put("/previz/ghost", summary="Show or hide the ghost (stage-1 pose)",
             openapi_extra=_body_doc({"type": "object", "properties": {"visible": {"type": "boolean"}},
                                      "required": ["visible"]}))
    async def previz_ghost(request: Request) -> dict[str, Any]:
        body = _validate_model(GhostToggle, await json_body(request))
        if hub.previz is None:
            raise _error(404, "no_previz", "this server runs without a Pre-Viz")
        hub.previz.set_ghost(body.visible)
        return {"ghost": body.visible}

    app.include_router(api)

    # --- the Pre-Viz, proxied behind the guard and the token -----------------------------------------------------
    @app.get("/previz", include_in_schema=False)
    def previz_redirect(request: Request) -> Response:
        query = request.url.query
        return RedirectResponse(f"/previz/{'?' + query if query else ''}", status_code=307)

    @app.get("/previz/{path:path}", include_in_schema=False)
    async def previz_page(path: str, request: Request) -> Response:
        if hub.previz is None:
            raise _error(404, "no_previz", "this server runs without a Pre-Viz")
        from backend.previz import fetch_page

        try:
            status_code, headers, body = await fetch_page(hub.previz.port, path,
                                                          request.headers.get("accept-encoding", ""))
        except Exception as exc:  # refused, reset, truncated, timed out, malformed: the same to the client
            raise _error(502, "previz_unavailable", f"the Pre-Viz did not answer: {type(exc).__name__}") from exc
        response = Response(body, status_code=status_code, headers=headers)
        if token is not None:  # the page's WebSocket (same path, no query) then carries the cookie
            response.set_cookie(security.PREVIZ_COOKIE, security.previz_cookie_value(token), path="/previz",
                                httponly=True, samesite="strict")
        return response

    async def previz_socket(ws: WebSocket) -> None:
        if hub.previz is None:
            await ws.close(code=4404, reason="this server runs without a Pre-Viz")
            return
        from backend.previz import relay_socket

        hub.clients["previz"] += 1
        try:
            await relay_socket(ws, hub.previz, hub.stopping)
        finally:
            hub.clients["previz"] -= 1

    app.add_api_websocket_route("/previz", previz_socket)
    app.add_api_websocket_route("/previz/", previz_socket)

    # --- WebSockets ------------------------------------------------------------------------------------------------
    async def ws_open(ws: WebSocket, kind: str) -> _Socket:
        await ws.accept()
        hub.loop = asyncio.get_running_loop()
        hub.clients[kind] += 1
        return _Socket(ws, hub.stopping)

    @app.websocket("/ws/control")
    async def ws_control(ws: WebSocket) -> None:
        sock = await ws_open(ws, "control")
        queue: asyncio.Queue = asyncio.Queue(maxsize=256)
        hub._control_queues.add(queue)

        async def pump() -> None:
            while True:
                await sock.send(await queue.get())

        async def handle(data: Any) -> None:
            cid = data.get("id") if isinstance(data, dict) and isinstance(data.get("id"), str) else None
            try:
                ack = await asyncio.to_thread(hub.run_command, data)
            except HTTPException as exc:
                detail = exc.detail if isinstance(exc.detail, dict) else {"code": "error", "message": str(exc.detail)}
                await sock.send({"type": "error", "id": cid, **detail})
                return
            except Exception:  # a fault of the server, not of the message: say so, keep the socket
                await sock.error("internal_error", "the server could not carry out this command", id=cid)
                return
            await sock.send({"type": "ack", **ack})

        try:
            await sock.run(sock.messages(handle), pump())
        finally:
            hub._control_queues.discard(queue)
            hub.clients["control"] -= 1

    @app.websocket("/ws/telemetry")
    async def ws_telemetry(ws: WebSocket) -> None:
        sock = await ws_open(ws, "telemetry")
        loop = asyncio.get_running_loop()
        sub: dict[str, Any] = {"signals": [], "frames": True, "rate": 30.0}
        changed = asyncio.Event()
        emb = session.embodiment

        async def handle(data: Any) -> None:
            if not isinstance(data, dict) or data.get("type") != "subscribe":
                await sock.error("invalid_message", "send {'type': 'subscribe', 'signals': [...], 'frames': bool, 'rate': Hz}")
                return
            signals = data.get("signals", [])
            if not isinstance(signals, list) or not all(
                    isinstance(s, dict) and isinstance(s.get("node"), str) and isinstance(s.get("port"), str)
                    for s in signals):
                await sock.error("invalid_message", "signals is a list of {node: str, port: str}", field="signals")
                return
            rate = data.get("rate", 30.0)
            if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 0 < rate <= TELEMETRY_MAX_HZ:
                await sock.error("invalid_message", f"rate must be within (0, {TELEMETRY_MAX_HZ:g}] Hz", field="rate")
                return
            frames = data.get("frames", True)
            if not isinstance(frames, bool):
                await sock.error("invalid_message", "frames is true or false", field="frames")
                return
            sub.update(signals=[{"node": s["node"], "port": s["port"]} for s in signals[:200]], frames=frames,
                       rate=float(rate))
            changed.set()
            await sock.send({"type": "subscribed", "signals": len(sub["signals"]), "rate": sub["rate"]})

        def message(frame: AnimationFrame) -> dict[str, Any]:
            apu = session.engine.apu
            msg: dict[str, Any] = {"type": "telemetry", "t": frame.t, "seq": frame.seq}
            if apu is not None and sub["signals"]:
                msg["signals"] = {f"{s['node']}.{s['port']}": _signal_json(emb, apu.signal_value(s["node"], s["port"]))
                                  for s in sub["signals"]}
            if sub["frames"]:
                msg["frame"] = {"position": _frame_channels(emb, frame.position),
                                "stage1": _frame_channels(emb, frame.stage1 if frame.stage1 is not None else frame.position),
                                "classes": _limit_classes(emb, frame),
                                # channels the engine's safety net corrected on this frame: the program
                                # relies on the net there (its own output breaks the robot's limits)
                                "corrected": [emb.channel_names[i] for i in np.flatnonzero(frame.corrected)]
                                if frame.corrected is not None else []}
            if apu is not None:
                msg["layers"] = {s.node_id: s.block.layer_states() for s in apu.steps
                                 if hasattr(s.block, "layer_states")}
            return msg

        async def send_loop() -> None:
            last_seq, due = -1, 0.0
            while True:
                now = loop.time()
                if changed.is_set():  # a new subscription takes effect at once
                    changed.clear()
                    due = now
                if now < due:  # short naps, so a slower or faster new rate applies quickly
                    await asyncio.sleep(min(due - now, 0.25))
                    continue
                period = 1.0 / sub["rate"]
                due = due + period if due + period > now else now + period  # never faster than the rate
                frame = session.engine.last_frame
                if frame is None or frame.seq == last_seq:
                    continue
                last_seq = frame.seq
                try:
                    msg = message(frame)
                except Exception:
                    await sock.error("internal_error", "telemetry for this subscription failed; subscribe again")
                    sub.update(signals=[])
                    continue
                await sock.send(msg)  # a slow client only slows its own loop: it is decimated

        try:
            await sock.run(sock.messages(handle), send_loop())
        finally:
            hub.clients["telemetry"] -= 1

    @app.websocket("/ws/frames")
    async def ws_frames(ws: WebSocket) -> None:
        fmt = ws.query_params.get("format", "json")
        try:
            decimate = int(ws.query_params.get("decimate", "1"))
        except ValueError:
            decimate = 0
        if fmt not in ("json", "msgpack") or not 1 <= decimate <= 1000:
            await ws.accept()
            await ws.close(code=4400, reason="format must be json|msgpack and decimate an integer in 1..1000")
            return
        sock = await ws_open(ws, "frames")
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue = asyncio.Queue(maxsize=64)
        emb = session.embodiment

        def offer(frame: AnimationFrame) -> None:
            if not loop.is_closed():
                loop.call_soon_threadsafe(_put_drop_oldest, queue, frame)

        sink = Sink(f"ws-frames-{id(ws):x}", offer, max_queue=64, decimate=decimate)
        session.engine.add_sink(sink)

        async def handle(_: Any) -> None:
            await sock.error("unexpected_message", "/ws/frames only sends frames; it takes no messages")

        async def send_loop() -> None:
            import msgpack

            while True:
                frame: AnimationFrame = await queue.get()
                doc = frame.to_dict(emb)
                if fmt == "json":
                    await sock.send(doc)
                else:
                    await sock.send_bytes(msgpack.packb(doc))

        try:
            await sock.run(sock.messages(handle), send_loop())
        finally:
            hub.clients["frames"] -= 1
            # Off the event loop: removing a sink joins its thread. Runs to the end even if this
            # handler is cancelled meanwhile.
            await asyncio.to_thread(session.engine.remove_sink, sink)

    # --- the editor ------------------------------------------------------------------------------------------------------
    if frontend_dir is not None and (frontend_dir / "index.html").exists():
        from fastapi.staticfiles import StaticFiles

        app.mount("/", StaticFiles(directory=str(frontend_dir), html=True), name="editor")
    else:
        @app.get("/", response_class=HTMLResponse, include_in_schema=False)
        def index() -> str:
            link = '<li><a href="/previz/">3D Pre-Viz</a></li>' if hub.previz else ""
            return (f"<!doctype html><title>Nutty</title><h1>Nutty is running</h1>"
                    f"<p>Robot <b>{session.embodiment.name}</b>, program <b>{session.program.name if session.program else '-'}</b>."
                    f" The editor is not built (run <code>make run</code>).</p>"
                    f"<ul><li><a href='/docs'>API (OpenAPI)</a></li>{link}</ul>")

    return app
