"""`nutty import FILE --robot ROBOT --out CLIP.json`: turn a glTF/GLB, BVH or CSV animation into a clip.

Source joints/nodes/columns map to the robot's DoFs by name (DoF, joint or child-link name: exact,
then ignoring case and separators) or through `--map MAPPING.json|.yaml`
(`{"joints": {"Src": "dof" | {"dof", "axis", "scale", "offset"} | [{"dof": ...}, ...] | null}}`).
Rotations are taken relative to the rest (bind) pose, expressed in the robot's axes (glTF and BVH are
+Y up: `--up`, `--forward`) and reduced to the twist about the DoF's URDF axis (or split between
several DoFs in the listed order). Prints which channels mapped to which DoF, the rotation each
mapping drops, which channels did not map and why, and the trajectory-helper's view of the clip
against the robot's velocity, acceleration and jerk limits (`--fit-limits` slows it down to fit).

Exit 0 on success; 1 with `--strict` when there are warnings (nothing is written); 2 if the file, the
mapping or the robot cannot be used (one short message, no traceback).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from backend.commands._common import fail
from backend.engine.embodiment import DEFAULT_ROBOT, EmbodimentError, load_embodiment


def _whole(min_value: int):
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got '{text}'") from None
        if v < min_value:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {min_value}, got {v}")
        return v

    return parse


def _finite(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got '{text}'") from None
    if v != v or v in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number, got '{text}'")
    return v


def register(sub) -> None:
    p = sub.add_parser(
        "import",
        help="import a glTF/GLB, BVH or CSV animation as a nutty-clip/1 clip",
        description="Import an animation file (.gltf/.glb, .bvh, .csv) as a keyframed clip "
        "(nutty-clip/1) for a robot, mapping source joints to DoFs by name or a "
        "mapping file. Rotations are taken relative to the rest pose, in the robot's "
        "axes, and reduced to each DoF's URDF axis; the report gives the rotation "
        "each mapping drops and the clip's samples over the robot's limits. "
        "See docs/importing.md. Exit 0 on success, 1 on warnings with --strict, "
        "2 on errors.",
    )
    p.add_argument("file", help="animation file: .gltf, .glb, .bvh or .csv (header time,<dof>,...)")
    p.add_argument("--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name")
    p.add_argument("--out", required=True, help="clip JSON file to write")
    p.add_argument("--name", help="clip name (default: the file name without extension)")
    p.add_argument(
        "--map",
        dest="mapping",
        help="mapping file (.json or .yaml): "
        '{"joints": {"Src": "dof" | {"dof": ..., "axis": [x, y, z], "scale": 1, "offset": 0} | '
        '[{"dof": "head_yaw"}, {"dof": "head_pitch"}] | null}}',
    )
    _add_source_options(p)
    _add_sampling_options(p)
    _add_check_options(p)
    p.set_defaults(func=run)


def _add_source_options(p) -> None:
    """How the source is read: which animation, its format, its keys (tolerance, interpolation), its axes
    and its rest frame."""
    p.add_argument(
        "--animation",
        help="glTF: animation name or index (default the first; a channel the mapping file names that "
        "only one other animation has comes from that one)",
    )
    p.add_argument(
        "--format",
        dest="fmt",
        metavar="NAME",
        help="override the file-extension guess: an importer's name (gltf, bvh, csv, or one a plugin adds)",
    )
    p.add_argument(
        "--tolerance",
        type=_finite,
        default=1e-3,
        help="rad/m: drop BVH keys that linear interpolation reproduces within this (0 keeps all; "
        "default 1e-3)",
    )
    p.add_argument(
        "--interp",
        choices=("constant", "linear", "bezier"),
        help="CSV: interpolation of the keys (default linear)",
    )
    p.add_argument(
        "--up",
        choices=("y", "z"),
        help="the source's up axis (default y: glTF and BVH are +Y up; "
        "z for files already +Z up like the robot)",
    )
    p.add_argument(
        "--forward",
        default="x",
        choices=("x", "-x", "y", "-y", "z", "-z"),
        help="the source axis that faces the robot's +X (default x; z for CMU-style BVH, whose "
        "actor faces +Z)",
    )
    p.add_argument(
        "--rest-frame",
        type=_whole(0),
        metavar="N",
        help="BVH: frame N is the rest pose (default: the pose the OFFSETs define)",
    )


def _add_sampling_options(p) -> None:
    """Which source samples are kept, and how gaps of bad samples are repaired."""
    p.add_argument(
        "--skip-frames",
        type=_whole(0),
        default=0,
        metavar="N",
        help="drop the source's first N frames (e.g. a T-pose frame); the clip starts after them",
    )
    p.add_argument(
        "--fill",
        choices=("hold", "linear"),
        help="repair short gaps of NaN/inf samples (hold the last value, or interpolate) instead of stopping",
    )
    p.add_argument(
        "--max-gap",
        type=_whole(1),
        default=10,
        metavar="N",
        help="--fill repairs gaps of at most N samples (default 10)",
    )


def _add_check_options(p) -> None:
    """What is reported, and against which limits; --strict and --json."""
    p.add_argument(
        "--swing-warn",
        type=_finite,
        default=5.0,
        metavar="DEG",
        help="warn when a mapping drops more than DEG degrees of rotation about other axes (default 5)",
    )
    p.add_argument("--strict", action="store_true", help="warnings are errors: exit 1 and write nothing")
    p.add_argument(
        "--rate",
        type=_finite,
        default=100.0,
        metavar="HZ",
        help="rate at which the trajectory-helper samples the clip (the engine's tick rate; default 100)",
    )
    p.add_argument(
        "--fit-limits",
        action="store_true",
        help="slow the clip down uniformly by the factor that fits the robot's velocity, "
        "acceleration and jerk limits",
    )
    p.add_argument(
        "--physics",
        action="store_true",
        help="also play the clip in physics (MuJoCo, through the robot's default program) and report "
        "tracking error, effort and contacts, raw and filtered (docs/simulation.md)",
    )
    p.add_argument("--json", action="store_true", help="print the whole report as JSON")


def _add_physics(args, emb, doc: dict, report: dict) -> str | None:
    """Put the clip's physics report in `report["physics"]`; an error message, or None."""
    from backend.commands.sim import clip_stage_program  # lazy: a fast `nutty --help`
    from backend.sim.analysis import clip_physics  # lazy: MuJoCo is an optional extra
    from backend.sim.availability import SimUnavailable
    from backend.sim.model import SimError
    from backend.sim.motions import MotionError

    try:
        report["physics"] = clip_physics(emb, doc, clip_stage_program(emb), rate=args.rate)
    except (SimUnavailable, MotionError, SimError) as exc:
        return f"physics: {exc}"
    return None


def run(args) -> int:
    from backend.importers import ClipImportError, format_report, import_clip  # lazy: a fast `nutty --help`

    path = Path(args.file)
    try:
        emb = load_embodiment(args.robot)
    except EmbodimentError as exc:
        return fail(str(exc))
    try:
        doc, report = import_clip(
            path,
            emb,
            args.mapping,
            name=args.name,
            animation=args.animation,
            tolerance=args.tolerance,
            interp=args.interp,
            fmt=args.fmt,
            up=args.up,
            forward=args.forward,
            rest_frame=args.rest_frame,
            fill=args.fill,
            max_gap=args.max_gap,
            skip_frames=args.skip_frames,
            swing_warn=args.swing_warn,
            rate=args.rate,
            fit_limits=args.fit_limits,
        )
    except ClipImportError as exc:
        return fail(str(exc))
    except (ValueError, TypeError, KeyError, IndexError, OverflowError, ArithmeticError, OSError) as exc:
        # a file malformed in a way no check above caught: still one short message, no traceback
        msg = str(exc).splitlines()[0][:300] if str(exc) else ""
        return fail(f"cannot import '{path.name}': {type(exc).__name__}: {msg}")
    if args.physics:
        problem = _add_physics(args, emb, doc, report)
        if problem:
            return fail(problem)
    out = Path(args.out)
    warnings = report.get("warnings", [])
    if args.strict and warnings:
        report["out"] = None
        if args.json:
            print(json.dumps(report, indent=2))
        else:
            print(format_report(report))
        return fail(f"{len(warnings)} warning(s) and --strict: nothing written", code=1)
    try:
        if out.parent and not out.parent.exists():
            out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(doc, indent=1) + "\n")
    except OSError as exc:
        return fail(f"cannot write '{out}': {exc.strerror or exc}")
    report["out"] = str(out)
    if args.json:
        print(json.dumps(report, indent=2))
        for w in warnings:
            print(f"nutty: warning: {w['message']}", file=sys.stderr)
    else:
        print(format_report(report))
        if "physics" in report:
            from backend.sim.report import format_report as format_physics  # lazy: only with --physics

            print("\n" + format_physics("physics", report["physics"]))
        print(f"wrote {out}")
    return 0
