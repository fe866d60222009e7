"""`nutty validate PROGRAM.json --robot ROBOT [--json]`: check an Animation Program against a robot.

Exit 0 if the program is valid, 1 if not, 2 if the file or the robot cannot be read. Every error is
listed at once, as `[code] node.port: message` (with line and column for malformed JSON); `--json`
prints `{"valid", "level", "errors": [{"code", "node", "port", "message", "path", ...}], "warnings"}`.
"""

from __future__ import annotations

import json
from pathlib import Path

from backend.commands._common import fail
from backend.engine.embodiment import DEFAULT_ROBOT, EmbodimentError, load_embodiment


def register(sub) -> None:
    p = sub.add_parser(
        "validate",
        help="check an Animation Program against a robot, listing every error",
        description="Validate an Animation Program (JSON) for a robot: every error at once, "
        "each with its code, node and port. Exit 0 if valid, 1 if not, 2 if the "
        "file or robot cannot be read.",
    )
    p.add_argument("program", help="Animation Program JSON file")
    p.add_argument("--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument(
        "--max-level",
        type=int,
        default=3,
        choices=(0, 1, 2, 3),
        help="highest APU level the target engine allows (default 3)",
    )
    p.set_defaults(func=run)


def _count(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def run(args) -> int:
    from backend.graph.compiler import compile_program  # lazy: a fast `nutty --help`

    path = Path(args.program)
    try:
        data = path.read_bytes()
    except OSError as exc:
        return fail(f"cannot read program '{args.program}': {exc.strerror or exc}")
    try:
        emb = load_embodiment(args.robot)
    except EmbodimentError as exc:
        return fail(str(exc))
    result = compile_program(data, emb, max_level=args.max_level)
    report = result.report
    if args.json:
        print(json.dumps(report.model_dump(mode="json"), indent=2))
        return 0 if report.valid else 1
    if report.valid:
        program = result.program
        n_nodes = len(program.nodes) if program else 0
        n_edges = len(program.edges) if program else 0
        print(
            f"{path}: valid for robot '{emb.name}' (APU level {report.level}, {_count(n_nodes, 'node')}, "
            f"{_count(n_edges, 'edge')})"
        )
    else:
        print(f"{path}: invalid for robot '{emb.name}', {_count(len(report.errors), 'error')}:")
        for issue in report.errors:
            print(f"  {issue.render()}")
    for issue in report.warnings:
        print(f"  warning {issue.render()}")
    return 0 if report.valid else 1
