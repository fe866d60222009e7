"""The Pre-Viz in its own process, so that viser never takes the engine's interpreter lock.

Why (issue 15, measured on a 2-core machine): posing the robot and its ghost through viser's scene
handles costs ~2.5 ms of Python per shown frame, and viser's own thread then encodes and sends the
messages. At ~55 frames/s that made the Pre-Viz the biggest user of the server's interpreter lock
after the clock itself, and the clock waited for it: `nutty serve` at 500 Hz lost hundreds of ticks a
minute with the Pre-Viz page open, a handful without. In a child process the server pays only for
sending two position vectors down a pipe per shown frame (tens of µs, on the Pre-Viz sink's thread).

`PreVizProcess` (the server's side) offers what the server uses of `backend.previz.PreViz`: `port`,
`proxy_secret`, `url`, `ghost_visible`, `set_ghost`, `set_theme`, `set_preview`, `on_pose_grab`,
`frames_shown`, `shown`, `drag_gaze`, `trusted_clients`, `start` and `stop`. The child runs a `PreViz` on a stand-in session (`_Remote`):
the embodiment, and gaze drags sent back to the server, which sets the program's input.

Messages, server -> child: ("frame", position, stage1, events, joints), ("call", id, name, args), ("stop",);
child -> server: ("ready", port) or ("error", text) once, ("reply", id, ok, value), ("state",
frames_shown, ghost, trusted ids) when they change (frames_shown at most 4 times a second), ("gaze",
[x, y, z]) for a trusted client's drag, ("pose", dof, value) for a link turned in the preview. A
child that dies takes only the Pre-Viz with it.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import multiprocessing
import os
import secrets
import signal
import threading
import time
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from backend.drivers.readings import physics_source
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame, FrameEvent
from backend.engine.runtime import Sink
from backend.logs import configure_logging, settings
from backend.previz import attach_previz_sink, check_loopback, gaze_from_drag
from backend.session import EngineSession

log = logging.getLogger(__name__)

STATE_PERIOD = 0.25  # s between two frame-count reports of the child
START_TIMEOUT = 120.0  # s for the child to import viser and load the URDF (twice) on a busy machine
CALL_TIMEOUT = 10.0  # s for one call into the child
CHILD_NICE = 10  # the Pre-Viz process yields the CPU to the server (whose clock runs at a higher priority)


class PreVizUnavailable(RuntimeError):
    """The Pre-Viz process did not start, or has gone."""


@dataclass
class _Shown:
    """What `PreViz.show` reads of an Animation Frame."""

    position: np.ndarray
    stage1: np.ndarray | None
    events: list[FrameEvent] = field(default_factory=list)
    joints: np.ndarray | None = None
    physics: tuple[np.ndarray, tuple[str, ...]] | None = None


class _Remote:
    """The child's stand-in for the engine session: the embodiment, and a program that takes a gaze
    target, which is sent to the server (the server checks the real program and sets the input)."""

    def __init__(self, embodiment: Embodiment, send: Any):
        self.embodiment = embodiment
        self._send = send

    @property
    def program(self) -> _Remote:
        return self

    def input(self, name: str) -> bool | None:
        return True if name == "gaze_target" else None

    def set_input(self, name: str, value: Any) -> None:
        self._send(("gaze", [float(v) for v in value]))


def _child_main(
    conn: Any,
    embodiment: Embodiment,
    host: str,
    port: int,
    allowed_origins: list[str],
    proxy_secret: str,
    proxy_only: bool = False,
    log_settings: tuple[str | int, bool] | None = None,
) -> None:
    """The Pre-Viz process: a PreViz fed from `conn` until the server says stop or goes away.
    `log_settings`: the server's (level, json_lines), so the child logs as the server does."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl+C reaches the whole group: the server decides
    if log_settings is not None:  # a spawned process starts with logging unconfigured
        configure_logging(*log_settings)
    with contextlib.suppress(AttributeError, OSError):
        os.nice(CHILD_NICE)  # on a busy machine the preview lags, never the robot's clock
    lock = threading.Lock()

    def send(message: tuple) -> None:
        with lock:
            conn.send(message)

    try:
        from backend.previz import PreViz  # viser loads in the child process only

        pv = PreViz(
            _Remote(embodiment, send),
            host=host,
            port=port,
            allowed_origins=allowed_origins,
            proxy_secret=proxy_secret,
            proxy_only=proxy_only,
        )
    except Exception as exc:  # reported to the server, which raises it where the port is asked for
        log.debug("the Pre-Viz could not start", exc_info=True)  # the traceback stays here, for a bug report
        send(("error", f"{type(exc).__name__}: {exc}"))
        return
    calls = {
        name: getattr(pv, name) for name in ("shown", "set_ghost", "set_theme", "move_gaze", "set_preview")
    }
    pv.on_pose_grab = lambda dof, value: send(("pose", dof, value))
    send(("ready", pv.port))
    reported: tuple = ()
    reported_at = 0.0
    try:
        while True:
            ready = conn.poll(STATE_PERIOD)
            latest = None
            while ready:  # everything waiting: calls in order, and only the newest frame is shown
                message = conn.recv()
                kind = message[0]
                if kind == "frame":
                    latest = message
                elif kind == "call":
                    _, call_id, name, args = message
                    try:
                        send(("reply", call_id, True, calls[name](*args)))
                    except Exception as exc:  # raised to the server's caller; the loop goes on
                        log.debug("Pre-Viz call %s failed", name, exc_info=True)
                        send(("reply", call_id, False, f"{type(exc).__name__}: {exc}"))
                elif kind == "stop":
                    return
                ready = conn.poll()
            if latest is not None:
                _, position, stage1, events, joints, physics = latest
                # duck-typed: show() reads only the position, stage1, events and joints of a frame
                shown = _Shown(position, stage1, [FrameEvent(*e) for e in events], joints, physics)
                pv.show(cast(AnimationFrame, shown))
            state = (pv.frames_shown, pv.ghost_visible, tuple(sorted(pv.trusted_clients)))
            now = time.monotonic()
            if state != reported and (state[1:] != reported[1:] or now - reported_at >= STATE_PERIOD):
                send(("state", *state))
                reported, reported_at = state, now
    except (EOFError, OSError):  # the server has gone
        pass
    finally:
        pv.server.stop()


class PreVizProcess:
    """The 3D Pre-Viz (`backend.previz.PreViz`) run in a child process; `start()` attaches it to the
    engine as a sink (at most `backend.previz.MAX_RATE` frames per second, a stale frame dropped, never queued)."""

    def __init__(
        self,
        session: EngineSession,
        host: str = "127.0.0.1",
        port: int = 8080,
        allowed_origins: list[str] | None = None,
        start_timeout: float = START_TIMEOUT,
        proxy_only: bool = False,
    ):
        check_loopback(host)
        self.session = session
        #: `PreViz.proxy_only`: with a token, only the API's proxy reaches the child's port.
        self.proxy_only = bool(proxy_only)
        #: `PreViz.run_command`: gizmo drags as `set_gaze` commands on the server's command path.
        self.run_command: Any = None
        #: `PreViz.on_pose_grab`: a link turned in the clip editor's preview, as (dof, value).
        self.on_pose_grab: Any = None
        self.host = host
        self.proxy_secret = secrets.token_urlsafe(24)
        self.start_timeout = start_timeout
        self.frames_shown = 0
        #: The physics preview's simulated pose, shown as the physics ghost (none without `--sim`).
        self.physics_source = physics_source(session.engine.sinks)
        self._ghost = True
        self._trusted: frozenset[int] = frozenset()
        self._port: int | None = None
        self._failure: str | None = None
        self._ready = threading.Event()
        self._calls: dict[int, Future] = {}
        self._ids = itertools.count(1)
        self._send_lock = threading.Lock()
        self._sink: Sink | None = None
        context = multiprocessing.get_context("spawn")  # a fork would copy the engine's threads' locks
        self._conn, child = context.Pipe()
        self._proc = context.Process(
            target=_child_main,
            name="nutty-previz",
            daemon=True,
            args=(
                child,
                session.embodiment,
                host,
                port,
                list(allowed_origins or []),
                self.proxy_secret,
                self.proxy_only,
                settings(),
            ),
        )
        self._proc.start()
        child.close()
        self._reader = threading.Thread(target=self._read, name="previz-link", daemon=True)
        self._reader.start()

    # --- the link -----------------------------------------------------------------------------------
    def _read(self) -> None:
        try:
            while True:
                message = self._conn.recv()
                kind = message[0]
                if kind == "state":
                    self.frames_shown, self._ghost, trusted = message[1], message[2], message[3]
                    self._trusted = frozenset(trusted)
                elif kind == "reply":
                    future = self._calls.pop(message[1], None)
                    if future is not None:
                        if message[2]:
                            future.set_result(message[3])
                        else:
                            future.set_exception(PreVizUnavailable(message[3]))
                elif kind == "gaze":
                    gaze_from_drag(self.session, self.run_command, message[1])
                elif kind == "pose" and self.on_pose_grab is not None:
                    self.on_pose_grab(message[1], message[2])
                elif kind == "ready":
                    self._port = int(message[1])
                    self._ready.set()
                elif kind == "error":
                    self._failure = message[1]
                    self._ready.set()
        except (EOFError, OSError):
            pass
        if self._failure is None:
            self._failure = "the Pre-Viz process has exited"
        self._ready.set()
        for future in list(self._calls.values()):
            future.set_exception(PreVizUnavailable(self._failure))
        self._calls.clear()

    def _send(self, message: tuple, timeout: float) -> None:
        if not self._send_lock.acquire(timeout=timeout):
            raise PreVizUnavailable("the Pre-Viz process is not taking messages")
        try:
            self._conn.send(message)
        except (OSError, ValueError) as exc:
            raise PreVizUnavailable(f"the Pre-Viz process has gone: {exc}") from exc
        finally:
            self._send_lock.release()

    def _call(self, name: str, *args: Any) -> Any:
        self.wait_ready()
        call_id = next(self._ids)
        future: Future = Future()
        self._calls[call_id] = future
        if self._failure is not None:  # it went between the check and the registration
            self._calls.pop(call_id, None)
            raise PreVizUnavailable(self._failure)
        self._send(("call", call_id, name, args), CALL_TIMEOUT)
        return future.result(CALL_TIMEOUT)

    def wait_ready(self) -> None:
        """Block until the child serves (raises PreVizUnavailable if it failed to start)."""
        if not self._ready.wait(self.start_timeout):
            raise PreVizUnavailable(f"the Pre-Viz process did not start within {self.start_timeout:g} s")
        if self._port is None:
            raise PreVizUnavailable(self._failure or "the Pre-Viz process did not start")

    # --- what the server uses -----------------------------------------------------------------------
    @property
    def port(self) -> int:
        """viser's loopback port (it moves to the next free one when the one asked for is taken)."""
        self.wait_ready()
        port = self._port
        if port is None:  # wait_ready() raised already; this tells the type checker so
            raise PreVizUnavailable(self._failure or "the Pre-Viz process did not start")
        return port

    def url(self, host: str | None = None) -> str:
        return f"http://{host or self.host}:{self.port}"

    @property
    def alive(self) -> bool:
        return self._proc.is_alive()

    @property
    def ghost_visible(self) -> bool:
        return self._ghost

    def set_ghost(self, visible: bool) -> None:
        self._call("set_ghost", bool(visible))
        self._ghost = bool(visible)

    def set_preview(self, vector: Any, label: str = "", lease: float = 0.0) -> None:
        self._call("set_preview", None if vector is None else np.asarray(vector, dtype=float), label, lease)

    def set_theme(self, theme: str) -> None:
        self._call("set_theme", theme)

    @property
    def trusted_clients(self) -> frozenset[int]:
        """Ids of the viser clients whose gaze drags count (as of the child's last report)."""
        return self._trusted

    def shown(self) -> dict[str, Any]:
        """What the Pre-Viz displays now (`PreViz.shown`)."""
        return self._call("shown")

    def drag_gaze(self, position: Any, client_id: int | None = None) -> bool:
        """`PreViz.drag_gaze`: the gizmo moves in the child, the input is set here."""
        target = self._call("move_gaze", [float(v) for v in position], client_id)
        return target is not None and gaze_from_drag(self.session, self.run_command, target)

    def show(self, frame: AnimationFrame) -> None:
        """Send one frame to the child (on the Pre-Viz sink's thread)."""
        events = [(e.dof, e.kind, dict(e.payload)) for e in frame.events]
        stage1 = frame.stage1 if self._ghost else None
        physics = self.physics_source() if self.physics_source is not None else None
        # a Pre-Viz that has gone shows nothing; the engine and the API go on
        with contextlib.suppress(PreVizUnavailable):
            self._send(("frame", frame.position, stage1, events, frame.joints, physics), CALL_TIMEOUT)

    def start(self) -> PreVizProcess:
        self._sink = attach_previz_sink(self.session, self.show)
        return self

    def stop(self, timeout: float = 5.0) -> None:
        """Detach from the engine and end the child (killed if it does not stop within `timeout`)."""
        if self._sink is not None:
            self.session.engine.remove_sink(self._sink)
            self._sink = None
        if self._proc.is_alive():
            with contextlib.suppress(PreVizUnavailable):
                self._send(("stop",), 1.0)
            self._proc.join(timeout)
        if self._proc.is_alive():
            self._proc.kill()
            self._proc.join(1.0)
        self._conn.close()
