"""Drivers: pluggable outputs that forward Animation Frames to robots, tools and files.

Every driver is an engine `Sink` (its own thread and bounded queue: a slow driver drops frames and
counts them, it never stalls the clock). Write one for a real robot by subclassing `Sink` and
overriding `consume(frame)`, or run a separate process on the `/ws/frames` WebSocket (docs/drivers.md).
"""

from backend.drivers.osc import OscDriver
from backend.drivers.recorder import FrameRecorder, read_recording
from backend.drivers.sim_servo import SimulatedServos

__all__ = ["FrameRecorder", "OscDriver", "SimulatedServos", "read_recording"]
