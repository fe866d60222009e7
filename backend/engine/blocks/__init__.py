"""The Animation Block library: BLOCKS holds every block type the `nutty.blocks` entry points name
(this project's, in pyproject.toml, and those of installed plugin packages; see backend.plugins). It is
filled when this package is imported; `reload()` reads the entry points again."""

from __future__ import annotations

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
from backend.engine.blocks.catalog import CATEGORIES, block_catalog, editor_rules
from backend.plugins import load


def reload() -> None:
    """Fill BLOCKS (in place) from the `nutty.blocks` entry points; on a PluginError it is left as it was."""
    found: dict[str, type[Block]] = {}
    load("nutty.blocks", lambda cls: cls.type_name, lambda cls: register_block(cls, found))
    BLOCKS.clear()
    BLOCKS.update(found)


reload()

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
    "reload",
]
