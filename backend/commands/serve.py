"""`nutty serve`: the engine clock, the HTTP/WebSocket API, the editor and the 3D Pre-Viz."""

from __future__ import annotations

import contextlib
import ipaddress
import json
import os
import signal
import sys
import threading
import time
from pathlib import Path

from backend.commands._common import fail, warn_unsafe
from backend.engine.embodiment import DEFAULT_ROBOT, EmbodimentError, load_embodiment, resolve_robot_path

LOCAL_HOSTS = {"127.0.0.1", "localhost", "::1"}

# Shutdown budget (seconds; see `Shutdown`): the robot gets --shutdown-timeout to reach rest, the
# HTTP server HTTP_GRACE more for open requests and WebSockets, and a watchdog ends the process
# EXIT_BOUND after the shutdown-timeout whatever hangs.
DEFAULT_SHUTDOWN_TIMEOUT = 3.0
MAX_SHUTDOWN_TIMEOUT = 600.0
PARK_SLACK = 1.0  # how much longer than its own timeout park() may take before it is given up on
HOLD_SECONDS = 0.3  # after the park: the clock keeps emitting the rest pose this long, so every driver
#                     ends on a run of rest frames even if it drops some
DRAIN_SECONDS = 0.5  # then, clock stopped: time for the drivers to take the last frames off their queues
HTTP_GRACE = 1.5  # uvicorn's timeout_graceful_shutdown: then hung clients are cancelled
HURRIED_GRACE = 0.25  # the same after a second signal
EXIT_BOUND = 4.5  # watchdog: the process is gone at most shutdown-timeout + EXIT_BOUND after the first signal
REST_TOLERANCE = 1e-9


def register(sub) -> None:
    p = sub.add_parser("serve", help="serve the engine, the API, the editor and the Pre-Viz",
                       description="Run a robot's program live: engine clock, REST/WebSocket API, browser editor "
                                   "and 3D Pre-Viz. With no arguments: the bundled robot and its interactive program.")
    p.add_argument("--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name")
    p.add_argument("--program", default=None, help="program JSON (default: the robot's programs/interactive.json)")
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1; others need --token)")
    p.add_argument("--port", type=int, default=8000, help="HTTP port (default 8000)")
    p.add_argument("--previz-port", type=int, default=8080, help="Pre-Viz (viser) port (default 8080)")
    p.add_argument("--no-previz", action="store_true", help="run without the 3D Pre-Viz")
    p.add_argument("--rate", type=float, default=100.0, help="tick rate in Hz, 30..1000 (default 100)")
    p.add_argument("--osc", default=None, metavar="HOST:PORT", help="also send every frame as OSC to HOST:PORT")
    p.add_argument("--record", default=None, metavar="FILE.jsonl", help="record every frame to a JSONL file")
    p.add_argument("--sim-servo", type=float, default=8.0, metavar="HZ",
                   help="bandwidth of the simulated servos whose tracking error /api/status reports (0 = off)")
    p.add_argument("--token", default=None, help="require 'Authorization: Bearer TOKEN' on mutating routes and WebSockets")
    p.add_argument("--allowed-origin", action="append", default=[], type=_origin, metavar="ORIGIN",
                   help="also let pages from ORIGIN (scheme://host[:port]) change the robot (repeatable; "
                        "the server's own http://localhost|127.0.0.1|[::1]:PORT always may)")
    p.add_argument("--unsafe-no-limits", action="store_true",
                   help="switch off the engine's safety net (position, velocity, acceleration and jerk limits on "
                        "every frame): logged on stderr and in /api/status; never with a robot you care about")
    p.add_argument("--shutdown-timeout", type=float, default=DEFAULT_SHUTDOWN_TIMEOUT, metavar="SECONDS",
                   help="on SIGTERM/SIGINT, give the robot at most this long to reach its rest pose before the "
                        f"drivers close (default {DEFAULT_SHUTDOWN_TIMEOUT:g}; the process exits within it + "
                        f"{EXIT_BOUND:g} s)")
    p.set_defaults(func=run)


def _origin(value: str) -> str:
    """argparse type of --allowed-origin: scheme://host[:port], nothing else."""
    import argparse

    from backend.security import parse_origin

    if parse_origin(value) is None:
        raise argparse.ArgumentTypeError(f"invalid origin {value!r}: expected scheme://host[:port], e.g. https://robot.example")
    return value.rstrip("/")


def default_program_path(robot_folder: Path | None) -> Path | None:
    if robot_folder is None or not (robot_folder / "programs").is_dir():
        return None
    preferred = robot_folder / "programs" / "interactive.json"
    if preferred.exists():
        return preferred
    found = sorted((robot_folder / "programs").glob("*.json"))
    return found[0] if found else None


def builtin_idle(robot_name: str) -> dict:
    """A small idle program any robot can run: breathing over the rest pose or a posture, filtered."""
    from backend.graph.builder import ProgramBuilder

    b = ProgramBuilder("built-in idle", "Breathing over the rest pose or a posture, motion filter and safety limits.",
                       robot=robot_name)
    arousal = b.expose("arousal", default=0.0, min=-1.0, max=1.0, description="calm (-1) to excited (+1)")
    rest = b.node("rest_pose", "rest", ui={"x": 0, "y": 0})
    breathe = b.node("sine", "breathe", ui={"x": 0, "y": 160}, dofs=["stationary:*"], amplitude=0.04,
                     frequency=0.25, phase_spread=0.6)
    gain = b.node("gain_offset", "arousal_gain", ui={"x": 260, "y": 160}, gain=1.0)
    posture = b.node("posture", "posture", ui={"x": 260, "y": -140}, duration=1.2)
    mix = b.node("layer_mixer", "mix", ui={"x": 520, "y": 60},
                 layers=[{"name": "base"}, {"name": "posture", "mode": "override"}, {"name": "idle", "mode": "additive"}])
    nmf = b.node("nmf_stage2", "nmf", ui={"x": 780, "y": 60}, preset="D")
    safety = b.node("safety_limiter", "safety", ui={"x": 1040, "y": 60})
    b.connect(rest, mix, "out", "base").connect(posture, mix, "out", "posture").chain(breathe, gain)
    b.connect(gain, mix, "out", "idle").chain(mix, nmf, safety, b.output())
    b.doc["nodes"][-1]["ui"] = {"x": 1300, "y": 60}
    b.connect(arousal, gain, "value", "offset")
    return b.to_dict()


def run(args) -> int:
    import uvicorn

    from backend.api import create_app
    from backend.session import EngineSession, SessionError

    if args.host not in LOCAL_HOSTS and not args.token:
        return fail(f"binding to {args.host} exposes the robot to the network: pass --token TOKEN")
    if not (0 < args.shutdown_timeout <= MAX_SHUTDOWN_TIMEOUT):  # also refuses NaN
        return fail(f"--shutdown-timeout must be within (0, {MAX_SHUTDOWN_TIMEOUT:g}] seconds, "
                    f"got {args.shutdown_timeout:g}")
    try:
        emb = load_embodiment(args.robot)
    except EmbodimentError as exc:
        return fail(str(exc))
    folder = resolve_robot_path(args.robot)
    folder = folder if folder.is_dir() else None
    try:
        if args.unsafe_no_limits:
            warn_unsafe()
        session = EngineSession.create(emb, rate=args.rate, safety=not args.unsafe_no_limits)
        if args.program:
            source, label = Path(args.program).read_text(), args.program
        else:
            path = default_program_path(folder)
            source, label = (path.read_text(), str(path)) if path else (builtin_idle(emb.name), "built-in idle")
        session.load_program(source)
    except OSError as exc:
        return fail(f"cannot read program: {exc}")
    except SessionError as exc:
        print(exc.render(), file=sys.stderr)
        return 1
    try:
        attach_drivers(session, args)
    except ValueError as exc:
        return fail(str(exc))
    session.engine.start()
    # From here on SIGTERM/SIGINT/SIGHUP park the robot and close the drivers (see Shutdown).
    shutdown = Shutdown(session, args.shutdown_timeout)
    restore_signals = shutdown.install()
    previz = None
    if not args.no_previz:
        from backend.previz import PreViz

        # Loopback only, always: the network reaches it through the API's /previz/ proxy and token.
        previz = PreViz(session, port=args.previz_port, allowed_origins=args.allowed_origin).start()
    shown = "localhost" if args.host in LOCAL_HOSTS else args.host
    app = create_app(session, token=args.token, previz=previz, allowed_origins=args.allowed_origin,
                     host=args.host, port=args.port)
    print(f"Nutty: robot '{emb.name}', program '{session.program.name}' ({label}), level {session.engine.apu.level}, "
          f"{session.engine.rate:g} Hz", flush=True)
    print(f"  editor   http://{shown}:{args.port}/", flush=True)
    print(f"  API      http://{shown}:{args.port}/docs", flush=True)
    if previz:
        print(f"  Pre-Viz  http://{shown}:{args.port}/previz/ (locally also http://127.0.0.1:{previz.port}/)", flush=True)
    hub = getattr(app.state, "hub", None)
    if callable(getattr(hub, "shutdown", None)):
        shutdown.before_server_stops(hub.shutdown)  # WebSocket handlers close (1001) once the robot is at rest
    server = shutdown.attach(uvicorn_server(uvicorn.Config(
        ShutdownGate(app, shutdown.closing), host=args.host, port=args.port, log_level="warning",
        timeout_graceful_shutdown=HTTP_GRACE), shutdown))
    try:
        server.run()
    finally:
        code = shutdown.finish(previz)
        restore_signals()
    return code


def attach_drivers(session, args) -> None:
    """Drivers from the command line: OSC, a recorder, simulated servos (see backend/drivers)."""
    from backend.drivers import FrameRecorder, OscDriver, SimulatedServos

    emb = session.embodiment
    if args.osc:
        host, _, port = args.osc.rpartition(":")
        if not host or not port.isdigit():
            raise ValueError(f"--osc expects HOST:PORT, got '{args.osc}'")
        session.engine.add_sink(OscDriver(emb, host, int(port)))
    if args.record:
        session.engine.add_sink(FrameRecorder(emb, args.record))
    if args.sim_servo and args.sim_servo > 0:
        session.engine.add_sink(SimulatedServos(emb, bandwidth_hz=args.sim_servo))


def rest_and_stop(session, previz=None, timeout: float = DEFAULT_SHUTDOWN_TIMEOUT) -> dict:
    """Park the robot (exact rest pose, at most `timeout` s), then close the drivers and the Pre-Viz.

    The synchronous form of what `nutty serve` does on a signal (see `Shutdown`); returns park()'s report.
    """
    result = park_robot(session, timeout)
    session.engine.close()
    if previz is not None:
        previz.stop()
    return result


# --------------------------------------------------------------------------------------------------
# Shutdown
#
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


def _say(message: str) -> None:
    """Write a line to stderr without Python's buffered streams (safe from a signal handler)."""
    try:
        os.write(2, (message.rstrip("\n") + "\n").encode(errors="replace"))
    except OSError:
        pass


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
    import numpy as np

    emb, frame = session.embodiment, session.engine.last_frame
    if frame is None:
        return 0.0, 0.0
    mask = emb.continuous_mask
    if not mask.any():
        return 0.0, 0.0
    return (float(np.max(np.abs(frame.position[mask] - emb.rest[mask]))),
            float(np.max(np.abs(frame.velocity[mask]))))


def _reset_and_settle(session, timeout: float) -> dict:
    t0 = time.monotonic()
    fade = min(1.0, timeout / 2)
    try:
        session.execute({"type": "reset", "fade": fade})
    except Exception:  # a program without layers or clips: nothing to fade
        pass
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
    return {"reached_rest": error <= REST_TOLERANCE and speed <= REST_TOLERANCE,
            "seconds": time.monotonic() - t0, "max_error": error}


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
            headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                       (b"connection", b"close")]
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


def uvicorn_server(config, shutdown: "Shutdown"):
    """A uvicorn Server that leaves the signals to `shutdown` (uvicorn's own handlers re-raise the signal
    after serving, which killed the process before the robot reached rest)."""
    import uvicorn

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

    def __init__(self, session, timeout: float = DEFAULT_SHUTDOWN_TIMEOUT, *, watchdog: bool = True,
                 exit=os._exit):
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
                except (OSError, ValueError):
                    pass

        def restore() -> None:
            for sig, handler in previous.items():
                try:
                    signal.signal(sig, handler)
                except (OSError, ValueError, TypeError):
                    pass

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
            _say(f"nutty: {reason} again: hurrying; the robot still finishes going to rest "
                 f"(at most {self.timeout:g} s), then clients get {HURRIED_GRACE:g} s")
        elif n > 2:
            _say(f"nutty: {reason}: already stopping; the process exits within {self.timeout + EXIT_BOUND:g} s "
                 "of the first signal (SIGKILL stops it at once, without rest)")
        if self._wfd >= 0:
            try:
                os.write(self._wfd, b"!")
            except OSError:  # a full pipe: the worker is awake already
                pass

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
        _say(f"nutty: {self.reasons[0] if self.reasons else 'stop'}: taking the robot to rest "
             f"(at most {self.timeout:g} s), then closing")
        self.result = self._park()
        time.sleep(0.05 if self.hurried else HOLD_SECONDS)  # park() left the engine emitting the rest pose
        try:
            self.session.engine.stop()  # the last frame is the rest pose
        except Exception:
            pass
        self._drain(0.1 if self.hurried else DRAIN_SECONDS)
        for fn in self._hooks:
            try:
                fn()
            except Exception as exc:
                _say(f"nutty: during shutdown: {type(exc).__name__}: {exc}")
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
            except BaseException as exc:  # reported, never fatal: the shutdown goes on
                box["error"] = f"{type(exc).__name__}: {exc}"

        worker = threading.Thread(target=work, name="nutty-park", daemon=True)
        worker.start()
        worker.join(self.timeout + PARK_SLACK)
        if "result" in box:
            return box["result"]
        error, _ = rest_error(self.session)
        return {"reached_rest": False, "seconds": time.monotonic() - t0, "max_error": error,
                "error": box.get("error", f"park() did not return within {self.timeout + PARK_SLACK:g} s")}

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
        _say(f"nutty: shutdown did not finish within {self.timeout + EXIT_BOUND:g} s; exiting now")
        self._exit(self.exit_code if self.exit_code is not None else 1)

    def finish(self, previz=None) -> int:
        """After the server returned (main thread): make sure the robot parked, close everything;
        returns the exit status (0 at rest, 1 not)."""
        if not self.reasons:
            self.request("server stopped")
        self.parked.wait(self.timeout + PARK_SLACK + DRAIN_SECONDS + 1.0)
        try:
            self.session.engine.close()  # sinks deliver what they hold, files close
        except Exception as exc:
            _say(f"nutty: closing the drivers: {type(exc).__name__}: {exc}")
        if previz is not None:
            try:
                previz.stop()
            except Exception as exc:
                _say(f"nutty: stopping the Pre-Viz: {type(exc).__name__}: {exc}")
        result = self.result or {"reached_rest": False}
        took = time.monotonic() - self.started_at if self.started_at is not None else 0.0
        if result.get("reached_rest"):
            self.exit_code = 0
            _say(f"nutty: robot at rest after {float(result.get('seconds', 0.0)):.2f} s; drivers closed; "
                 f"stopped in {took:.2f} s")
        else:
            self.exit_code = 1
            why = result.get("error") or f"max error {float(result.get('max_error', float('nan'))):.3g}"
            _say(f"nutty: warning: the robot did not reach rest within {self.timeout:g} s ({why}); "
                 f"drivers closed; stopped in {took:.2f} s")
        wfd, self._wfd = self._wfd, -1  # a late signal must not write into a reused descriptor
        for fd in (self._rfd, wfd):
            try:
                os.close(fd)
            except OSError:
                pass
        return self.exit_code
