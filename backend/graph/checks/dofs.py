"""DoF errors: every DoF selector (`x-widget: dofs`) and pose key (`x-widget: pose`) of a node's
parameters against the robot (`unknown_dof`, or `invalid_param` for a pose value of the wrong kind)."""

from __future__ import annotations

import difflib
from collections.abc import Iterator
from typing import Any

from pydantic import BaseModel

from backend.engine.blocks.base import BlockParams
from backend.engine.blocks.core import pose_vector
from backend.engine.embodiment import Embodiment
from backend.engine.selectors import SelectorError, select_dofs
from backend.graph.checks.text import loc as _loc
from backend.graph.issues import Issue
from backend.graph.schema import Node

# The `x-widget` marks of parameter annotations that name DoFs (see backend.engine.blocks.base).
SELECTORS = "dofs"  # a list of DoF selectors
POSE = "pose"  # DoF name -> value


def _widget(info: Any) -> str | None:
    extra = info.json_schema_extra
    return extra.get("x-widget") if isinstance(extra, dict) else None


def _dof_params(
    model: BaseModel, prefix: tuple[Any, ...] = ()
) -> Iterator[tuple[tuple[Any, ...], str, Any, BaseModel]]:
    """Every DoF-naming parameter of a parameter model, nested models included.

    Yields (location, widget, value, owning model) for fields marked `x-widget: dofs` (selector lists)
    or `x-widget: pose` (DoF name -> value).
    """
    for name, info in type(model).model_fields.items():
        value = getattr(model, name, None)
        widget = _widget(info)
        if widget in (SELECTORS, POSE):
            yield (*prefix, name), widget, value, model
        elif isinstance(value, BaseModel):
            yield from _dof_params(value, (*prefix, name))
        elif isinstance(value, (list, tuple)):
            for j, item in enumerate(value):
                if isinstance(item, BaseModel):
                    yield from _dof_params(item, (*prefix, name, j))


def _dof_hint(emb: Embodiment, name: str) -> str:
    candidates = [d.name for d in emb.dofs] + list(getattr(emb, "channel_index", {}) or {})
    hint = difflib.get_close_matches(name.lstrip("!"), candidates, n=1)
    return f"; did you mean '{hint[0]}'?" if hint else ""


def dof_errors(node: Node, index: int, params: BlockParams, emb: Embodiment) -> list[Issue]:
    """Check every DoF selector and pose key of a node against the robot, each with its exact path."""
    out: list[Issue] = []
    for loc, widget, value, owner in _dof_params(params):
        port = _loc(loc)
        owner_name = getattr(owner, "name", None) if owner is not params else None
        whose = f"{str(loc[0]).rstrip('s')} '{owner_name}' of " if isinstance(owner_name, str) else ""
        head = f"{whose}node '{node.id}' ({node.type}), parameter '{port}'"
        if widget == SELECTORS and isinstance(value, (list, tuple)):
            for j, sel in enumerate(value):
                try:
                    select_dofs(emb, [sel])
                except SelectorError as exc:
                    out.append(
                        Issue(
                            code="unknown_dof",
                            node=node.id,
                            port=port,
                            path=_loc((f"nodes[{index}].params", *loc, j)),
                            message=f"{head}: {exc}{_dof_hint(emb, str(sel))}",
                        )
                    )
        elif widget == POSE and isinstance(value, dict):
            for name, v in value.items():
                path = _loc((f"nodes[{index}].params", *loc, name))
                try:
                    pose_vector(emb, {name: v})
                except SelectorError as exc:
                    out.append(
                        Issue(
                            code="unknown_dof",
                            node=node.id,
                            port=port,
                            path=path,
                            message=f"{head}: {exc}{_dof_hint(emb, str(name))}",
                        )
                    )
                except (ValueError, TypeError) as exc:
                    out.append(
                        Issue(
                            code="invalid_param", node=node.id, port=port, path=path, message=f"{head}: {exc}"
                        )
                    )
    return out


def find_value(data: Any, target: str, loc: tuple[Any, ...] = ()) -> tuple[Any, ...] | None:
    """Where a string (e.g. a selector a block rejected) occurs in a parameter dump."""
    if data == target:
        return loc
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        if isinstance(data, dict) and key == target:
            return (*loc, key)
        found = find_value(value, target, (*loc, key))
        if found is not None:
            return found
    return None
