"""Every number parameter gives the editor's slider a range an animator can use: a declared soft range
(`x-soft`) inside the hard bounds wherever the hard span is wide, so LFO amplitude slides over 0..1
and a filter's velocity limit over 0..20 rad/s, not 0..100 or 0..1e6."""

from __future__ import annotations

from typing import Any

import pytest

from backend.engine.blocks import BLOCKS

# A slider over more than this many units (with no soft range) is too coarse to set a value with.
WIDEST_HARD_SLIDER = 20.0


def _numbers() -> list[tuple[str, str, dict[str, Any], dict[str, Any]]]:
    out = []
    for kind, cls in sorted(BLOCKS.items()):
        for name, prop in cls.Params.model_json_schema().get("properties", {}).items():
            branch = next((b for b in prop.get("anyOf", [prop]) if b.get("type") != "null"), prop)
            if branch.get("type") == "number":
                out.append((kind, name, prop, branch))
    return out


@pytest.mark.parametrize(
    ("kind", "name", "prop", "branch"), _numbers(), ids=lambda v: v if isinstance(v, str) else ""
)
def test_number_parameters_have_a_usable_slider_range(kind, name, prop, branch):
    lo = branch.get("minimum", branch.get("exclusiveMinimum"))
    hi = branch.get("maximum", branch.get("exclusiveMaximum"))
    soft = prop.get("x-soft")
    if soft is None:
        if lo is not None and hi is not None:
            assert hi - lo <= WIDEST_HARD_SLIDER, (
                f"{kind}.{name}: hard range {lo}..{hi} needs an x-soft range"
            )
        return
    s_lo, s_hi = soft
    assert s_lo < s_hi, f"{kind}.{name}: empty soft range"
    assert (lo is None or s_lo >= lo) and (hi is None or s_hi <= hi), f"{kind}.{name}: soft beyond hard"
    step = prop.get("x-step")
    assert step is None or 0 < step <= (s_hi - s_lo) / 10, f"{kind}.{name}: step too coarse for its range"
    default = prop.get("default")
    if isinstance(default, (int, float)):
        assert s_lo <= default <= s_hi, f"{kind}.{name}: the default {default} is off its slider"


def test_the_lfo_slides_over_animation_sized_values():
    props = BLOCKS["lfo"].Params.model_json_schema()["properties"]
    assert props["amplitude"]["x-soft"] == [0, 1] and props["offset"]["x-soft"] == [-1, 1]
    assert props["frequency"]["x-soft"] == [0, 5] and props["frequency"]["x-step"] == 0.01  # 0.2 Hz reachable
    assert props["amplitude"]["maximum"] == 100.0  # typing may still go there
