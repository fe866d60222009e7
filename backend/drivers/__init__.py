"""Drivers: pluggable outputs that forward Animation Frames to robots, tools and files.

Every driver is an engine `Sink` (its own thread and bounded queue: a slow driver drops frames and
counts them, it never stalls the clock). Write one for a real robot by subclassing `Sink` and
overriding `consume(frame)`, or run a separate process on the `/ws/frames` WebSocket (docs/drivers.md).
Importing this package imports every module in it, so a driver declared with `@driver_option` in a
new file is on `nutty serve`'s command line with no other edit.
"""

from __future__ import annotations

import importlib
import pkgutil

from backend.drivers.osc import OscDriver
from backend.drivers.recorder import FrameRecorder, read_recording
from backend.drivers.registry import DRIVER_OPTIONS, add_driver_options, build_drivers, driver_option
from backend.drivers.sim_servo import SimulatedServos

for _info in pkgutil.iter_modules(__path__):
    if not _info.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_info.name}")

__all__ = [
    "DRIVER_OPTIONS",
    "FrameRecorder",
    "OscDriver",
    "SimulatedServos",
    "add_driver_options",
    "build_drivers",
    "driver_option",
    "read_recording",
]
