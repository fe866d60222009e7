"""Small helpers the check passes share to word their issues: document paths, pydantic error phrases."""

from __future__ import annotations

from typing import Any

from pydantic_core import ErrorDetails


def loc(parts: tuple[Any, ...] | list[Any]) -> str:
    """A document path from its parts: ("nodes", 3, "params", "dofs", 1) -> nodes[3].params.dofs[1]."""
    out = ""
    for part in parts:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def phrase(err: ErrorDetails) -> str:
    """What is wrong with a value, from one pydantic error ("must be at most 10.0")."""
    kind, ctx = err.get("type", ""), err.get("ctx") or {}
    if kind == "less_than_equal":
        return f"must be at most {ctx.get('le')}"
    if kind == "greater_than_equal":
        return f"must be at least {ctx.get('ge')}"
    if kind == "less_than":
        return f"must be below {ctx.get('lt')}"
    if kind == "greater_than":
        return f"must be above {ctx.get('gt')}"
    if kind == "missing":
        return "is required"
    if kind == "literal_error":
        return f"must be one of {ctx.get('expected')}"
    msg = str(err.get("msg", "is invalid"))
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    return msg[:1].lower() + msg[1:]


def short(value: Any, limit: int = 60) -> str:
    """repr(value), cut to `limit` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"
