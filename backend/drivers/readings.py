"""What the motors really do, from the drivers that read them back: per URDF joint {commanded,
measured, error, effort, saturated} (api_types.JointReading). Real servos (backend.hardware) fill it,
and so will a physics preview: any sink with a `joint_readings()` method takes part."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

#: |effort| at or above this fraction of a motor's maximum torque counts as saturated (servos and the
#: physics preview alike).
SATURATED_EFFORT = 0.95


def joint_readings(sinks: Iterable[Any]) -> dict[str, dict[str, Any]] | None:
    """Every reading driver's joints merged, or None when no sink reads its motors. A joint read by two
    drivers: a real one's reading over a simulation's (`simulated = True`), else the later one's."""
    out: dict[str, dict[str, Any]] = {}
    found = False
    for sink in sorted(sinks, key=lambda s: not getattr(s, "simulated", False)):  # stable: real ones last
        read = getattr(sink, "joint_readings", None)
        if callable(read):
            found = True
            readings: Any = read()
            out.update(readings)
    return out if found else None


def first_method(sinks: Iterable[Any], name: str) -> Any:
    """Method `name` of the first sink that has it (a driver's optional capability), or None."""
    for sink in sinks:
        method = getattr(sink, name, None)
        if callable(method):
            return method
    return None


def hardware_status(sinks: Iterable[Any]) -> dict[str, Any] | None:
    """The real servos' status (api_types.HardwareStatus) of the first sink that drives them, or None."""
    status = first_method(sinks, "hardware_status")
    return None if status is None else status()


def simulation_status(sinks: Iterable[Any]) -> dict[str, Any] | None:
    """The physics preview's status (api_types.SimulationStatus) of the first sink that simulates, or None."""
    status = first_method(sinks, "simulation_status")
    return None if status is None else status()


def physics_source(sinks: Iterable[Any]) -> Any:
    """The physics preview's `physics_pose` (() -> (joints, links in contact) | None) of the first sink
    that simulates, for the Pre-Viz's physics ghost; None without one."""
    return first_method(sinks, "physics_pose")
