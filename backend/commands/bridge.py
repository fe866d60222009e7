"""`nutty bridge`: on the robot's own computer, follow one engine's frames over Zenoh and feed a local
driver; bring the robot to rest by itself when the frames stop (backend/bridge.py, docs/fleet.md)."""

from __future__ import annotations

import argparse
import json
import logging
import signal
import threading

from backend.bridge import DEFAULT_TIMEOUT, MAX_TIMEOUT, MIN_TIMEOUT
from backend.commands._common import fail
from backend.drivers import DRIVER_OPTIONS, add_driver_options, build_driver
from backend.drivers.registry import engine_only
from backend.logs import add_logging_options
from backend.ros2.options import add_ros2_options, check_ros2_options
from backend.shutdown import DEFAULT_SHUTDOWN_TIMEOUT, SHUTDOWN_SIGNALS
from backend.zenoh_link.keys import robot_id_arg
from backend.zenoh_link.session import add_zenoh_options

REPORT_SECONDS = 5.0  # s between log lines of latency and gaps (0: only the final summary)
WAIT_SECONDS = 60.0  # s to wait at start for the engine to answer

log = logging.getLogger("backend.bridge")  # the relay's own logger: one name for everything the bridge says


def register(sub) -> None:
    p = sub.add_parser(
        "bridge",
        help="on the robot's computer: follow an engine's frames over Zenoh into a driver",
        description="Follow one robot's frames over Zenoh and feed them to local drivers, through the "
        "robot's limits; when frames stop for --timeout seconds, take the robot to rest by "
        "itself, and blend back when they return. Logs latency and gaps.",
    )
    p.add_argument(
        "--zenoh", action="store_true", required=True, help="follow the robot over Zenoh (required)"
    )
    p.add_argument("--robot-id", required=True, type=robot_id_arg, metavar="ID", help="the robot to follow")
    p.add_argument(
        "--driver",
        action="append",
        default=[],
        choices=sorted(DRIVER_OPTIONS),
        metavar="NAME",
        help=f"a driver to feed ({', '.join(sorted(DRIVER_OPTIONS))}; repeatable); its option below "
        "says where (e.g. --driver osc --osc 10.0.0.5:9000); at least one, or --ros2",
    )
    add_driver_options(p)  # every driver's own option, from the registry: a new driver needs no edit here
    p.add_argument(
        "--robot",
        required=True,
        help="the robot folder, URDF or bundled name: its limits are the bridge's own, never taken "
        "from the network",
    )
    p.add_argument(
        "--rate", type=float, default=None, help="the engine's tick rate in Hz (default: ask the engine)"
    )
    p.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT,
        metavar="SECONDS",
        help=f"take the robot to rest after this long without a frame (default {DEFAULT_TIMEOUT:g})",
    )
    p.add_argument(
        "--wait",
        type=float,
        default=WAIT_SECONDS,
        metavar="SECONDS",
        help=f"wait this long at start for the engine to answer (default {WAIT_SECONDS:g})",
    )
    p.add_argument(
        "--report",
        type=float,
        default=REPORT_SECONDS,
        metavar="SECONDS",
        help=f"log latency and gaps this often (default {REPORT_SECONDS:g}; 0: only at the end)",
    )
    p.add_argument(
        "--shutdown-timeout",
        type=float,
        default=DEFAULT_SHUTDOWN_TIMEOUT,
        metavar="SECONDS",
        help=f"on SIGTERM/SIGINT, give the robot this long to reach rest (default {DEFAULT_SHUTDOWN_TIMEOUT:g})",
    )
    add_zenoh_options(p)
    add_ros2_options(p, serve=False)  # --ros2: the relayed frames on ROS 2 too (backend/ros2/options.py)
    add_logging_options(p)  # --log-level, --log-json (backend/logs.py)
    p.set_defaults(func=run)


def chosen_drivers(args: argparse.Namespace) -> list[tuple[str, object]]:
    """(name, option value) of each --driver; ValueError for a driver without its option, or an option
    given for a driver not chosen."""
    names = list(dict.fromkeys(args.driver))
    out = []
    refused = engine_only(args, "`nutty bridge`")
    if refused:
        raise ValueError(refused)
    for name in names:
        opt = DRIVER_OPTIONS[name]
        value = getattr(args, opt.dest, None)
        if value is None:
            raise ValueError(f"--driver {name} needs --{name} {opt.metavar}")
        if not opt.enabled(value):
            raise ValueError(f"--{name} {value} turns the {name} driver off, but --driver {name} asks for it")
        out.append((name, value))
    for name, opt in DRIVER_OPTIONS.items():
        if name not in names and getattr(args, opt.dest, None) not in (None, opt.default):
            raise ValueError(f"--{name} is given but not --driver {name}")
    return out


def _check(args: argparse.Namespace) -> str | None:
    if not MIN_TIMEOUT <= args.timeout <= MAX_TIMEOUT:
        return f"--timeout must be within {MIN_TIMEOUT:g}..{MAX_TIMEOUT:g} seconds, got {args.timeout:g}"
    if args.rate is not None and not 30.0 <= args.rate <= 1000.0:
        return f"--rate must be within 30..1000 Hz, got {args.rate:g}"
    for flag, value in (("--wait", args.wait), ("--shutdown-timeout", args.shutdown_timeout)):
        if not 0 < value <= 600:
            return f"{flag} must be within (0, 600] seconds, got {value:g}"
    if not 0 <= args.report <= 3600:
        return f"--report must be within 0..3600 seconds, got {args.report:g}"
    if not args.driver and not args.ros2:
        return "say where the frames go: --driver NAME (with its option) and/or --ros2"
    return check_ros2_options(args)


def run(args) -> int:
    from backend.engine.embodiment import EmbodimentError, load_embodiment  # lazy: a fast `nutty --help`
    from backend.zenoh_link.session import ZenohOptions, ZenohSetupError  # lazy: a fast `nutty --help`

    problem = _check(args)
    if problem:
        return fail(problem)
    try:
        drivers = chosen_drivers(args)
        robot = load_embodiment(args.robot)
        session = ZenohOptions.from_args(args).open()
    except (ValueError, EmbodimentError, ZenohSetupError) as exc:
        return fail(str(exc))
    try:  # from here on the session is closed on every path (an open one keeps the process alive)
        return _follow(session, args, drivers, robot)
    finally:
        session.close()


def _follow(session, args, drivers, robot) -> int:
    from backend.bridge import FrameRelay, report_line  # lazy: a fast `nutty --help`
    from backend.zenoh_link.follow import follow_frames, wait_for_engine  # lazy: a fast `nutty --help`

    def waiting(message: str) -> None:
        log.info(message.removeprefix("nutty bridge: "))  # the logger's name says who speaks

    signals = _Signals()
    restore = signals.install()
    relay = subscriber = ros = None
    sinks = []
    try:
        try:
            rate = wait_for_engine(
                session, args.robot_id, rate=args.rate, wait=args.wait, log=waiting, stop=signals.first
            )
            if signals.first.is_set():  # stopped while waiting: nothing was ever sent
                return 0
            sinks = [build_driver(DRIVER_OPTIONS[name], robot, value, args) for name, value in drivers]
            if args.ros2:
                ros = _ros2_sink(args, robot)
                sinks.append(ros[1])
            relay = FrameRelay(robot, rate, sinks, timeout=args.timeout)
        except (TimeoutError, ValueError, OSError, RuntimeError) as exc:
            return fail(str(exc), 1)
        relay.start()
        subscriber = follow_frames(session, args.robot_id, relay.receive, relay.reject)
        print(
            f"nutty bridge: following robot '{args.robot_id}' ({robot.name}, {rate:g} Hz) into "
            f"{', '.join(s.name for s in sinks)}; rest after {args.timeout:g} s without frames",
            flush=True,
        )
        while not signals.first.wait(args.report or 3600.0):
            log.info(report_line(args.robot_id, relay.summary()))
        subscriber.undeclare()
        subscriber = None
        at_rest = True if signals.second.is_set() else relay.park(args.shutdown_timeout)
        if at_rest:
            log.info("robot at rest; closing")
        else:
            log.warning("the robot did not reach rest; closing")
        return 0 if at_rest else 1
    finally:
        if subscriber is not None:
            subscriber.undeclare()
        if relay is not None:
            relay.stop()
            summary = relay.summary()
            log.info(report_line(args.robot_id, summary))
            print("nutty bridge: summary " + json.dumps(summary), flush=True)
        for sink in sinks:
            sink.close()
        if ros is not None:
            ros[0].close()
        restore()


def _ros2_sink(args, robot):
    """(the ROS node, a sink publishing the relayed frames: /joint_states, /tf, the controller's topic,
    frame events on NS/events); Ros2Unavailable (a RuntimeError) or ValueError saying why not."""
    from backend.ros2.link import event_publisher  # lazy: rclpy loads only with --ros2
    from backend.ros2.node import RosNode  # lazy: as above
    from backend.ros2.options import controller_of  # lazy: a fast `nutty --help`
    from backend.ros2.outputs import FramePublisher, message_types  # lazy: as above

    controller = controller_of(args, robot)
    message_types()  # every message package there, or say which is missing
    node = RosNode("nutty_bridge")
    try:
        events = event_publisher(node.node, args.ros2_namespace)
        sink = FramePublisher(robot, node.node, controller=controller, events=events)
    except Exception:
        node.close()
        raise
    log.info("ROS 2: publishing the relayed frames (%s)", ", ".join(sink.topics()))
    return node, sink


class _Signals:
    """SIGTERM/SIGINT/SIGHUP: the first asks the bridge to take the robot to rest and stop, the second to
    stop without waiting for rest."""

    def __init__(self):
        self.first, self.second = threading.Event(), threading.Event()

    def _on_signal(self, signum, frame) -> None:
        (self.second if self.first.is_set() else self.first).set()

    def install(self):
        previous = {}
        if threading.current_thread() is threading.main_thread():
            for sig in SHUTDOWN_SIGNALS:
                if sig not in (signal.SIGINT, signal.SIGTERM) and signal.getsignal(sig) is signal.SIG_IGN:
                    continue  # nohup
                previous[sig] = signal.signal(sig, self._on_signal)

        def restore() -> None:
            for sig, handler in previous.items():
                signal.signal(sig, handler)

        return restore
