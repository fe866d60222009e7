"""Example calls generated from a tool's JSON Schema (the arguments a model would send), for tests
that execute every generated tool: required arguments only, each the first enum value or a value
within its range."""

from __future__ import annotations

from typing import Any

STRINGS = {"text": "Hello!", "target": "no-such-command"}  # plausible text for free string arguments


def example_arguments(schema: dict[str, Any]) -> dict[str, Any]:
    """Required arguments of an object schema, each an example value."""
    props = schema.get("properties", {})
    required = list(schema.get("required", []))
    if not required and schema.get("minProperties") and props:
        required = [next(iter(props))]
    return {name: example_value(props[name], name) for name in required}


def example_value(schema: dict[str, Any], name: str = "") -> Any:
    if "enum" in schema:
        return schema["enum"][0]
    kind = schema.get("type")
    if kind in ("number", "integer"):
        lo = schema.get("minimum", schema.get("exclusiveMinimum", 0.0))
        hi = schema.get("maximum", lo + 1.0)
        value = (lo + hi) / 2
        return int(value) if kind == "integer" else value
    if kind == "boolean":
        return True
    if kind == "string":
        return STRINGS.get(name, "x")
    if kind == "array":
        return [example_value(schema.get("items", {"type": "number"}))] * schema.get("minItems", 1)
    if kind == "object":
        return example_arguments(schema)
    return None
