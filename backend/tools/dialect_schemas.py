"""Argument schemas rewritten for a provider's function-calling rules (the tools' own schemas, made by
backend.tools.schema, are plain JSON Schema: optional properties simply left out of `required`).

- `strict_schema`: OpenAI's strict mode (Structured Outputs for function calls). Every object is
  closed (`additionalProperties: false`) and lists every property in `required`; an optional
  property takes `null` instead ("leave it out"), so its type gains "null". Keywords strict mode
  refuses (`default`, `minLength`, `maxLength`, `minProperties`, ...) are dropped, and what they said
  moves into the description, so the model still reads it and the server still enforces it.
- `gemini_schema`: Gemini's function declarations (`Schema`: a subset of OpenAPI 3.0). Type names
  upper case, `nullable` instead of a "null" type, no `additionalProperties`, `const`, `$ref` or
  exclusive bounds (an exclusive minimum becomes the description's).

`drop_nulls` undoes the strict dialect's nulls on the way in: a call's `null` for a property that is
optional in the tool's own schema means "not given".
"""

from __future__ import annotations

import copy
from typing import Any

#: What OpenAI's strict mode accepts (its "Supported schemas" list); anything else is dropped.
OPENAI_STRICT_KEYWORDS = frozenset(
    {
        "type",
        "description",
        "properties",
        "required",
        "additionalProperties",
        "items",
        "enum",
        "const",
        "anyOf",
        "$defs",
        "$ref",
        "pattern",
        "format",
        "minimum",
        "maximum",
        "exclusiveMinimum",
        "exclusiveMaximum",
        "multipleOf",
        "minItems",
        "maxItems",
    }
)

#: The fields of Gemini's `Schema` object (v1beta) this dialect writes.
GEMINI_KEYWORDS = frozenset(
    {
        "type",
        "format",
        "description",
        "nullable",
        "enum",
        "maxItems",
        "minItems",
        "properties",
        "required",
        "minProperties",
        "maxProperties",
        "minLength",
        "maxLength",
        "pattern",
        "anyOf",
        "propertyOrdering",
        "default",
        "items",
        "minimum",
        "maximum",
    }
)

_SAID = {  # a dropped keyword, and how the description says it
    "default": "default {!r}",
    "minLength": "at least {} characters",
    "maxLength": "at most {} characters",
    "minProperties": "at least {} of them",
    "maxProperties": "at most {} of them",
    "exclusiveMinimum": "greater than {}",
    "exclusiveMaximum": "less than {}",
    "uniqueItems": "no repeats",
    "multipleOf": "a multiple of {}",
}


def _say(node: dict[str, Any], dropped: dict[str, Any]) -> dict[str, Any]:
    """`node` with what `dropped` keywords said appended to its description."""
    notes = [
        _SAID[k].format(v) for k, v in dropped.items() if k in _SAID and not (k == "uniqueItems" and not v)
    ]
    if not notes:
        return node
    text = node.get("description", "").rstrip()
    joined = "; ".join(notes)
    return {**node, "description": f"{text} ({joined})" if text else joined[0].upper() + joined[1:]}


def _nullable(node: dict[str, Any]) -> dict[str, Any]:
    """`node` that also accepts null (meaning: not given)."""
    out = dict(node)
    kind = out.get("type")
    if isinstance(kind, str) and kind != "null":
        out["type"] = [kind, "null"]
    elif isinstance(kind, list) and "null" not in kind:
        out["type"] = [*kind, "null"]
    elif "anyOf" in out:
        out["anyOf"] = [*out["anyOf"], {"type": "null"}]
    if "enum" in out and None not in out["enum"]:
        out["enum"] = [*out["enum"], None]
    return out


def strict_schema(schema: dict[str, Any]) -> dict[str, Any]:
    """`schema` in OpenAI's strict dialect (see the module doc). A new object."""
    node = {k: v for k, v in schema.items() if k in OPENAI_STRICT_KEYWORDS}
    node = _say(node, {k: v for k, v in schema.items() if k not in OPENAI_STRICT_KEYWORDS})
    if "items" in node and isinstance(node["items"], dict):
        node["items"] = strict_schema(node["items"])
    if "anyOf" in node:
        node["anyOf"] = [strict_schema(o) for o in node["anyOf"]]
    if node.get("type") == "object" or "properties" in node:
        props = node.get("properties", {})
        required = set(node.get("required", []))
        node["properties"] = {
            name: strict_schema(p) if name in required else _nullable(strict_schema(p))
            for name, p in props.items()
        }
        node["required"] = list(props)
        node["additionalProperties"] = False
    return node


def _gemini_type(kind: Any) -> tuple[str | None, bool]:
    """(Gemini's upper-case type, whether null is allowed too) of a JSON Schema `type`."""
    kinds = kind if isinstance(kind, list) else [kind] if kind is not None else []
    real = [k for k in kinds if k != "null"]
    return (real[0].upper() if real else None), ("null" in kinds)


def gemini_schema(schema: dict[str, Any]) -> dict[str, Any]:
    """`schema` as a Gemini function declaration's `Schema` (see the module doc). A new object."""
    src = copy.deepcopy(schema)
    if "const" in src:  # no const: a one-value enum says the same
        src["enum"] = [src.pop("const")]
    node = {k: v for k, v in src.items() if k in GEMINI_KEYWORDS}
    node = _say(node, {k: v for k, v in src.items() if k not in GEMINI_KEYWORDS})
    kind, nullable = _gemini_type(src.get("type"))
    if kind is not None:
        node["type"] = kind
    if nullable:
        node["nullable"] = True
    if "enum" in node:
        node["enum"] = [str(v) for v in node["enum"] if v is not None]
        node.setdefault("type", "STRING")
    if isinstance(node.get("items"), dict):
        node["items"] = gemini_schema(node["items"])
    if "anyOf" in node:
        node["anyOf"] = [gemini_schema(o) for o in node["anyOf"] if o != {"type": "null"}]
    if "properties" in node:
        node["properties"] = {name: gemini_schema(p) for name, p in node["properties"].items()}
        node["propertyOrdering"] = list(node["properties"])
        node.setdefault("type", "OBJECT")
    return node


def drop_nulls(arguments: Any, schema: dict[str, Any]) -> Any:
    """`arguments` without the nulls the strict dialect sends for optional properties of `schema` (the
    tool's own schema), at every level; other values are left as they are."""
    if not isinstance(arguments, dict) or not isinstance(schema.get("properties"), dict):
        return arguments
    required = set(schema.get("required", []))
    out = {}
    for name, value in arguments.items():
        prop = schema["properties"].get(name)
        if value is None and prop is not None and name not in required:
            continue
        out[name] = drop_nulls(value, prop) if isinstance(prop, dict) else value
    return out
