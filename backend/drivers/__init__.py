"""Drivers: pluggable outputs that forward Animation Frames to robots, tools and files.

Every driver is an engine `Sink` (its own thread and bounded queue: a slow driver drops frames and
counts them, it never stalls the clock). Write one for a real robot by subclassing `Sink` and
overriding `consume(frame)`, or run a separate process on the `/ws/frames` WebSocket (docs/drivers.md).
DRIVER_OPTIONS holds the drivers the `nutty.drivers` entry points name (backend.drivers.registry), so a
driver with its entry point is on `nutty serve`'s command line with no other edit.
"""

from __future__ import annotations

from backend.drivers.osc import OscDriver
from backend.drivers.recorder import FrameRecorder, read_recording
from backend.drivers.registry import (
    DRIVER_OPTIONS,
    DriverArgs,
    DriverOption,
    DriverSetting,
    add_driver_options,
    build_driver,
    build_drivers,
    register_driver,
    reload,
)
from backend.drivers.sim_servo import SimulatedServos

reload()

__all__ = [
    "DRIVER_OPTIONS",
    "DriverArgs",
    "DriverOption",
    "DriverSetting",
    "FrameRecorder",
    "OscDriver",
    "SimulatedServos",
    "add_driver_options",
    "build_driver",
    "build_drivers",
    "read_recording",
    "register_driver",
    "reload",
]
