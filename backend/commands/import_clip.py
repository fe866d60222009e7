"""`nutty import FILE --robot ROBOT --out CLIP.json`: turn a glTF/GLB, BVH or CSV animation into a clip.

Source joints/nodes/columns map to the robot's DoFs by name (exact, then ignoring case and separators)
or through `--map MAPPING.json|.yaml` (`{"joints": {"Src": "dof" | {"dof", "axis", "scale", "offset"}}}`).
Rotations become the twist angle about the DoF's joint axis. Prints which channels mapped to which DoF,
which did not and why, key counts and the duration. Exit 0 on success, 2 if the file, the mapping or the
robot cannot be used.
"""

from __future__ import annotations

import json
from pathlib import Path

from backend.commands._common import fail
from backend.engine.embodiment import DEFAULT_ROBOT, EmbodimentError, load_embodiment


def register(sub) -> None:
    p = sub.add_parser("import", help="import a glTF/GLB, BVH or CSV animation as a nutty-clip/1 clip",
                       description="Import an animation file (.gltf/.glb, .bvh, .csv) as a keyframed clip "
                                   "(nutty-clip/1) for a robot, mapping source joints to DoFs by name or a "
                                   "mapping file. Exit 0 on success, 2 on errors.")
    p.add_argument("file", help="animation file: .gltf, .glb, .bvh or .csv (header time,<dof>,...)")
    p.add_argument("--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name")
    p.add_argument("--out", required=True, help="clip JSON file to write")
    p.add_argument("--name", help="clip name (default: the file name without extension)")
    p.add_argument("--map", dest="mapping", help="mapping file (.json or .yaml): "
                   '{"joints": {"Src": "dof" | {"dof": ..., "axis": [x, y, z], "scale": 1, "offset": 0}}}')
    p.add_argument("--animation", help="glTF: animation name or index (default the first)")
    p.add_argument("--format", dest="fmt", choices=("gltf", "bvh", "csv"), help="override the file-extension guess")
    p.add_argument("--tolerance", type=float, default=1e-3,
                   help="rad/m: drop BVH keys that linear interpolation reproduces within this (0 keeps all; "
                        "default 1e-3)")
    p.add_argument("--interp", choices=("constant", "linear", "bezier"),
                   help="CSV: interpolation of the keys (default linear)")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    from backend.importers import ClipImportError, format_report, import_clip

    path = Path(args.file)
    try:
        emb = load_embodiment(args.robot)
    except EmbodimentError as exc:
        return fail(str(exc))
    try:
        doc, report = import_clip(path, emb, args.mapping, name=args.name, animation=args.animation,
                                  tolerance=args.tolerance, interp=args.interp, fmt=args.fmt)
    except ClipImportError as exc:
        return fail(str(exc))
    out = Path(args.out)
    try:
        if out.parent and not out.parent.exists():
            out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(doc, indent=1) + "\n")
    except OSError as exc:
        return fail(f"cannot write '{out}': {exc.strerror or exc}")
    report["out"] = str(out)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(format_report(report))
        print(f"wrote {out}")
    return 0
