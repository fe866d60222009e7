"""`nutty embodiment ROBOT [--json]`: the robot's kinematronics summary and DoF table."""

from __future__ import annotations

import json
import math

from backend.commands._common import fail
from backend.engine.embodiment import DEFAULT_ROBOT, EmbodimentError, load_embodiment


def register(sub) -> None:
    p = sub.add_parser(
        "embodiment",
        help="print a robot's kinematronics (DoFs per dimension, limits)",
        description="Print the kinematronics summary and DoF table of a robot folder or URDF file.",
    )
    p.add_argument(
        "robot", nargs="?", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name"
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=run)


def _fmt(x) -> str:
    if x is None:
        return "-"
    if isinstance(x, (list, tuple)):
        return "[" + ",".join(f"{v:.2f}" for v in x) + "]"
    if isinstance(x, float) and not math.isfinite(x):
        return "-"
    return f"{x:.3g}"


def run(args) -> int:
    try:
        emb = load_embodiment(args.robot)
    except EmbodimentError as exc:
        return fail(str(exc))
    if args.json:
        print(json.dumps(emb.to_dict(), indent=2))
        return 0
    counts = emb.dimension_counts()
    print(f"{emb.name}: {sum(counts.values())} DoFs, {emb.n_channels} channels")
    print("  " + "   ".join(f"{dim} {n}" for dim, n in counts.items()))
    header = ("name", "dimension", "type", "min", "max", "velocity", "accel", "jerk", "rest", "notes")
    rows = []
    for d in emb.dofs:
        notes = []
        if d.drives:
            notes.append("drives " + ", ".join(f"{j}×{c:g}" for j, c in d.drives.items()))
        if d.axis:
            notes.append(f"axis {d.axis}")
        if d.group:
            notes.append(f"group {d.group}")
        if d.options:
            notes.append("options " + "/".join(d.options))
        if d.kind:
            notes.append(d.kind + (": " + "/".join(d.sounds) if d.sounds else ""))
        rows.append(
            (
                d.name,
                d.dimension.value,
                d.type.value,
                _fmt(d.min),
                _fmt(d.max),
                _fmt(d.velocity),
                _fmt(d.acceleration),
                _fmt(d.jerk),
                _fmt(d.rest),
                "; ".join(notes),
            )
        )
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    print()
    print("  ".join(h.ljust(w) for h, w in zip(header, widths)).rstrip())
    print("  ".join("-" * w for w in widths))
    for r in rows:
        print("  ".join(str(c).ljust(w) for c, w in zip(r, widths)).rstrip())
    return 0
