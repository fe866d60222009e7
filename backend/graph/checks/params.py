"""Parameter errors: a node's parameters against its block's pydantic model (`unknown_param`,
`invalid_param`), each located down to the nested field (`layers[1].mask`)."""

from __future__ import annotations

import difflib
import typing
from typing import Any

from pydantic import BaseModel, ValidationError
from pydantic_core import ErrorDetails

from backend.engine.blocks.base import Block
from backend.graph.checks.text import loc as _loc
from backend.graph.checks.text import phrase as _phrase
from backend.graph.checks.text import short as _short
from backend.graph.issues import Issue
from backend.graph.schema import Node


def _submodel(annotation: Any) -> type[BaseModel] | None:
    """The pydantic model inside an annotation such as `list[LayerSpec]` or `LayerSpec | None`."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _submodel(arg)
        if found is not None:
            return found
    return None


def walk_loc(model: type[BaseModel], loc: tuple[Any, ...]) -> tuple[list[Any], type[BaseModel] | None, int]:
    """Follow a pydantic error location through (nested) parameter models.

    Returns the parameter path (field names and list indices of nested models), the model the path
    ends in (None past a plain field) and how many parts of `loc` it used.
    """
    parts: list[Any] = []
    cur: type[BaseModel] | None = model
    k = 0
    while k < len(loc) and cur is not None:
        name = loc[k]
        if not isinstance(name, str) or name not in cur.model_fields:
            break
        parts.append(name)
        k += 1
        sub = _submodel(cur.model_fields[name].annotation)
        if sub is None:
            cur = None
            break
        if k < len(loc) and isinstance(loc[k], int):
            parts.append(loc[k])
            k += 1
        cur = sub
    return parts, cur, k


def params_errors(node: Node, index: int, cls: type[Block], exc: ValidationError) -> list[Issue]:
    """The issues of a node whose parameters its block's model rejected (one per value)."""
    out: list[Issue] = []
    grouped: dict[str, list[ErrorDetails]] = {}
    for err in exc.errors():
        loc = tuple(err["loc"])
        parts, model, used = walk_loc(cls.Params, loc)
        if err["type"] == "extra_forbidden":
            name = loc[used] if used < len(loc) else (loc[-1] if loc else "?")
            known = list((model or cls.Params).model_fields)
            hint = difflib.get_close_matches(str(name), known, n=1)
            extra = f"; did you mean '{hint[0]}'?" if hint else f" (it has: {', '.join(known)})"
            where = f"'{_loc(parts)}' " if parts else ""
            port = _loc([*parts, name])
            what = f"has no setting '{name}' in {where}" if parts else f"has no parameter '{name}'"
            out.append(
                Issue(
                    code="unknown_param",
                    node=node.id,
                    port=port,
                    path=_loc((f"nodes[{index}].params", *parts, name)),
                    message=f"node '{node.id}' ({node.type}) {what.rstrip()}{extra}",
                )
            )
            continue
        # Group the errors of one value (a union type reports one error per alternative).
        key = _loc(loc[: used + 1]) if loc else ""
        grouped.setdefault(key, []).append(err)
    for errs in grouped.values():
        loc = tuple(errs[0]["loc"])
        parts, _, used = walk_loc(cls.Params, loc)
        port = _loc(parts) if parts else (str(loc[0]) if loc else None)
        got = errs[0].get("input")
        if len(errs) == 1:
            reason = _phrase(errs[0])
        else:
            reason = "has the wrong type (" + "; ".join(dict.fromkeys(_phrase(e) for e in errs)) + ")"
        label = _loc(loc[: used + 1]) if loc else "parameters"
        if errs[0]["type"] == "missing":
            message = f"node '{node.id}' ({node.type}) needs parameter '{label}'"
        else:
            message = f"node '{node.id}' ({node.type}): parameter '{label}' {reason}, got {_short(got)}"
        out.append(
            Issue(
                code="invalid_param",
                node=node.id,
                port=port,
                path=_loc((f"nodes[{index}].params", *loc[: used + 1])),
                message=message,
            )
        )
    return out
