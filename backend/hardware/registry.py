"""The bus kinds hardware.yaml can name (`driver: dynamixel`): `ServoBus` classes registered by
`nutty.hardware` entry points, each named after its class's `kind`:

    [project.entry-points."nutty.hardware"]
    dynamixel = "backend.hardware.dynamixel:DynamixelBus"

A bus kind whose SDK is not installed still registers (the SDK is imported when a bus is opened), so
`nutty serve --hardware` can say which extra to install.
"""

from __future__ import annotations

from typing import Any

from backend.hardware.bus import ServoBus
from backend.plugins import load

BUSES: dict[str, type[ServoBus]] = {}


def bus_kind(cls: Any) -> str:
    return cls.kind


def register_bus(cls: type[ServoBus], registry: dict[str, type[ServoBus]] | None = None) -> type[ServoBus]:
    """Add a bus class (a ServoBus with `kind` and `config_model`) to `registry` (default BUSES)."""
    buses = BUSES if registry is None else registry
    if not (isinstance(cls, type) and issubclass(cls, ServoBus)):
        raise TypeError(f"{cls!r} is not a ServoBus")
    if not isinstance(getattr(cls, "kind", None), str) or getattr(cls, "config_model", None) is None:
        raise TypeError(f"{cls!r} declares no `kind` and `config_model`")
    if cls.kind in buses:
        raise ValueError(f"bus kind {cls.kind!r} is declared twice ({buses[cls.kind]} and {cls})")
    buses[cls.kind] = cls
    return cls


def reload() -> None:
    """Fill BUSES (in place) from the `nutty.hardware` entry points."""
    found: dict[str, type[ServoBus]] = {}
    load("nutty.hardware", bus_kind, lambda cls: register_bus(cls, found))
    BUSES.clear()
    BUSES.update(found)


reload()
