"""`nutty new PROGRAM.json --robot ROBOT [--template idle|blank|layers] [--force]`: a starter program.

Writes a valid, laid-out Animation Program for the robot, checked by the validator before it is
written:
- `blank`: the rest pose straight to the output (Level 0);
- `idle` (default): a layer mixer with the rest pose as base and an additive breathing sine whose
  rate is the exposed input `breath_rate`, then a safety limiter (Level 3);
- `layers`: `idle` plus an override `look` layer (a pose on the robot's first movable DoFs) that
  starts inactive and is switched with a `set_layer` command, and an exposed `energy` input.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from backend.commands._common import fail
from backend.engine.embodiment import DEFAULT_ROBOT, DofType, EmbodimentError, load_embodiment

TEMPLATES = ("idle", "blank", "layers")
COL, ROW = 280, 160  # editor grid: one column per stage, one row per layer


def register(sub) -> None:
    p = sub.add_parser(
        "new",
        help="write a valid starter Animation Program for a robot",
        description="Write a valid, laid-out starter Animation Program for a robot.",
    )
    p.add_argument("program", help="file to write (PROGRAM.json)")
    p.add_argument("--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name")
    p.add_argument(
        "--template",
        default="idle",
        choices=TEMPLATES,
        help="idle: breathing over the rest pose with a safety limiter (default); blank: rest pose only; "
        "layers: idle plus a switchable look layer",
    )
    p.add_argument("--name", default=None, help="program name (default: from the file name)")
    p.add_argument("--force", action="store_true", help="overwrite PROGRAM.json if it exists")
    p.set_defaults(func=run)


def _node(nid: str, kind: str, col: int, row: int, **params: Any) -> dict[str, Any]:
    return {"id": nid, "type": kind, "params": params, "ui": {"x": col * COL, "y": row * ROW}}


def _edge(src: str, dst: str, port: str = "in", src_port: str = "out") -> dict[str, Any]:
    return {"from": {"node": src, "port": src_port}, "to": {"node": dst, "port": port}}


def starter_program(emb, template: str = "idle", name: str = "starter") -> dict[str, Any]:
    """The starter document for `emb` (valid for it by construction; `nutty new` checks it anyway)."""
    doc: dict[str, Any] = {
        "format": "nutty-program/1",
        "name": name,
        "robot": emb.name,
        "description": "",
        "max_level": 3,
        "inputs": [],
        "nodes": [],
        "edges": [],
    }
    if template == "blank":
        doc["description"] = "The robot's rest pose. Add sources and operators between 'rest' and 'output'."
        doc["max_level"] = 0
        doc["nodes"] += [_node("rest", "rest_pose", 0, 0, dofs=["*"]), _node("output", "output", 1, 0)]
        doc["edges"].append(_edge("rest", "output"))
        return doc
    movable = _movable(emb)
    breathe_on = ["stationary:*"] if movable else ["*"]
    layers = _add_breathing(doc, breathe_on)
    if template == "layers":
        _add_look_layer(doc, layers, movable, breathe_on)
    doc["nodes"] += [
        _node("mixer", "layer_mixer", 3, 1, layers=layers),
        _node("limit", "safety_limiter", 4, 1, velocity_scale=1.0, margin=0.02),
        _node("output", "output", 5, 1),
    ]
    doc["edges"] += [_edge("mixer", "limit"), _edge("limit", "output")]
    return doc


def _movable(emb) -> list:
    """The DoFs a starter may move: continuous, stationary, with a range, driving no others."""
    return [
        d
        for d in emb.dofs
        if d.type is DofType.continuous
        and d.dimension.value == "stationary"
        and d.max > d.min
        and not d.drives
    ]


def _add_breathing(doc: dict[str, Any], breathe_on: list[str]) -> list[dict[str, Any]]:
    """The idle template's part: breathing (paced by the 'breath_rate' input) added over the rest pose;
    returns the mixer's layers (the mixer itself comes last)."""
    doc["description"] = (
        "Breathing over the rest pose; set 'breath_rate' to change its pace. A safety "
        "limiter keeps every DoF within its limits."
    )
    doc["inputs"].append(
        {
            "name": "breath_rate",
            "type": "float",
            "default": 0.25,
            "min": 0.05,
            "max": 1.0,
            "description": "breaths per second",
        }
    )
    doc["nodes"] += [
        _node("rest", "rest_pose", 1, 0, dofs=["*"]),
        _node("in_breath_rate", "input", 0, 1, name="breath_rate", type="float"),
        _node("breath", "sine", 1, 1, dofs=breathe_on, amplitude=0.02, frequency=0.25, phase_spread=0.4),
    ]
    doc["edges"] += [
        _edge("rest", "mixer", "base"),
        _edge("in_breath_rate", "breath", "frequency", "value"),
        _edge("breath", "mixer", "breathing"),
    ]
    return [
        {"name": "base", "mode": "override"},
        {"name": "breathing", "mode": "additive", "mask": breathe_on},
    ]


def _add_look_layer(
    doc: dict[str, Any], layers: list[dict[str, Any]], movable: list, breathe_on: list[str]
) -> None:
    """The layers template's part: an 'energy' input scaling the breathing, and a 'look' pose layer
    that starts off (the breathing's edge into the mixer is rerouted through the gain)."""
    doc["description"] = (
        "Breathing over the rest pose, plus a 'look' layer (a pose) that starts off: "
        'send {"type": "set_layer", "layer": "look", "active": true} to fade it '
        "in. 'energy' scales the breathing depth."
    )
    doc["inputs"].append(
        {
            "name": "energy",
            "type": "float",
            "default": 1.0,
            "min": 0.0,
            "max": 3.0,
            "description": "how deep the breathing is (1 = normal)",
        }
    )
    # 30 % of the way from rest toward the farther limit of the first two movable DoFs (rad or m)
    look = {
        d.name: round(d.rest + 0.3 * ((d.max if d.max - d.rest >= d.rest - d.min else d.min) - d.rest), 4)
        for d in movable[:2]
    }
    doc["nodes"] += [
        _node("in_energy", "input", 1, 2, name="energy", type="float"),
        _node("depth", "gain_offset", 2, 1, dofs=breathe_on, gain=1.0),
        _node("look", "pose", 1, 3, values=look),
    ]
    doc["edges"][-1:] = [
        _edge("breath", "depth"),
        _edge("in_energy", "depth", "gain", "value"),
        _edge("depth", "mixer", "breathing"),
        _edge("look", "mixer", "look"),
    ]
    layers.append(
        {"name": "look", "mode": "override", "fade": 0.6, "mask": list(look) or ["*"], "active": False}
    )


def run(args) -> int:
    from backend.graph.compiler import compile_program  # lazy: a fast `nutty --help`
    from backend.graph.roundtrip import format_json  # lazy: a fast `nutty --help`

    out = Path(args.program)
    if out.exists() and not args.force:
        return fail(f"'{out}' already exists; pass --force to overwrite it")
    try:
        emb = load_embodiment(args.robot)
    except EmbodimentError as exc:
        return fail(str(exc))
    doc = starter_program(
        emb, args.template, args.name or out.stem.replace("_", " ").replace("-", " ") or "starter"
    )
    result = compile_program(doc, emb)
    if not result.ok:  # a bug in a template, not the user's fault: say so rather than write a broken file
        for issue in result.report.errors:
            print(f"  {issue.render()}", file=sys.stderr)
        return fail(f"template '{args.template}' does not fit robot '{emb.name}'", code=1)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(format_json(doc))
    except OSError as exc:
        return fail(f"cannot write '{out}': {exc.strerror or exc}")
    print(
        f"wrote {out}: template '{args.template}', APU level {result.report.level}, {len(doc['nodes'])} nodes, "
        f"for robot '{emb.name}'",
        file=sys.stderr,
    )
    print(
        f"try: nutty run {out} --robot {args.robot} --seconds 5 --out {out.with_suffix('.csv').name}",
        file=sys.stderr,
    )
    return 0
