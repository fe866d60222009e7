"""The WebSockets: /ws/control (commands in, acks and events out), /ws/telemetry (subscribed
signals and frames at a chosen rate) and /ws/frames (every frame, for drivers).

Each handler races its send loop against the client's disconnect and the app's shutdown
(ClientSocket.run) and answers a bad message with an error message, never by closing.
"""

from __future__ import annotations

import asyncio
import logging
import math
from typing import Any

import msgpack
from fastapi import APIRouter, WebSocket

from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink
from backend.errors import DomainError
from backend.hub import Hub, put_drop_oldest
from backend.routes.client_socket import ClientSocket
from backend.routes.errors import error_detail
from backend.routes.state import HubDep
from backend.routes.telemetry import Subscription, SubscriptionError

router = APIRouter()
MAX_DECIMATE = 1000
log = logging.getLogger(__name__)


async def _open(ws: WebSocket, hub: Hub, kind: str) -> ClientSocket:
    await ws.accept()
    hub.loop = asyncio.get_running_loop()
    hub.clients[kind] += 1
    return ClientSocket(ws, hub.stopping)


@router.websocket("/ws/control")
async def ws_control(ws: WebSocket, hub: HubDep) -> None:
    sock = await _open(ws, hub, "control")
    queue: asyncio.Queue = asyncio.Queue(maxsize=256)
    hub.control_queues.add(queue)

    async def pump() -> None:
        while True:
            await sock.send(await queue.get())

    async def handle(data: Any) -> None:
        cid = data.get("id") if isinstance(data, dict) and isinstance(data.get("id"), str) else None
        try:
            ack = await asyncio.to_thread(hub.run_command, data)
        except DomainError as exc:
            await sock.send({"type": "error", "id": cid, **error_detail(exc)})
            return
        except Exception:  # a fault of the server, not of the message: say so, keep the socket
            log.exception("/ws/control: command %r failed", cid)
            await sock.error("internal_error", "the server could not carry out this command", id=cid)
            return
        await sock.send({"type": "ack", **ack})

    try:
        await sock.run(sock.messages(handle), pump())
    finally:
        hub.control_queues.discard(queue)
        hub.clients["control"] -= 1


@router.websocket("/ws/telemetry")
async def ws_telemetry(ws: WebSocket, hub: HubDep) -> None:
    sock = await _open(ws, hub, "telemetry")
    sub = Subscription()

    async def handle(data: Any) -> None:
        try:
            sub.update(data)
        except SubscriptionError as exc:
            await sock.send({"type": "error", **error_detail(exc)})
            return
        await sock.send({"type": "subscribed", "signals": len(sub.signals), "rate": sub.rate})

    try:
        await sock.run(sock.messages(handle), _send_telemetry(sock, hub, sub))
    finally:
        hub.clients["telemetry"] -= 1


async def _send_telemetry(sock: ClientSocket, hub: Hub, sub: Subscription) -> None:
    """Send the latest frame at the subscribed rate; a slow client only slows its own loop (decimated)."""
    loop = asyncio.get_running_loop()
    last_seq, due = -1, 0.0
    while True:
        now = loop.time()
        if sub.changed.is_set():  # a new subscription takes effect at once
            sub.changed.clear()
            due = now
        if now < due:  # short naps, so a slower or faster new rate applies quickly
            await asyncio.sleep(min(due - now, 0.25))
            continue
        period = 1.0 / sub.rate
        # On a grid of the period: clients at one rate wake together and share one message (see
        # telemetry.SharedTexts); never faster than the rate.
        slot = math.floor(now / period)
        due = (slot + 1.0) * period
        frame = hub.session.engine.last_frame
        if frame is None or frame.seq == last_seq:
            continue
        try:
            last_seq, text = sub.text(hub.session, frame, (sub.rate, slot))
        except Exception:  # one subscription's fault: the client subscribes again, the socket stays
            log.exception("/ws/telemetry: building the message for %s failed", sub.signal_keys)
            await sock.error("internal_error", "telemetry for this subscription failed; subscribe again")
            sub.signals = []
            continue
        await sock.send_text(text)


@router.websocket("/ws/frames")
async def ws_frames(ws: WebSocket, hub: HubDep) -> None:
    fmt = ws.query_params.get("format", "json")
    try:
        decimate = int(ws.query_params.get("decimate", "1"))
    except ValueError:
        decimate = 0
    if fmt not in ("json", "msgpack") or not 1 <= decimate <= MAX_DECIMATE:
        await ws.accept()
        await ws.close(code=4400, reason="format must be json|msgpack and decimate an integer in 1..1000")
        return
    sock = await _open(ws, hub, "frames")
    loop = asyncio.get_running_loop()
    queue: asyncio.Queue = asyncio.Queue(maxsize=64)
    engine = hub.session.engine

    def offer(frame: AnimationFrame) -> None:
        if not loop.is_closed():
            loop.call_soon_threadsafe(put_drop_oldest, queue, frame)

    sink = Sink(f"ws-frames-{id(ws):x}", offer, max_queue=64, decimate=decimate)
    engine.add_sink(sink)

    async def handle(_: Any) -> None:
        await sock.error("unexpected_message", "/ws/frames only sends frames; it takes no messages")

    try:
        await sock.run(sock.messages(handle), _send_frames(sock, queue, hub.session.embodiment, fmt))
    finally:
        hub.clients["frames"] -= 1
        # Off the event loop: removing a sink joins its thread. Runs to the end even if this
        # handler is cancelled meanwhile.
        await asyncio.to_thread(engine.remove_sink, sink)


async def _send_frames(sock: ClientSocket, queue: asyncio.Queue, emb: Embodiment, fmt: str) -> None:
    while True:
        frame: AnimationFrame = await queue.get()
        doc = frame.to_dict(emb)
        if fmt == "json":
            await sock.send(doc)
        else:
            packed = msgpack.packb(doc)
            if packed is not None:  # packb returns the bytes when it is given no stream
                await sock.send_bytes(packed)
