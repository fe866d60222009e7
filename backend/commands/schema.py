"""`nutty schema OUT_DIR`: export what the editor's generated types and rules come from."""

from __future__ import annotations

import json
from pathlib import Path

from backend.commands._common import fail


def register(sub) -> None:
    p = sub.add_parser(
        "schema",
        help="export JSON Schemas (program, commands, API), the block catalog and rules",
        description="Write program.schema.json, commands.schema.json, api.schema.json (the API's "
        "responses and messages), clip.schema.json (the clip format), behaviour.schema.json (the behaviour format), blocks.json (the block catalog) "
        "and rules.json (the wiring rule, the palette's categories) to OUT_DIR.",
    )
    p.add_argument("out_dir", help="output folder")
    p.set_defaults(func=run)


def schemas() -> dict[str, object]:
    from backend.api_types import api_json_schema  # lazy: a fast `nutty --help`
    from backend.behaviours import behaviour_json_schema  # lazy: a fast `nutty --help`
    from backend.control import command_json_schema  # lazy: a fast `nutty --help`
    from backend.engine.blocks import block_catalog, editor_rules  # lazy: a fast `nutty --help`
    from backend.engine.clips import clip_json_schema  # lazy: a fast `nutty --help`
    from backend.graph.schema import program_json_schema  # lazy: a fast `nutty --help`

    return {
        "program.schema.json": program_json_schema(),
        "commands.schema.json": command_json_schema(),
        "api.schema.json": api_json_schema(),
        "clip.schema.json": clip_json_schema(),
        "behaviour.schema.json": behaviour_json_schema(),
        "blocks.json": block_catalog(),
        "rules.json": editor_rules(),
    }


def run(args) -> int:
    out = Path(args.out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
        for name, doc in schemas().items():
            (out / name).write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n")
    except OSError as exc:
        return fail(f"cannot write to '{out}': {exc.strerror}")
    return 0
