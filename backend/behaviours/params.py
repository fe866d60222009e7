"""A behaviour's parameters: the caller's values checked against their declared types, and put into
the items (`{param}` as a field's whole value takes the typed value; a say's text substitutes it).
"""

from __future__ import annotations

import math
import re
from typing import Any

from backend.behaviours.format import Behaviour, Param
from backend.behaviours.issues import Issue
from backend.behaviours.vocabulary import Vocabulary

WHOLE = re.compile(r"^\{([A-Za-z_][A-Za-z0-9_]*)\}$")
INSIDE = re.compile(r"\{([A-Za-z_][A-Za-z0-9_]*)\}")
GAZE_REACH = 20.0  # m: as the look_at command (backend.control.postures)


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_value(name: str, p: Param, v: Any, vocab: Vocabulary | None) -> str | None:
    """Why `v` cannot be parameter `name`'s value, or None."""
    if p.type == "string":
        if not isinstance(v, str):
            return f"'{name}' is a string, got {v!r}"
        if len(v) > 200:
            return f"'{name}' is at most 200 characters"
        if p.choices and v not in p.choices:
            return f"'{name}' is one of {p.choices}, got {v!r}"
    elif p.type == "number":
        if not _number(v):
            return f"'{name}' is a number, got {v!r}"
        if (p.min is not None and v < p.min) or (p.max is not None and v > p.max):
            return f"'{name}' must be within {p.min}..{p.max}, got {v}"
    elif p.type == "bool":
        if not isinstance(v, bool):
            return f"'{name}' is true or false, got {v!r}"
    elif isinstance(v, str):  # vec3: an exposed input followed live
        inputs = vocab.inputs if vocab is not None else None
        if inputs is not None and v not in inputs:
            return f"'{name}': the running program has no exposed input '{v}' (inputs: {sorted(inputs)})"
        if inputs is not None and inputs[v].type != "vec3":
            return f"'{name}': exposed input '{v}' is a {inputs[v].type}, not a vec3"
    elif not (isinstance(v, (list, tuple)) and len(v) == 3 and all(_number(c) for c in v)):
        return f"'{name}' is a point [x, y, z] (m) or the name of an exposed vec3 input, got {v!r}"
    elif any(abs(c) > GAZE_REACH for c in v):
        return f"'{name}': each coordinate within +-{GAZE_REACH:g} m, got {list(v)}"
    return None


def bind(beh: Behaviour, given: Any, vocab: Vocabulary | None) -> tuple[dict[str, Any], list[Issue]]:
    """The parameter values to play with: the caller's, else the defaults. Issues name `params.<name>`
    (unknown, missing or of the wrong type)."""
    issues: list[Issue] = []
    if given is None:
        given = {}
    if not isinstance(given, dict):
        return {}, [Issue("params is an object of parameter name -> value", "params", field="params")]
    for name in given:
        if name not in beh.params:
            known = sorted(beh.params) or "none"
            issues.append(Issue(f"no parameter '{name}' (parameters: {known})", f"params.{name}", field=name))
    values: dict[str, Any] = {}
    for name, p in beh.params.items():
        v = given.get(name, p.default)
        if v is None:
            issues.append(Issue(f"parameter '{name}' is required", f"params.{name}", field=name))
            continue
        why = check_value(name, p, v, vocab)
        if why is not None:
            issues.append(Issue(why, f"params.{name}", field=name))
            continue
        values[name] = list(v) if isinstance(v, tuple) else v
    return values, issues


def check_declarations(beh: Behaviour) -> list[Issue]:
    """Each parameter's default fits its type (an input name is checked when the behaviour plays)."""
    issues = []
    for name, p in beh.params.items():
        if p.default is not None:
            why = check_value(name, p, p.default, None)
            if why is not None:
                issues.append(Issue(f"default: {why}", f"params.{name}.default", field="default"))
        if p.min is not None and p.max is not None and p.min >= p.max:
            issues.append(Issue("min must be below max", f"params.{name}.min", field="min"))
    return issues


def references(value: Any) -> list[str]:
    """The parameters a field's value names."""
    if isinstance(value, str):
        whole = WHOLE.match(value)
        return [whole.group(1)] if whole else []
    return []


def substitute(item: dict[str, Any], values: dict[str, Any]) -> dict[str, Any]:
    """`item` (a JSON dict) with its parameters put in; names without a value stay as they are."""
    out = {}
    for key, v in item.items():
        if key in ("id", "start", "kind", "label"):
            out[key] = v
        elif key == "text" and isinstance(v, str):
            out[key] = INSIDE.sub(
                lambda m: _text(values[m.group(1)]) if m.group(1) in values else m.group(0), v
            )
        else:
            names = references(v)
            out[key] = values[names[0]] if names and names[0] in values else v
    return out


def _text(v: Any) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float) and v.is_integer():
        return str(int(v))
    return str(v)
