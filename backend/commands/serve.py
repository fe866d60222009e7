"""`nutty serve`: the engine clock, the HTTP/WebSocket API, the editor and the 3D Pre-Viz."""

from __future__ import annotations

import logging
import sys
from pathlib import Path

from backend.commands._common import fail, warn_unsafe
from backend.drivers import add_driver_options, build_drivers
from backend.engine.embodiment import DEFAULT_ROBOT, EmbodimentError, load_embodiment, resolve_robot_path
from backend.engine.gil import collector_paused, settle_heap
from backend.logs import add_logging_options
from backend.ros2.options import add_ros2_options, check_ros2_options

# The shutdown machinery lives in backend.shutdown; its public names stay importable from here.
from backend.shutdown import (  # noqa: F401 (re-exported: callers import them from here)
    COMMAND_SOCKETS,
    DEFAULT_SHUTDOWN_TIMEOUT,
    DRAIN_SECONDS,
    EXIT_BOUND,
    HOLD_SECONDS,
    HTTP_GRACE,
    HURRIED_GRACE,
    PARK_SLACK,
    REST_TOLERANCE,
    SAFE_METHODS,
    SHUTDOWN_SIGNALS,
    SHUTTING_DOWN,
    Shutdown,
    ShutdownGate,
    park_robot,
    rest_and_stop,
    rest_error,
    uvicorn_server,
)
from backend.zenoh_link.serve import add_serve_options as add_zenoh_options
from backend.zenoh_link.serve import banner as zenoh_banner
from backend.zenoh_link.serve import open_for_serve

log = logging.getLogger(__name__)

LOCAL_HOSTS = {"127.0.0.1", "localhost", "::1"}

MAX_SHUTDOWN_TIMEOUT = 600.0  # seconds: the largest --shutdown-timeout accepted


def register(sub) -> None:
    p = sub.add_parser(
        "serve",
        help="serve the engine, the API, the editor and the Pre-Viz",
        description="Run a robot's program live: engine clock, REST/WebSocket API, browser editor "
        "and 3D Pre-Viz. With no arguments: the bundled robot and its interactive program.",
    )
    p.add_argument("--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name")
    p.add_argument(
        "--program", default=None, help="program JSON (default: the robot's programs/interactive.json)"
    )
    p.add_argument(
        "--host", default="127.0.0.1", help="address to bind (default 127.0.0.1; others need --token)"
    )
    p.add_argument("--port", type=int, default=8000, help="HTTP port (default 8000)")
    p.add_argument("--previz-port", type=int, default=8080, help="Pre-Viz (viser) port (default 8080)")
    p.add_argument("--no-previz", action="store_true", help="run without the 3D Pre-Viz")
    p.add_argument("--rate", type=float, default=100.0, help="tick rate in Hz, 30..1000 (default 100)")
    p.add_argument(
        "--clock-cpu",
        default="off",
        metavar="CPU|auto|off",
        help="run the engine's clock on this CPU alone and keep that CPU out of idle states (Linux; "
        "keeping it awake needs root): ticks several times cheaper, at the price of one CPU always "
        "busy. 'auto': the highest CPU the process may use (default off; backend/engine/clock_cpu.py)",
    )
    add_driver_options(p)  # --osc, --record, --sim-servo and every other driver in backend/drivers
    p.add_argument(
        "--token",
        default=None,
        help="require 'Authorization: Bearer TOKEN' on mutating routes and WebSockets",
    )
    p.add_argument(
        "--allowed-origin",
        action="append",
        default=[],
        type=_origin,
        metavar="ORIGIN",
        help="also let pages from ORIGIN (scheme://host[:port]) change the robot (repeatable; "
        "the server's own http://localhost|127.0.0.1|[::1]:PORT always may)",
    )
    p.add_argument(
        "--unsafe-no-limits",
        action="store_true",
        help="switch off the engine's safety net (position, velocity, acceleration and jerk limits on "
        "every frame): logged on stderr and in /api/status; never with a robot you care about",
    )
    p.add_argument(
        "--shutdown-timeout",
        type=float,
        default=DEFAULT_SHUTDOWN_TIMEOUT,
        metavar="SECONDS",
        help="on SIGTERM/SIGINT, give the robot at most this long to reach its rest pose before the "
        f"drivers close (default {DEFAULT_SHUTDOWN_TIMEOUT:g}; the process exits within it + "
        f"{EXIT_BOUND:g} s)",
    )
    add_zenoh_options(p)  # --zenoh, --robot-id, --zenoh-connect/-listen/-mode/-config (backend/zenoh_link)
    add_ros2_options(p)  # --ros2, --ros2-namespace, --ros2-controller, ... (backend/ros2/options.py)
    add_logging_options(p)  # --log-level, --log-json (backend/logs.py)
    p.set_defaults(func=run)


def _origin(value: str) -> str:
    """argparse type of --allowed-origin: scheme://host[:port], nothing else."""
    import argparse  # lazy: a fast `nutty --help`

    from backend.security import parse_origin  # lazy: a fast `nutty --help`

    if parse_origin(value) is None:
        raise argparse.ArgumentTypeError(
            f"invalid origin {value!r}: expected scheme://host[:port], e.g. https://robot.example"
        )
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
    from backend.graph.builder import ProgramBuilder  # lazy: a fast `nutty --help`

    b = ProgramBuilder(
        "built-in idle",
        "Breathing over the rest pose or a posture, motion filter and safety limits.",
        robot=robot_name,
    )
    arousal = b.expose("arousal", default=0.0, min=-1.0, max=1.0, description="calm (-1) to excited (+1)")
    rest = b.node("rest_pose", "rest", ui={"x": 0, "y": 0})
    breathe = b.node(
        "sine",
        "breathe",
        ui={"x": 0, "y": 160},
        dofs=["stationary:*"],
        amplitude=0.04,
        frequency=0.25,
        phase_spread=0.6,
    )
    gain = b.node("gain_offset", "arousal_gain", ui={"x": 260, "y": 160}, gain=1.0)
    posture = b.node("posture", "posture", ui={"x": 260, "y": -140}, duration=1.2)
    mix = b.node(
        "layer_mixer",
        "mix",
        ui={"x": 520, "y": 60},
        layers=[
            {"name": "base"},
            {"name": "posture", "mode": "override"},
            {"name": "idle", "mode": "additive"},
        ],
    )
    nmf = b.node("nmf_stage2", "nmf", ui={"x": 780, "y": 60}, preset="D")
    safety = b.node("safety_limiter", "safety", ui={"x": 1040, "y": 60})
    b.connect(rest, mix, "out", "base").connect(posture, mix, "out", "posture").chain(breathe, gain)
    b.connect(gain, mix, "out", "idle").chain(mix, nmf, safety, b.output())
    b.doc["nodes"][-1]["ui"] = {"x": 1300, "y": 60}
    b.connect(arousal, gain, "value", "offset")
    return b.to_dict()


def run(args) -> int:
    """`nutty serve`: check the options, load the robot and program, start the clock, then serve until
    a signal or the server stops (the robot parks first: backend/shutdown.py); the exit status."""
    problem = check_options(args)
    if problem:
        return fail(problem)
    loaded = load_session(args)
    if isinstance(loaded, int):
        return loaded
    emb, session, label = loaded
    zenoh = None
    try:
        attach_drivers(session, args)
        zenoh = open_for_serve(args, emb)  # joins Zenoh before the clock starts: a taken id changes nothing
        ros2 = open_ros2(args, emb)  # joins ROS 2 before the clock starts, likewise
    except (ValueError, RuntimeError, OSError) as exc:  # a driver's port taken, Zenoh or ROS 2 refusing
        if zenoh is not None:
            zenoh.close()
        session.engine.close()
        return fail(str(exc))
    settle_heap()  # before the clock starts: the robot's program, kernels and imports never walked again
    clock_cpu = open_clock_cpu(args, session.engine)
    session.engine.start()
    previz = spawn_previz(session, args)
    # The server's own imports come after the first frame: the robot need not wait for them, and the
    # collector waits for them (its full collections would hold the clock up for tens of milliseconds).
    with collector_paused():
        import uvicorn  # after the first frame, collector paused (above)

        from backend.api import create_app  # after the first frame, collector paused (above)
    # From here on SIGTERM/SIGINT/SIGHUP park the robot and close the drivers (see Shutdown).
    shutdown = Shutdown(session, args.shutdown_timeout)
    restore_signals = shutdown.install()
    previz = ready_previz(previz)
    with collector_paused():
        app = create_app(
            session,
            token=args.token,
            previz=previz,
            allowed_origins=args.allowed_origin,
            host=args.host,
            port=args.port,
        )
    print_banner(args, emb, session, label, previz)
    hub = getattr(app.state, "hub", None)
    close_sockets = getattr(hub, "shutdown", None)
    if callable(close_sockets):  # WebSocket handlers close (1001) once the robot is at rest
        shutdown.before_server_stops(close_sockets)
    server = shutdown.attach(uvicorn_server(server_config(uvicorn, app, args, shutdown), shutdown))
    try:
        if zenoh is not None:
            # Zenoh commands are refused from the first signal on, as REST's
            zenoh.start(hub, shutdown.closing)
            print(zenoh_banner(zenoh), flush=True)
        if ros2 is not None:
            ros2.start(hub, shutdown.closing)
            print(ros2_banner(ros2), flush=True)
        server.run()
    finally:
        code = shutdown.finish(previz)  # the park's frames went out on Zenoh and ROS 2 too
        if zenoh is not None:
            zenoh.close()  # a Zenoh session left open keeps the process from exiting
        if ros2 is not None:
            ros2.close()
        if clock_cpu is not None:
            clock_cpu.close()  # after the clock stopped: the CPU goes back to its idle states
        restore_signals()
    return code


def check_options(args) -> str | None:
    """What is wrong with the options no argparse type can check alone, or None."""
    if args.host not in LOCAL_HOSTS and not args.token:
        return f"binding to {args.host} exposes the robot to the network: pass --token TOKEN"
    if not (0 < args.shutdown_timeout <= MAX_SHUTDOWN_TIMEOUT):  # also refuses NaN
        return (
            f"--shutdown-timeout must be within (0, {MAX_SHUTDOWN_TIMEOUT:g}] seconds, "
            f"got {args.shutdown_timeout:g}"
        )
    try:
        choose_clock_cpu(args.clock_cpu)
    except ValueError as exc:
        return str(exc)
    if args.unsafe_no_limits and getattr(args, "hardware", None):
        return "--unsafe-no-limits is refused with --hardware: real servos always get the safety net's frames"
    return check_ros2_options(args)


def open_clock_cpu(args, engine):
    """The clock's own CPU that `--clock-cpu` asks for, opened (the server's threads moved off it, the
    CPU kept awake where permitted), or None; the clock thread moves to it when it starts."""
    cpu = choose_clock_cpu(args.clock_cpu)
    if cpu is None or engine.clock_priority is None:
        return None
    from backend.engine.clock_cpu import ClockCpu  # lazy: a fast `nutty --help`

    engine.clock_priority.cpu = opened = ClockCpu(cpu).open()
    print(f"clock on CPU {cpu}" + ("" if opened.kept_awake else f" ({opened.note})"), flush=True)
    return opened


def choose_clock_cpu(spec: str) -> int | None:
    from backend.engine.clock_cpu import choose  # lazy: a fast `nutty --help`

    return choose(spec)


def open_ros2(args, emb):
    """The ROS 2 link the options ask for, joined (not started), or None; ValueError or Ros2Unavailable
    (a RuntimeError) saying why not."""
    if not args.ros2:
        return None
    from backend.ros2.link import Ros2Link  # lazy: rclpy loads only with --ros2
    from backend.ros2.options import controller_of  # lazy: a fast `nutty --help`

    link = Ros2Link(
        args.ros2_namespace,
        controller=controller_of(args, emb),
        read_only=args.ros2_read_only,
        hold=args.ros2_trajectory_hold,
    )
    return link.open()


def ros2_banner(link) -> str:
    from backend.ros2.options import banner  # lazy: a fast `nutty --help`

    return banner(link)


def load_session(args):
    """(embodiment, EngineSession with its program loaded, the program's label), or the exit status
    after saying why not (the clock is not started)."""
    from backend.session import EngineSession, SessionError  # lazy: a fast `nutty --help`

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
            source, label = (
                (path.read_text(), str(path)) if path else (builtin_idle(emb.name), "built-in idle")
            )
        session.load_program(source)
    except OSError as exc:
        return fail(f"cannot read program: {exc}")
    except SessionError as exc:
        print(exc.render(), file=sys.stderr)
        return 1
    return emb, session, label


def spawn_previz(session, args):
    """The Pre-Viz child process, starting (it imports viser while the server imports), or None with
    --no-previz."""
    if args.no_previz:
        return None
    from backend.previz_process import PreVizProcess  # lazy: a fast `nutty --help`

    # Loopback only, always: the network reaches it through the API's /previz/ proxy and token. In its
    # own process: viser never holds the clock's interpreter lock (backend/previz_process.py).
    return PreVizProcess(
        session,
        port=args.previz_port,
        allowed_origins=args.allowed_origin,
        proxy_only=args.token is not None,
    )


def ready_previz(previz):
    """The Pre-Viz once it listens and is fed frames, or None when it could not start (the robot and
    the API go on without it)."""
    if previz is None:
        return None
    from backend.previz_process import PreVizUnavailable  # lazy: a fast `nutty --help`

    try:
        previz.wait_ready()
        previz.start()
    except PreVizUnavailable as exc:
        log.warning("the Pre-Viz did not start (%s); serving without it", exc)
        previz.stop()
        return None
    return previz


def print_banner(args, emb, session, label: str, previz) -> None:
    """Where the editor, the API and the Pre-Viz are (stdout: what a person or a script reads)."""
    shown = "localhost" if args.host in LOCAL_HOSTS else args.host
    apu = session.engine.apu  # None once a fault (a servo's, a simulated contact) has dropped the program
    level = f"level {apu.level}" if apu is not None else "stopped by a fault before the server started"
    print(
        f"Nutty: robot '{emb.name}', program '{session.program.name}' ({label}), {level}, "
        f"{session.engine.rate:g} Hz",
        flush=True,
    )
    print(f"  editor   http://{shown}:{args.port}/", flush=True)
    print(f"  API      http://{shown}:{args.port}/docs", flush=True)
    if previz:
        direct = "" if args.token is not None else f" (locally also http://127.0.0.1:{previz.port}/)"
        print(f"  Pre-Viz  http://{shown}:{args.port}/previz/{direct}", flush=True)


def server_config(uvicorn, app, args, shutdown):
    """uvicorn's Config for the API behind the shutdown gate. Its loggers follow --log-level through
    the root logger (backend/logs.py; log_config=None: uvicorn installs no handlers of its own), and
    its per-request access lines appear at debug only."""
    level = getattr(args, "log_level", "warning")
    return uvicorn.Config(
        ShutdownGate(app, shutdown.closing),
        host=args.host,
        port=args.port,
        log_config=None,
        log_level=level,
        access_log=level == "debug",
        timeout_graceful_shutdown=HTTP_GRACE,
        ws_per_message_deflate=False,
    )


def attach_drivers(session, args) -> None:
    """The drivers the command line asks for (each driver declares its own option: backend/drivers).
    A driver with `prepare(engine)` (real servos: connect, start from the measured pose) gets it before
    the clock's first tick; its error stops the start."""
    for sink in build_drivers(session.embodiment, args):
        session.engine.add_sink(sink)
        prepare = getattr(sink, "prepare", None)
        if callable(prepare):
            prepare(session.engine)
