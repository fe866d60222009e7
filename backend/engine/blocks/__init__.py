"""The Animation Block library. Importing this package registers every block module in it."""

from __future__ import annotations

import importlib
import pkgutil

from backend.engine.blocks.base import BLOCKS, Block, BlockContext, BlockParams, Port, PortType, Role, register_block

for _info in pkgutil.iter_modules(__path__):
    if _info.name != "base" and not _info.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_info.name}")


def block_catalog() -> list[dict]:
    """Every registered block type with its schema, ports, category and doc (palette order)."""
    order = {"sources": 0, "operators": 1, "layers": 2, "stage2": 3, "signals": 4, "output": 5}
    return [BLOCKS[k].describe() for k in sorted(BLOCKS, key=lambda k: (order.get(BLOCKS[k].category, 9), k))]


__all__ = ["BLOCKS", "Block", "BlockContext", "BlockParams", "Port", "PortType", "Role", "block_catalog", "register_block"]
