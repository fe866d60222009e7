"""Every registered block honours the block contract: described, schema-driven, resettable, ticking.

This runs over the whole registry, so a new block gets these checks without writing them.
"""

from __future__ import annotations

import numpy as np
import pytest

from backend.engine.blocks import BLOCKS, block_catalog
from backend.engine.blocks.base import BlockContext, PortType, Role
from backend.engine.frames import PartialFrame
from backend.engine.library import RobotLibrary

CATEGORIES = {"sources", "operators", "layers", "stage2", "signals", "output"}


def test_catalog_describes_every_block():
    entries = block_catalog()
    assert {e["type"] for e in entries} == set(BLOCKS)
    for e in entries:
        assert e["category"] in CATEGORIES, e["type"]
        assert e["summary"] and len(e["summary"]) < 160, e["type"]
        assert e["doc"].startswith(e["summary"]) and e["summary"] != e["title"], e[
            "type"
        ]  # the docstring is shown
        assert e["params_schema"]["type"] == "object", e["type"]
        for port in (*e["inputs"].values(), *e["outputs"].values()):
            assert port["type"] in {t.value for t in PortType}


def _defaults_constructible(cls) -> bool:
    return not any(f.is_required() for f in cls.Params.model_fields.values())


@pytest.mark.parametrize("type_name", sorted(BLOCKS))
def test_block_ticks_with_default_params(desk, type_name):
    cls = BLOCKS[type_name]
    if not _defaults_constructible(cls):
        pytest.skip(f"{type_name} has required parameters")
    folder = desk.urdf_path.parent
    ctx = BlockContext(embodiment=desk, rate=100.0, resources=RobotLibrary(folder, desk))
    try:
        block = cls(cls.Params(), ctx, "n")
    except ValueError as exc:  # e.g. a default that needs a resource this robot lacks
        pytest.skip(f"{type_name} needs configuration on this robot: {exc}")
    ins, outs = cls.ports(block.params)
    inputs = {}
    for name, port in ins.items():
        if port.type is PortType.frame:
            inputs[name] = PartialFrame(desk.rest.copy(), np.ones(desk.n_channels, bool), [])
    for _ in range(3):
        result = block.tick(0.01, inputs)
    if cls.role is Role.output:
        assert "frame" in result
        return
    assert set(result) <= set(outs), f"{type_name} returned undeclared outputs {set(result) - set(outs)}"
    for name, port in outs.items():
        value = result.get(name)
        if port.type is PortType.frame and value is not None:
            assert value.values.shape == (desk.n_channels,)
            assert value.mask.dtype == bool
            assert np.all(np.isfinite(value.values[value.mask]))
    block.reset()
