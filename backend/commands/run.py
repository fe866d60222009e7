"""`nutty run PROGRAM --robot ROBOT --seconds S [--rate HZ] --out FILE`: run a program headless.

Writes exactly S x HZ frames: CSV (`t,<continuous DoF names…>`) or JSONL (every channel and event).
No wall-clock sleeping: the engine steps as fast as it can with the same semantics as live.
"""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path

from backend.commands._common import fail, warn_unsafe
from backend.engine.embodiment import DEFAULT_ROBOT, EmbodimentError, load_embodiment
from backend.engine.runtime import MAX_RATE, MIN_RATE


def register(sub) -> None:
    p = sub.add_parser(
        "run",
        help="run an Animation Program headless and write its frames",
        description="Run an Animation Program (JSON) on a robot without a clock and write "
        "every frame to CSV or JSONL.",
    )
    p.add_argument("program", help="Animation Program JSON file")
    p.add_argument("--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name")
    p.add_argument("--seconds", type=float, required=True, help="duration to run (s)")
    p.add_argument(
        "--rate", type=float, default=None, help="tick rate in Hz (default: the program's, else 100)"
    )
    p.add_argument("--out", required=True, help="output file: .csv or .jsonl")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="set an exposed input (VALUE parsed as JSON, else taken as a string); repeatable",
    )
    p.add_argument(
        "--commands",
        default=None,
        metavar="FILE.jsonl",
        help="replay timed commands: one JSON object per line with 't' (s) and a command",
    )
    p.add_argument("--max-level", type=int, default=3, choices=(0, 1, 2, 3), help="highest APU level allowed")
    p.add_argument(
        "--profile",
        action="store_true",
        help="time every block on every tick and print a table of cook times (µs), the most "
        "expensive node first",
    )
    p.add_argument(
        "--unsafe-no-limits",
        action="store_true",
        help="write the program's frames without the engine's safety net (position, velocity, "
        "acceleration and jerk limits): for inspecting a program, never for a robot",
    )
    p.set_defaults(func=run)


def parse_assignment(text: str) -> tuple[str, object]:
    if "=" not in text:
        raise ValueError(f"--set expects NAME=VALUE, got '{text}'")
    name, _, raw = text.partition("=")
    try:
        value = json.loads(raw)
    except json.JSONDecodeError:
        value = raw
    return name.strip(), value


def run(args) -> int:
    from backend.session import EngineSession, SessionError  # lazy: a fast `nutty --help`

    if not (args.seconds > 0 and math.isfinite(args.seconds)):
        return fail(f"--seconds must be a positive number, got {args.seconds}")
    out = Path(args.out)
    if out.suffix.lower() not in (".csv", ".jsonl"):
        return fail(f"--out must end in .csv or .jsonl, got '{out.name}'")
    try:
        emb = load_embodiment(args.robot)
    except EmbodimentError as exc:
        return fail(str(exc))
    try:
        text = Path(args.program).read_text()
    except OSError as exc:
        return fail(f"cannot read program '{args.program}': {exc.strerror}")
    try:
        if args.unsafe_no_limits:
            warn_unsafe()
        session = EngineSession.create(
            emb, rate=args.rate, program_text=text, max_level=args.max_level, safety=not args.unsafe_no_limits
        )
    except SessionError as exc:
        print(exc.render(), file=sys.stderr)
        return 1
    rate = session.engine.rate
    if not MIN_RATE <= rate <= MAX_RATE:
        return fail(f"--rate must be within [{MIN_RATE:g}, {MAX_RATE:g}] Hz")
    try:
        for item in args.set:
            name, value = parse_assignment(item)
            session.set_input(name, value)
        timeline = session.read_command_file(args.commands) if args.commands else []
    except (ValueError, OSError) as exc:
        return fail(str(exc))

    n = round(args.seconds * rate)
    if args.profile:
        session.engine.set_profiling(every=1, window=max(1, n))
    frames_written = 0
    with out.open("w", newline="") as fh:
        if out.suffix.lower() == ".csv":
            names = emb.continuous_names
            idx = [emb.dof(nm).channels.start for nm in names]
            writer = csv.writer(fh)
            writer.writerow(["t", *names])
            for frame in session.run_headless(n, timeline):
                writer.writerow([f"{frame.t:.6f}", *(f"{frame.position[i]:.6g}" for i in idx)])
                frames_written += 1
        else:
            for frame in session.run_headless(n, timeline):
                fh.write(json.dumps(frame.to_dict(emb)) + "\n")
                frames_written += 1
    for note in session.notes:
        if note.get("event") == "error":
            print(f"nutty: warning: {note.get('message')}", file=sys.stderr)
    print(f"wrote {frames_written} frames ({args.seconds:g} s at {rate:g} Hz) to {out}", file=sys.stderr)
    if args.profile:
        from backend.engine.profile import format_table  # lazy: a fast `nutty --help`

        print(format_table(session.engine.profile()))
    return 0
