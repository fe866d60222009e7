"""JSON Schemas of tool arguments, made from the command models (the one source of the fields, their
types, ranges and descriptions) and filled with the values that exist now.

Pydantic's schemas are written for validation; a model reading a tool needs less: optional fields are
plain (not `anyOf [..., null]`), no titles, `$ref`s resolved, and a fixed-size list of one item type
as `items` (both function-calling dialects read that; not every one reads `prefixItems`).
"""

from __future__ import annotations

import copy
import functools
from typing import Any

from backend.control.ai import input_value_schema  # noqa: F401  (kept importable from here)
from backend.tools.live import Choice

COMMAND_HIDDEN = ("type", "id")  # a command's tag, and the id the server assigns


def model_arguments(model: type, hide: tuple[str, ...] = ()) -> dict[str, Any]:
    """The `{"type": "object", "properties", "required"}` schema of a pydantic model's fields, less
    `hide` (and, of a command, its `type` and `id`). A fresh copy: callers fill it in."""
    return copy.deepcopy(_model_arguments(model, tuple(sorted(hide))))


@functools.lru_cache(maxsize=256)
def _model_arguments(model: type, hide: tuple[str, ...]) -> dict[str, Any]:
    # Cached: a model class's schema never changes, and pydantic takes milliseconds to write one.
    schema = model.model_json_schema()
    defs = schema.get("$defs", {})
    hidden = set(hide) | (set(COMMAND_HIDDEN) if "type" in model.model_fields else set())
    props = {
        name: simplify(prop, defs)
        for name, prop in schema.get("properties", {}).items()
        if name not in hidden
    }
    required = [name for name in schema.get("required", []) if name in props]
    return {"type": "object", "properties": props, "required": required, "additionalProperties": False}


def simplify(node: Any, defs: dict[str, Any]) -> Any:
    """A pydantic JSON Schema node as a tool argument: see the module docstring."""
    if isinstance(node, list):
        return [simplify(x, defs) for x in node]
    if not isinstance(node, dict):
        return node
    if "$ref" in node:
        node = {**defs[node["$ref"].rsplit("/", 1)[-1]], **{k: v for k, v in node.items() if k != "$ref"}}
    if "anyOf" in node:
        options = [o for o in node["anyOf"] if o != {"type": "null"}]
        if len(options) == 1:
            node = {**simplify(options[0], defs), **{k: v for k, v in node.items() if k != "anyOf"}}
    out = {
        k: simplify(v, defs)
        for k, v in node.items()
        if not (k == "title" and isinstance(v, str)) and not (k == "default" and v is None)
    }
    items = out.get("prefixItems")
    if isinstance(items, list) and items and all(i == items[0] for i in items):
        out.pop("prefixItems")
        out["items"] = items[0]
    return out


def with_choices(prop: dict[str, Any], choices: list[Choice], what: str) -> dict[str, Any]:
    """`prop` restricted to `choices` (an enum), each choice listed with its description."""
    lines = "\n".join(c.line() for c in choices)
    base = prop.get("description")
    text = f"{base}. " if base else ""
    return {
        **prop,
        "type": "string",
        "enum": [c.name for c in choices],
        "description": f"{text}One of {what}:\n{lines}",
    }
