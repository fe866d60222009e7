"""`nutty play FILE.mcap|FILE.jsonl --robot R [--speed S] [--loop] <driver options>`: replay a recording
to drivers through the robot's safety net (backend/recording/player.py): from rest to the recording's
first pose within the limits, the frames at their own times, then back to rest.

Exit status: 0 played (or stopped by a signal) and parked; 1 the recording cannot be played on this
robot (unreadable, other channels, no frames) or the robot did not reach rest; 2 a usage error (a
missing file, an unknown robot, a bad option).
"""

from __future__ import annotations

import argparse
import json
import signal
import threading
from pathlib import Path

from backend.commands._common import fail
from backend.drivers import add_driver_options, build_drivers
from backend.drivers.registry import engine_only
from backend.logs import add_logging_options
from backend.shutdown import SHUTDOWN_SIGNALS

SPEEDS = (0.1, 10.0)  # the player's MIN_SPEED, MAX_SPEED (not imported: a fast `nutty --help`)


def register(sub) -> None:
    p = sub.add_parser(
        "play",
        help="replay a recording (.mcap or .jsonl) to drivers through the robot's limits",
        description="Replay a recording to drivers (the same driver options as `nutty serve`) through the "
        "robot's safety net: the robot is assumed at rest, is brought to the recording's first pose "
        "within its limits, the frames then play at their own times with their events, and at the "
        "end (or on SIGINT/SIGTERM) the robot is parked at rest within its limits. An MCAP is "
        "replayed from /nutty/channels (+ /nutty/events); a foreign bag with only /joint_states "
        "from the joints that have their own DoF.",
    )
    p.add_argument("recording", metavar="FILE.mcap|FILE.jsonl", help="the recording to play")
    p.add_argument(
        "--robot",
        required=True,
        help="the robot folder, URDF or bundled name: the limits the replay is held to",
    )
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        metavar="S",
        help=f"playback speed factor ({SPEEDS[0]:g}..{SPEEDS[1]:g}; default 1 = real time); the limits "
        "hold at any speed",
    )
    p.add_argument("--loop", action="store_true", help="play again from the first pose until stopped")
    add_driver_options(p)  # every driver's option, from the registry, as `nutty serve` takes them
    add_logging_options(p)
    p.set_defaults(func=run)


def _check(args: argparse.Namespace) -> str | None:
    """A usage problem with the command line, or None."""
    if not SPEEDS[0] <= args.speed <= SPEEDS[1]:
        return f"--speed must be within {SPEEDS[0]:g}..{SPEEDS[1]:g}, got {args.speed:g}"
    path = Path(args.recording)
    if path.suffix.lower() not in (".mcap", ".jsonl"):
        return f"a recording is FILE.mcap or FILE.jsonl, got '{args.recording}'"
    if not path.is_file():
        return f"no recording at '{args.recording}'"
    return engine_only(args, "`nutty play`")


def run(args) -> int:
    from backend.engine.embodiment import EmbodimentError, load_embodiment  # lazy: a fast `nutty --help`
    from backend.recording.playback import RecordingError, read_recording  # lazy: a fast `nutty --help`

    problem = _check(args)
    if problem:
        return fail(problem)
    try:
        robot = load_embodiment(args.robot)
    except EmbodimentError as exc:
        return fail(str(exc))
    try:
        rec = read_recording(args.recording, robot)
    except RecordingError as exc:
        return fail(str(exc), 1)
    if rec.unmapped:
        print(
            f"nutty play: recorded joints that are not joints of '{robot.name}' with a DoF of their own are "
            f"not played: {', '.join(rec.unmapped)}",
            flush=True,
        )
    return _play(args, robot, rec)


def _play(args, robot, rec) -> int:
    from backend.recording.player import Player  # lazy: a fast `nutty --help`

    stop, abort = threading.Event(), threading.Event()
    restore = _install_signals(stop, abort)
    sinks = []
    try:
        sinks = build_drivers(robot, args)
        player = Player(robot, rec, sinks, speed=args.speed, stop=stop, abort=abort)
        print(
            f"nutty play: {rec.path.name} ({len(rec.times)} frames, {rec.duration:.2f} s at "
            f"{1.0 / rec.dt:g} Hz, from {rec.source}) on '{robot.name}' at speed {args.speed:g} into "
            f"{', '.join(s.name for s in sinks) or 'no driver'}",
            flush=True,
        )
        stats = player.run(loop=args.loop)
    except (ValueError, OSError) as exc:
        return fail(str(exc), 1)
    finally:
        for sink in sinks:
            sink.close()
        restore()
    summary = stats.as_dict(player.h)
    print(
        f"nutty play: {stats.frames} frames ({stats.frames * player.h:.2f} s) played"
        f"{' (stopped by a signal)' if stats.stopped else ''}, {stats.loops} loop(s); the net corrected "
        f"{stats.corrected} of them; lead-in {summary['lead_in_s']:.2f} s, park {summary['park_s']:.2f} s; "
        f"{'at rest' if stats.parked else 'NOT at rest'}",
        flush=True,
    )
    print("nutty play: summary " + json.dumps(summary), flush=True)
    if not stats.parked:
        return fail("the robot did not reach rest", 1)
    return 0


def _install_signals(stop: threading.Event, abort: threading.Event):
    """SIGTERM/SIGINT/SIGHUP: the first parks the robot and ends the play, the second stops waiting for
    rest. Returns the function that puts the previous handlers back."""

    def on_signal(signum, frame) -> None:
        (abort if stop.is_set() else stop).set()

    previous = {}
    if threading.current_thread() is threading.main_thread():
        for sig in SHUTDOWN_SIGNALS:
            if sig not in (signal.SIGINT, signal.SIGTERM) and signal.getsignal(sig) is signal.SIG_IGN:
                continue  # nohup
            previous[sig] = signal.signal(sig, on_signal)

    def restore() -> None:
        for sig, handler in previous.items():
            signal.signal(sig, handler)

    return restore
