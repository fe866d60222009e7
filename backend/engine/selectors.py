"""DoF selectors: how programs name the DoFs they act on, so one program can run on many robots.

A selector is one of:
- an exact DoF name (`head_yaw`) or a channel name (`eye_leds.r`);
- a glob over DoF names (`head_*`, `*_pitch`, `ear_?`);
- a dimension selector `stationary:*`, `spatial:*`, `display:*`, `audible:*`, optionally with a glob
  after the colon (`stationary:neck_*`);
- a type selector `type:continuous`, `type:colour`, `type:enum`, `type:event`;
- `*` for every DoF.
A leading `!` excludes what the rest of the selector matches (applied after all inclusions).

`find_pairs` names left/right DoF pairs the same robot-independent way (*_left/*_right, left_*/right_*,
*_l/*_r, or explicit pairs).
"""

from __future__ import annotations

import fnmatch
from functools import lru_cache

import numpy as np

from backend.engine.embodiment import Dimension, Dof, DofType, Embodiment

_DIMENSIONS = {d.value for d in Dimension}
_TYPES = {t.value for t in DofType}


class SelectorError(ValueError):
    """A selector is malformed or matches nothing; `selector` says which one."""

    def __init__(self, selector: str, message: str):
        super().__init__(message)
        self.selector = selector


def _matches(emb: Embodiment, selector: str) -> list[Dof]:
    if selector == "*":
        return list(emb.dofs)
    if ":" in selector:
        head, _, pattern = selector.partition(":")
        pattern = pattern or "*"
        if head == "type":
            if pattern not in _TYPES:
                raise SelectorError(selector, f"unknown DoF type '{pattern}' (one of {sorted(_TYPES)})")
            return [d for d in emb.dofs if d.type.value == pattern]
        if head not in _DIMENSIONS:
            raise SelectorError(
                selector,
                f"unknown dimension '{head}' in selector '{selector}' (one of {sorted(_DIMENSIONS)})",
            )
        return [d for d in emb.dofs if d.dimension.value == head and fnmatch.fnmatchcase(d.name, pattern)]
    if any(ch in selector for ch in "*?["):
        return [d for d in emb.dofs if fnmatch.fnmatchcase(d.name, selector)]
    if emb.has_dof(selector):
        return [emb.dof(selector)]
    return []


def select_dofs(emb: Embodiment, selectors: list[str] | str, *, allow_empty: bool = True) -> list[Dof]:
    """DoFs matched by `selectors`, in embodiment order.

    Raises SelectorError for a malformed selector, or an exact name the robot lacks. A glob that
    matches nothing is not an error (a generic program may find no ears on a robot) unless
    `allow_empty` is False and the whole selection is empty.
    """
    if isinstance(selectors, str):
        selectors = [selectors]
    included: set[str] = set()
    excluded: set[str] = set()
    for raw in selectors:
        sel = raw.strip()
        negate = sel.startswith("!")
        if negate:
            sel = sel[1:]
        if not sel:
            raise SelectorError(raw, "empty DoF selector")
        found = _matches(emb, sel)
        exact = not any(ch in sel for ch in "*?[:")
        if exact and not found and sel not in emb.channel_index:
            raise SelectorError(raw, f"robot '{emb.name}' has no DoF '{sel}'")
        (excluded if negate else included).update(d.name for d in found)
    if selectors and all(s.strip().startswith("!") for s in selectors):
        included = {d.name for d in emb.dofs}  # only exclusions: "everything but ..."
    chosen = [d for d in emb.dofs if d.name in included and d.name not in excluded]
    if not chosen and not allow_empty:
        raise SelectorError(", ".join(selectors), f"selectors {selectors} match no DoF of robot '{emb.name}'")
    return chosen


def channel_mask(emb: Embodiment, selectors: list[str] | str, *, continuous_only: bool = False) -> np.ndarray:
    """Boolean mask over the embodiment's channels for the selected DoFs (channel names allowed too)."""
    return _channel_mask_cached(
        emb, tuple([selectors] if isinstance(selectors, str) else selectors), continuous_only
    )


@lru_cache(maxsize=1024)
def _channel_mask_cached(emb: Embodiment, selectors: tuple[str, ...], continuous_only: bool) -> np.ndarray:
    mask = np.zeros(emb.n_channels, dtype=bool)
    direct = [s for s in selectors if s in emb.channel_index and not emb.has_dof(s)]
    rest = [s for s in selectors if s not in direct]
    if rest:
        for d in select_dofs(emb, rest):
            mask[d.channels] = True
    for s in direct:
        mask[emb.channel_index[s]] = True
    if continuous_only:
        mask &= emb.continuous_mask
    mask.setflags(write=False)
    return mask


# --------------------------------------------------------------------------------------------------
# Left/right pairs (the mirror and asymmetry operators)
# --------------------------------------------------------------------------------------------------

# (left pattern, right pattern) as (prefix, suffix) pairs: *_left/*_right, left_*/right_*, *_l/*_r.
_SIDE_PATTERNS = ((("", "_left"), ("", "_right")), (("left_", ""), ("right_", "")), (("", "_l"), ("", "_r")))


def _width(d: Dof) -> int:
    return d.channels.stop - d.channels.start


def _partner_name(name: str) -> str | None:
    """The right-side name of a left-side DoF name, or None if the name has no left marker."""
    for (lp, ls), (rp, rs) in _SIDE_PATTERNS:
        if name.startswith(lp) and name.endswith(ls) and len(name) > len(lp) + len(ls):
            core = name[len(lp) : len(name) - len(ls)] if ls else name[len(lp) :]
            return f"{rp}{core}{rs}"
    return None


def find_pairs(
    emb: Embodiment, explicit: list[list[str]] | None = None, auto: bool = True
) -> list[tuple[Dof, Dof]]:
    """Left/right DoF pairs: explicit `[left, right]` pairs first, then pairs found by name.

    Raises ValueError naming the DoF when an explicit pair is unknown or mismatched.
    """
    pairs: list[tuple[Dof, Dof]] = []
    used: set[str] = set()
    for pair in explicit or []:
        a, b = pair
        for name in (a, b):
            if not emb.has_dof(name):
                raise ValueError(f"pair {pair}: robot '{emb.name}' has no DoF '{name}'")
            if name in used:
                raise ValueError(f"pair {pair}: DoF '{name}' is already in another pair")
        da, db = emb.dof(a), emb.dof(b)
        if da.type is not db.type or _width(da) != _width(db):
            raise ValueError(
                f"pair {pair}: '{a}' is {da.type.value} and '{b}' is {db.type.value}; "
                f"paired DoFs must have the same type"
            )
        if _width(da) == 0:
            raise ValueError(f"pair {pair}: event DoFs cannot be paired")
        pairs.append((da, db))
        used.update((a, b))
    if auto:
        for d in emb.dofs:
            partner = _partner_name(d.name)
            if partner is None or d.name in used or partner in used or not emb.has_dof(partner):
                continue
            p = emb.dof(partner)
            if p.type is d.type and _width(d) == _width(p) and _width(d) > 0:
                pairs.append((d, p))
                used.update((d.name, partner))
    return pairs


def pair_channels(pairs: list[tuple[Dof, Dof]]) -> tuple[np.ndarray, np.ndarray]:
    """The channels of the left and of the right DoF of each pair, in pair order."""
    left = [i for a, _ in pairs for i in range(a.channels.start, a.channels.stop)]
    right = [i for _, b in pairs for i in range(b.channels.start, b.channels.stop)]
    return np.array(left, dtype=np.intp), np.array(right, dtype=np.intp)
