"""What the editor learns about blocks: the catalog (every block type with its schema, ports and port
rules), the palette's categories in order, and the wiring rule (which output types an input accepts).

The editor holds no copy of these: `nutty schema` writes them to frontend/node_editor/generated/, and
`GET /api/blocks` serves the catalog.
"""

from __future__ import annotations

from typing import Any

from backend.engine.blocks.base import BLOCKS
from backend.engine.blocks.ports import PortType, compatibility_table

# Palette groups in palette order, with their titles.
CATEGORIES: dict[str, str] = {
    "sources": "Sources",
    "operators": "Operators",
    "layers": "Layers",
    "stage2": "Stage 2",
    "signals": "Signals",
    "output": "Output",
}


def block_catalog() -> list[dict[str, Any]]:
    """Every registered block type with its schema, ports, category and doc (palette order)."""
    order = {name: k for k, name in enumerate(CATEGORIES)}
    return [
        BLOCKS[k].describe()
        for k in sorted(BLOCKS, key=lambda k: (order.get(BLOCKS[k].category, len(order)), k))
    ]


def editor_rules() -> dict[str, Any]:
    """The rules the editor applies while wiring and grouping blocks, as JSON."""
    return {
        "port_types": [t.value for t in PortType],
        "accepts": compatibility_table(),
        "categories": [{"name": name, "title": title} for name, title in CATEGORIES.items()],
    }
