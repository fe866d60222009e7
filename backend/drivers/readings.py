"""What the motors really do, from the drivers that read them back: per URDF joint {commanded,
measured, error, effort, saturated} (api_types.JointReading). Real servos (backend.hardware) fill it,
and so will a physics preview: any sink with a `joint_readings()` method takes part."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any


def joint_readings(sinks: Iterable[Any]) -> dict[str, dict[str, Any]] | None:
    """Every reading driver's joints merged (a joint read by two drivers: the later one's), or None when
    no sink reads its motors."""
    out: dict[str, dict[str, Any]] = {}
    found = False
    for sink in sinks:
        read = getattr(sink, "joint_readings", None)
        if callable(read):
            found = True
            readings: Any = read()
            out.update(readings)
    return out if found else None


def hardware_status(sinks: Iterable[Any]) -> dict[str, Any] | None:
    """The real servos' status (api_types.HardwareStatus) of the first sink that drives them, or None."""
    for sink in sinks:
        status = getattr(sink, "hardware_status", None)
        if callable(status):
            result: Any = status()
            return result
    return None
