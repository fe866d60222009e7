"""How `nutty serve` stops: the robot parks at its exact rest pose before anything closes.

`Shutdown` runs the sequence (park, hold, drain, stop the HTTP server, close the drivers) on a
signal or when the server stops by itself; `ShutdownGate` keeps the API from steering the robot
meanwhile; `uvicorn_server` leaves the signals to `Shutdown`; a watchdog bounds the whole. The
steps and their budgets are described below the constants.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import threading
import time

import numpy as np

from backend.logs import direct_line

log = logging.getLogger(__name__)

# Shutdown budget (seconds; see `Shutdown`): the robot gets --shutdown-timeout to reach rest, the
# HTTP server HTTP_GRACE more for open requests and WebSockets, and a watchdog ends the process
# EXIT_BOUND after the shutdown-timeout whatever hangs.
DEFAULT_SHUTDOWN_TIMEOUT = 3.0
PARK_SLACK = 1.0  # how much longer than its own timeout park() may take before it is given up on
HOLD_SECONDS = 0.3  # after the park: the clock keeps emitting the rest pose this long, so every driver
#                     ends on a run of rest frames even if it drops some
DRAIN_SECONDS = 0.5  # then, clock stopped: time for the drivers to take the last frames off their queues
HTTP_GRACE = 1.5  # uvicorn's timeout_graceful_shutdown: then hung clients are cancelled
HURRIED_GRACE = 0.25  # the same after a second signal
EXIT_BOUND = 4.5  # watchdog: the process is gone at most shutdown-timeout + EXIT_BOUND after the first signal
REST_TOLERANCE = 1e-9

# --------------------------------------------------------------------------------------------------
# SIGTERM, SIGINT and SIGHUP (unless ignored, as under nohup) take the same path, as does the HTTP
# server stopping by itself:
#   1. the API stops taking anything that could steer the robot (`ShutdownGate`: mutating requests get
#      503 `shutting_down`, new WebSockets are refused, a message on an open /ws/control ends its session);
#   2. the robot parks: `EngineSession.park()` takes it to the embodiment's exact rest pose within its
#      velocity/acceleration/jerk limits, at most --shutdown-timeout seconds, while every driver - OSC,
#      the recorder, the simulated servos, the Pre-Viz and /ws/frames clients - keeps receiving frames;
#      the rest pose is held for HOLD_SECONDS, then the clock stops, so the last frame every driver got
#      is the rest pose at zero velocity;
#   3. the drivers get DRAIN_SECONDS to take those frames off their queues, then the API's WebSocket
#      handlers are told to finish (Hub.shutdown: they close with 1001);
#   4. uvicorn shuts down with timeout_graceful_shutdown = HTTP_GRACE: a hung client (a /ws/frames
#      reader that stopped reading, a 0.01 Hz telemetry client) is cancelled, never waited for;
#   5. the engine closes its sinks (queued frames delivered, files closed) and the Pre-Viz stops.
# A second signal hurries: the robot still reaches rest (the park already moves as fast as the limits
# allow, so cutting it would only leave the robot mid-motion), but the hold and the drain are cut short
# and clients get HURRIED_GRACE (none at all if uvicorn is already waiting for them). Further signals
# are ignored. A watchdog ends the process with status 1 if any step hangs, at most shutdown-timeout +
# EXIT_BOUND seconds after the first signal; SIGKILL remains the way to stop at once, without rest.
# The exit status is 0 when the robot reached rest, 1 when it did not.
# --------------------------------------------------------------------------------------------------

SHUTDOWN_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGINT", "SIGHUP") if hasattr(signal, n))
SAFE_METHODS = {"GET", "HEAD", "OPTIONS"}
COMMAND_SOCKETS = ("/ws/control",)  # WebSockets whose messages steer the robot
SHUTTING_DOWN = "the server is shutting down: the robot is going to rest"


def _say(message: str, level: int = logging.WARNING) -> None:
    """Log a line from a signal handler or the watchdog: formatted as the configured logging would
    (backend.logs.direct_line) but written straight to fd 2, because the logging module's handlers
    take locks and a buffered stream that the interrupted (or a hung) thread may hold."""
    if log.getEffectiveLevel() > level:
        return
    with contextlib.suppress(OSError):  # nowhere left to say it
        os.write(2, direct_line(log.name, level, message.rstrip("\n")))


def park_robot(session, timeout: float = DEFAULT_SHUTDOWN_TIMEOUT) -> dict:
    """Bring the robot to its exact rest pose; {"reached_rest", "seconds", "max_error"}.

    `EngineSession.park` when the session has it; otherwise the older fallback (a faded reset, then
    waiting for the output to settle), which does not clear gaze targets or stage-2 IK.
    """
    park = getattr(session, "park", None)
    if callable(park):
        result = park(timeout=timeout)
        return dict(result) if isinstance(result, dict) else {"reached_rest": bool(result)}
    return _reset_and_settle(session, timeout)


def rest_error(session) -> tuple[float, float]:
    """(max |position - rest|, max |velocity|) over the continuous channels of the last frame."""

    emb, frame = session.embodiment, session.engine.last_frame
    if frame is None:
        return 0.0, 0.0
    mask = emb.continuous_mask
    if not mask.any():
        return 0.0, 0.0
    return (
        float(np.max(np.abs(frame.position[mask] - emb.rest[mask]))),
        float(np.max(np.abs(frame.velocity[mask]))),
    )


def _reset_and_settle(session, timeout: float) -> dict:
    t0 = time.monotonic()
    fade = min(1.0, timeout / 2)
    try:
        session.execute({"type": "reset", "fade": fade})
    except Exception as exc:  # a program without layers or clips: nothing to fade; settle as it is
        log.debug("no faded reset before settling: %s", exc, exc_info=True)
    engine, still = session.engine, 0
    while time.monotonic() - t0 < timeout:
        if engine.running:
            time.sleep(engine.dt)
        else:
            engine.tick()
        _, speed = rest_error(session)
        still = still + 1 if speed < 1e-6 else 0
        if time.monotonic() - t0 > fade and still >= 3:
            break
    error, speed = rest_error(session)
    return {
        "reached_rest": error <= REST_TOLERANCE and speed <= REST_TOLERANCE,
        "seconds": time.monotonic() - t0,
        "max_error": error,
    }


class ShutdownGate:
    """ASGI wrapper around the app: once `closing` is set, nothing new can steer the robot.

    Mutating HTTP requests get 503 `shutting_down` (reads still work), new WebSockets are refused
    (close 1001), and a message arriving on an open command socket (/ws/control) ends that client's
    session (close 1001) instead of reaching its handler. Drivers on /ws/frames, telemetry and the
    Pre-Viz keep their sockets and watch the robot go to rest. Lifespan events pass through.
    """

    def __init__(self, app, closing: threading.Event):
        self.app = app
        self.closing = closing

    async def __call__(self, scope, receive, send):
        kind = scope.get("type")
        if kind == "http" and self.closing.is_set() and scope.get("method", "GET") not in SAFE_METHODS:
            body = json.dumps({"detail": {"code": "shutting_down", "message": SHUTTING_DOWN}}).encode()
            headers = [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
                (b"connection", b"close"),
            ]
            await send({"type": "http.response.start", "status": 503, "headers": headers})
            await send({"type": "http.response.body", "body": body})
            return
        if kind == "websocket":
            if self.closing.is_set():
                await receive()  # websocket.connect
                await send({"type": "websocket.close", "code": 1001, "reason": "shutting down"})
                return
            if scope.get("path") not in COMMAND_SOCKETS:
                await self.app(scope, receive, send)
                return
            closing = self.closing

            async def gated_receive():
                message = await receive()
                if message.get("type") == "websocket.receive" and closing.is_set():
                    with contextlib.suppress(Exception):  # the client is told; its handler sees a disconnect
                        await send({"type": "websocket.close", "code": 1001, "reason": "shutting down"})
                    return {"type": "websocket.disconnect", "code": 1001, "reason": "shutting down"}
                return message

            await self.app(scope, gated_receive, send)
            return
        await self.app(scope, receive, send)


def uvicorn_server(config, shutdown: Shutdown):
    """A uvicorn Server that leaves the signals to `shutdown` (uvicorn's own handlers re-raise the signal
    after serving, which killed the process before the robot reached rest)."""
    import uvicorn  # lazy: a fast `nutty --help`

    class NuttyServer(uvicorn.Server):
        @contextlib.contextmanager
        def capture_signals(self):  # uvicorn >= 0.29
            yield

        def install_signal_handlers(self) -> None:  # uvicorn < 0.29
            pass

        def handle_exit(self, sig, frame) -> None:
            shutdown.request(signal.Signals(sig).name if sig else "exit")

    return NuttyServer(config)


class Shutdown:
    """The one way `nutty serve` stops (see the comment above): park, drain, stop the server, close.

    `install()` takes SIGTERM/SIGINT/SIGHUP; the handler only records the signal and writes a byte to a
    pipe (no locks, nothing that could deadlock the interrupted main thread). The `nutty-shutdown`
    thread, blocked on that pipe, does the work while uvicorn keeps serving, so /ws/frames drivers see
    the robot reach rest; then it tells the attached server to exit. `finish()` (main thread, after the
    server returned) closes the engine and the Pre-Viz and returns the exit status.
    """

    def __init__(
        self, session, timeout: float = DEFAULT_SHUTDOWN_TIMEOUT, *, watchdog: bool = True, exit=os._exit
    ):
        self.session = session
        self.timeout = float(timeout)
        self.closing = threading.Event()  # the API gate
        self.parked = threading.Event()  # the robot is at rest (or the park gave up), the clock stopped
        self.reasons: list[str] = []  # what asked for the shutdown, in order
        self.result: dict | None = None  # park()'s report
        self.hurried = False
        self.released = False  # the server may exit
        self.exit_code: int | None = None
        self.started_at: float | None = None
        self._server = None
        self._hooks: list = []
        self._watchdog = watchdog
        self._exit = exit
        self._rfd, self._wfd = os.pipe()
        os.set_blocking(self._wfd, False)
        self._thread = threading.Thread(target=self._main, name="nutty-shutdown", daemon=True)
        self._thread.start()

    # --- asking -------------------------------------------------------------------------------------
    def install(self, signals: tuple[int, ...] = SHUTDOWN_SIGNALS):
        """Handle `signals` (main thread only); returns a function restoring the previous handlers."""
        previous = {}
        if threading.current_thread() is threading.main_thread():
            for sig in signals:
                try:
                    if sig not in (signal.SIGINT, signal.SIGTERM) and signal.getsignal(sig) is signal.SIG_IGN:
                        continue  # nohup: a hang-up is not a request to stop
                    previous[sig] = signal.signal(sig, self._on_signal)
                except (OSError, ValueError) as exc:  # a signal this platform will not let us take
                    log.debug("cannot handle %s: %s", signal.Signals(sig).name, exc)

        def restore() -> None:
            for sig, handler in previous.items():
                with contextlib.suppress(OSError, ValueError, TypeError):
                    signal.signal(sig, handler)

        return restore

    def _on_signal(self, signum, frame) -> None:
        self.request(signal.Signals(signum).name)

    def request(self, reason: str) -> None:
        """Ask for the shutdown. Safe in a signal handler: no locks, no buffered I/O, never blocks."""
        self.reasons.append(reason)
        n = len(self.reasons)
        if n >= 2:
            self.hurried = True
            server = self._server
            if server is not None:
                server.config.timeout_graceful_shutdown = HURRIED_GRACE
                if self.released:  # the robot is at rest already and uvicorn waits for clients: stop waiting
                    server.force_exit = True
        if n == 2:
            _say(
                f"{reason} again: hurrying; the robot still finishes going to rest "
                f"(at most {self.timeout:g} s), then clients get {HURRIED_GRACE:g} s"
            )
        elif n > 2:
            _say(
                f"{reason}: already stopping; the process exits within {self.timeout + EXIT_BOUND:g} s "
                "of the first signal (SIGKILL stops it at once, without rest)"
            )
        if self._wfd >= 0:
            with contextlib.suppress(OSError):  # a full pipe: the worker is awake already
                os.write(self._wfd, b"!")

    def before_server_stops(self, fn) -> None:
        """Call `fn()` once the robot is at rest and the drivers drained, just before the HTTP server is
        told to exit (the API's WebSocket handlers finish there instead of waiting for the grace)."""
        self._hooks.append(fn)

    def attach(self, server):
        """The uvicorn server to stop once the robot is at rest; returns it."""
        self._server = server
        if self.hurried:
            server.config.timeout_graceful_shutdown = HURRIED_GRACE
        if self.released:  # the shutdown ran before the server existed: start and stop at once
            server.should_exit = True
        return server

    # --- doing ----------------------------------------------------------------------------------------
    def _main(self) -> None:
        try:
            os.read(self._rfd, 1)
        except OSError:
            return
        self.started_at = time.monotonic()
        self.closing.set()
        if self._watchdog:
            threading.Thread(target=self._watch, name="nutty-shutdown-watchdog", daemon=True).start()
        log.info(
            "%s: taking the robot to rest (at most %g s), then closing",
            self.reasons[0] if self.reasons else "stop",
            self.timeout,
        )
        self.result = self._park()
        time.sleep(0.05 if self.hurried else HOLD_SECONDS)  # park() left the engine emitting the rest pose
        try:
            self.session.engine.stop()  # the last frame is the rest pose
        except Exception:  # the shutdown goes on: close() in finish() stops the clock too
            log.warning("stopping the engine clock during shutdown failed", exc_info=True)
        self._drain(0.1 if self.hurried else DRAIN_SECONDS)
        for fn in self._hooks:
            try:
                fn()
            except Exception:  # one hook's failure must not keep the server from being released
                log.warning("a before-server-stops hook (%r) failed during shutdown", fn, exc_info=True)
        self.parked.set()
        self.released = True
        server = self._server
        if server is not None:
            server.should_exit = True

    def _park(self) -> dict:
        box: dict = {}
        t0 = time.monotonic()

        def work() -> None:
            try:
                box["result"] = park_robot(self.session, self.timeout)
            except BaseException as exc:  # reported (finish() says the robot did not reach rest), never fatal
                log.exception("parking the robot failed")
                box["error"] = f"{type(exc).__name__}: {exc}"

        worker = threading.Thread(target=work, name="nutty-park", daemon=True)
        worker.start()
        worker.join(self.timeout + PARK_SLACK)
        if "result" in box:
            return box["result"]
        error, _ = rest_error(self.session)
        return {
            "reached_rest": False,
            "seconds": time.monotonic() - t0,
            "max_error": error,
            "error": box.get("error", f"park() did not return within {self.timeout + PARK_SLACK:g} s"),
        }

    def _drain(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            if not any(len(getattr(s, "_queue", ())) for s in self.session.engine.sinks):
                break
            time.sleep(0.01)
        time.sleep(min(0.05, seconds))  # /ws/frames: the event loop sends what its sinks handed over

    def _watch(self) -> None:
        assert self.started_at is not None
        deadline = self.started_at + self.timeout + EXIT_BOUND
        while (left := deadline - time.monotonic()) > 0:
            time.sleep(min(left, 0.25))
        # straight to fd 2 (_say): whatever hangs may hold the logging handler's lock
        _say(f"shutdown did not finish within {self.timeout + EXIT_BOUND:g} s; exiting now", logging.ERROR)
        self._exit(self.exit_code if self.exit_code is not None else 1)

    def finish(self, previz=None) -> int:
        """After the server returned (main thread): make sure the robot parked, close everything;
        returns the exit status (0 at rest, 1 not)."""
        if not self.reasons:
            self.request("server stopped")
        self.parked.wait(self.timeout + PARK_SLACK + DRAIN_SECONDS + 1.0)
        try:
            self.session.engine.close()  # sinks deliver what they hold, files close
        except Exception:  # reported; the Pre-Viz still stops and the status is still returned
            log.exception("closing the drivers failed")
        if previz is not None:
            try:
                previz.stop()
            except Exception:  # reported; the exit status is the robot's, not the preview's
                log.exception("stopping the Pre-Viz failed")
        result = self.result or {"reached_rest": False}
        took = time.monotonic() - self.started_at if self.started_at is not None else 0.0
        if result.get("reached_rest"):
            self.exit_code = 0
            log.info(
                "robot at rest after %.2f s; drivers closed; stopped in %.2f s",
                float(result.get("seconds", 0.0)),
                took,
            )
        else:
            self.exit_code = 1
            why = result.get("error") or f"max error {float(result.get('max_error', float('nan'))):.3g}"
            log.warning(
                "the robot did not reach rest within %g s (%s); drivers closed; stopped in %.2f s",
                self.timeout,
                why,
                took,
            )
        wfd, self._wfd = self._wfd, -1  # a late signal must not write into a reused descriptor
        for fd in (self._rfd, wfd):
            with contextlib.suppress(OSError):
                os.close(fd)
        return self.exit_code


def rest_and_stop(session, previz=None, timeout: float = DEFAULT_SHUTDOWN_TIMEOUT) -> dict:
    """Park the robot (exact rest pose, at most `timeout` s), then close the drivers and the Pre-Viz.

    The synchronous form of what `nutty serve` does on a signal (see `Shutdown`); returns park()'s report.
    """
    result = park_robot(session, timeout)
    session.engine.close()
    if previz is not None:
        previz.stop()
    return result
