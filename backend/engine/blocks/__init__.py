"""The Animation Block library. Importing this package registers every block module in it."""

from __future__ import annotations

import importlib
import pkgutil

from backend.engine.blocks.base import (
    BLOCKS,
    Block,
    BlockContext,
    BlockParams,
    Port,
    PortType,
    Role,
    register_block,
)

# Modules that define no block: the base classes, ports and their rules, the catalog built from the registry.
_SUPPORT = {"base", "ports", "catalog"}

for _info in pkgutil.iter_modules(__path__):
    if _info.name not in _SUPPORT and not _info.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_info.name}")

from backend.engine.blocks.catalog import CATEGORIES, block_catalog, editor_rules  # noqa: E402  (after the blocks)

__all__ = [
    "BLOCKS",
    "CATEGORIES",
    "Block",
    "BlockContext",
    "BlockParams",
    "Port",
    "PortType",
    "Role",
    "block_catalog",
    "editor_rules",
    "register_block",
]
