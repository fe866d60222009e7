"""`nutty fleet`: the live robots on Zenoh, their status, commands to one or many, their events, and a
Zenoh router for setups that want one (backend/fleet.py, docs/fleet.md).

    nutty fleet list                          live robot ids, one per line
    nutty fleet status [PATTERN]              their status (JSON, by robot id)
    nutty fleet send ID|PATTERN COMMAND-JSON  one command (the REST union) to a robot or a pattern
    nutty fleet watch [PATTERN]               events, robots appearing and vanishing (JSON lines)
    nutty fleet router                        forward Zenoh traffic for peers and clients (tcp/0.0.0.0:7447)
"""

from __future__ import annotations

import contextlib
import json
import sys
import threading

from backend.commands._common import fail
from backend.safe_json import JsonSafetyError, dumps, loads
from backend.zenoh_link.keys import RobotIdError, check_pattern
from backend.zenoh_link.session import ZenohOptions, ZenohSetupError, add_zenoh_options

ROUTER_ENDPOINT = "tcp/0.0.0.0:7447"  # Zenoh's usual port


def register(sub) -> None:
    p = sub.add_parser(
        "fleet",
        help="list, watch and command the robots on Zenoh",
        description="Every Nutty engine on Zenoh (nutty serve --zenoh): list the live ones, read their "
        "status, send a command to one robot or a pattern (museum-*), watch their events.",
    )
    fs = p.add_subparsers(dest="fleet_command", metavar="ACTION", required=True)

    def action(name: str, help: str):
        a = fs.add_parser(name, help=help, description=help)
        add_zenoh_options(a)
        a.add_argument(
            "--timeout",
            type=float,
            default=5.0,
            metavar="SECONDS",
            help="wait this long for answers (default 5)",
        )
        return a

    a = action("list", "the live robots' ids (liveliness), one per line")
    a.add_argument("pattern", nargs="?", default="*", help="only ids matching this pattern (e.g. museum-*)")
    a.add_argument("--json", action="store_true", help="print a JSON list")
    a.add_argument(
        "--wait",
        type=int,
        default=0,
        metavar="N",
        help="wait up to --timeout for at least N robots before listing",
    )
    a.set_defaults(func=run_list)

    a = action("status", "the status of every robot a pattern matches (JSON by robot id)")
    a.add_argument("pattern", nargs="?", default="*", help="robot id or pattern (default: all)")
    a.set_defaults(func=run_status)

    a = action("send", "send one command to a robot or to every robot a pattern matches")
    a.add_argument("target", metavar="ID|PATTERN", help="a robot id, or a pattern such as museum-* or *")
    a.add_argument(
        "command",
        metavar="COMMAND-JSON",
        help='a command of the REST union, e.g. \'{"type": "say", "text": "hello"}\'',
    )
    a.set_defaults(func=run_send)

    a = action("watch", "print events, acks and errors, and robots appearing and vanishing, as JSON lines")
    a.add_argument("pattern", nargs="?", default="*", help="robot id or pattern (default: all)")
    a.add_argument("--status", action="store_true", help="also print every robot's status each second")
    a.add_argument("--seconds", type=float, default=None, help="stop after this long (default: until Ctrl-C)")
    a.set_defaults(func=run_watch)

    a = action("router", f"run a Zenoh router (default listening on {ROUTER_ENDPOINT}) for peers and clients")
    a.set_defaults(func=run_router)


def _open(args, **overrides):
    from backend.fleet import Fleet  # lazy: a fast `nutty --help`

    options = ZenohOptions.from_args(args)
    for name, value in overrides.items():
        setattr(options, name, value)
    return Fleet(options, timeout=args.timeout)


def _with_fleet(args, body) -> int:
    """Check the timeout and pattern, open the fleet, run `body(fleet)`, always close the session."""
    if not 0 < args.timeout <= 600:
        return fail(f"--timeout must be within (0, 600] seconds, got {args.timeout:g}")
    pattern = getattr(args, "pattern", None) or getattr(args, "target", None)
    try:
        if pattern is not None:
            check_pattern(pattern)
        fleet = _open(args)
    except (RobotIdError, ZenohSetupError) as exc:
        return fail(str(exc))
    try:
        return body(fleet)
    finally:
        fleet.close()


def run_list(args) -> int:
    def body(fleet) -> int:
        if args.wait > 0:
            with contextlib.suppress(TimeoutError):  # fewer came than waited for: list whoever is there
                fleet.wait_for(args.wait, args.pattern, timeout=args.timeout)
        ids = fleet.robots(args.pattern)
        print(json.dumps(ids) if args.json else "\n".join(ids), flush=True)
        return 0

    return _with_fleet(args, body)


def run_status(args) -> int:
    from backend.fleet import is_error  # lazy: a fast `nutty --help`

    def body(fleet) -> int:
        answers = fleet.status(args.pattern)
        print(dumps(answers), flush=True)
        return 1 if any(is_error(a) for a in answers.values()) else 0

    return _with_fleet(args, body)


def run_send(args) -> int:
    from backend.fleet import is_error  # lazy: a fast `nutty --help`

    try:
        command = loads(args.command)
    except JsonSafetyError as exc:
        return fail(f"COMMAND-JSON: {exc}")
    if not isinstance(command, dict):
        return fail('COMMAND-JSON must be a JSON object with a "type", e.g. {"type": "say", "text": "hello"}')

    def body(fleet) -> int:
        answers = fleet.send(args.target, command)
        if not answers:
            print(f"nutty: no live robot matches '{args.target}'", file=sys.stderr)
            return 1
        print(dumps(answers), flush=True)
        return 1 if any(is_error(a) for a in answers.values()) else 0

    return _with_fleet(args, body)


def run_watch(args) -> int:
    if args.seconds is not None and not args.seconds > 0:
        return fail(f"--seconds must be > 0, got {args.seconds:g}")

    def body(fleet) -> int:
        with fleet.watch(args.pattern, seconds=args.seconds, status=args.status) as watch:
            try:
                for item in watch:
                    print(dumps(item), flush=True)
            except KeyboardInterrupt:
                pass
        return 0

    return _with_fleet(args, body)


def run_router(args) -> int:
    from backend.zenoh_link.session import ZenohOptions  # lazy: a fast `nutty --help`

    options = ZenohOptions.from_args(args)
    options.mode = "router"
    options.default_listen = [ROUTER_ENDPOINT]  # a router is there to be reached; a config's endpoints win
    try:
        warning = options.exposure_warning()
        session = options.open()
    except ZenohSetupError as exc:
        return fail(str(exc))
    if warning:
        print(f"nutty fleet router: warning: {warning}", file=sys.stderr, flush=True)
    stop = threading.Event()
    try:
        print(f"nutty fleet router: {options.describe()}; Ctrl-C to stop", flush=True)
        try:
            while not stop.wait(3600):
                pass
        except KeyboardInterrupt:
            pass
    finally:
        session.close()
    return 0
