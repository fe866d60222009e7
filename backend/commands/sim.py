"""`nutty sim report CLIP|PROGRAM [--seconds S] [--json]`: a clip or a program run headless in physics
(docs/simulation.md): per joint, peak and RMS tracking error, peak effort against the limit and time
saturated, and the contacts — for the raw motion and through the program's stage 2."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from backend.commands._common import fail
from backend.engine.embodiment import DEFAULT_ROBOT, EmbodimentError, load_embodiment


def register(sub) -> None:
    p = sub.add_parser("sim", help="the physics preview's tools: report what the motors make of a motion")
    tools = p.add_subparsers(dest="tool", metavar="TOOL", required=True)
    report = tools.add_parser(
        "report",
        help="run a clip or a program headless in physics and report tracking, effort and contacts",
        description="Runs a clip (played by a program's clip player) or a program headless, without a "
        "clock, and simulates the motion twice in MuJoCo: raw (before the program's stage 2 and the "
        "safety net) and filtered (what the motors get). Prints per joint the peak and RMS tracking "
        "error, the peak effort against the limit and the time saturated, and the contacts.",
    )
    report.add_argument(
        "target", metavar="CLIP|PROGRAM", help="a clip or program file, or the name of one of the robot's"
    )
    report.add_argument(
        "--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name"
    )
    report.add_argument(
        "--seconds",
        type=float,
        default=None,
        help="how long to run (s; default: a clip's length + 1, a program 10)",
    )
    report.add_argument(
        "--program",
        default=None,
        help="the program whose clip player plays a clip (default: the robot's default; none: a built-in "
        "stage of rest pose, clip, preset D and safety)",
    )
    report.add_argument(
        "--hardware", default=None, metavar="FILE", help="motor gains and effort from this hardware.yaml"
    )
    report.add_argument(
        "--table", type=float, default=None, metavar="HEIGHT", help="a table plane HEIGHT m above the floor"
    )
    report.add_argument("--json", action="store_true", help="print the report as JSON")
    report.set_defaults(func=run_report)


def clip_stage_program(emb, program: str | None = None) -> dict | None:
    """The program a clip plays in for a physics report: `program` (a file), else the robot's default
    (as `nutty serve` picks it), else None (the built-in clip stage). MotionError when unreadable."""
    from backend.commands.serve import default_program_path  # lazy: a fast `nutty --help`
    from backend.sim.motions import read_document

    folder = emb.urdf_path.parent if emb.urdf_path is not None else None
    path = Path(program) if program else default_program_path(folder)
    return read_document(path) if path is not None else None


def run_report(args) -> int:
    from backend.sim import SimUnavailable, require_mujoco  # lazy: a fast `nutty --help`

    try:
        require_mujoco()
    except SimUnavailable as exc:
        return fail(str(exc))
    from backend.hardware.config import HardwareConfigError, load_hardware  # lazy: as above
    from backend.sim.model import SimError, build, gains_for
    from backend.sim.motions import MotionError, clip_motion, find_target, program_motion, read_document
    from backend.sim.report import format_report, physics_report

    try:
        emb = load_embodiment(args.robot)
        path = find_target(emb, args.target)
        doc = read_document(path)
        hardware = load_hardware(args.hardware, emb) if args.hardware else None
        sim = build(emb, gains_for(emb, hardware), table=args.table)
        if doc["format"] == "nutty-clip/1":
            motion = clip_motion(emb, path.stem, doc, clip_stage_program(emb, args.program), args.seconds)
        else:
            motion = program_motion(emb, path.stem, doc, 10.0 if args.seconds is None else args.seconds)
    except (EmbodimentError, MotionError, SimError, HardwareConfigError) as exc:
        return fail(str(exc))
    report = physics_report(sim, motion.raw, motion.filtered, motion.rate, gains=args.hardware or "urdf")
    report.update({"robot": emb.name, "target": str(path), "kind": motion.kind})
    if args.json:
        json.dump(report, sys.stdout, indent=2)
        print()
    else:
        print(format_report(f"{motion.kind} {path.stem}", report))
    return 0
