"""The `nutty hardware` tools: find the servos on a bus, and calibrate a joint's zero and direction.

`scan(kind, port, ...)` pings every id of a serial bus and lists what answers (id, model, position).
`Calibration` walks one joint of a hardware file: torque off, the person puts the joint at 0 rad, then
turns it towards positive values; the servo's readings give `zero` and `direction` (and, with the angle
of the second pose, a check of the gear), and the file is written back with the old one kept beside it.
"""

from __future__ import annotations

import math
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import yaml

from backend.engine.embodiment import Embodiment
from backend.hardware.bus import HardwareError, ServoBus, ServoInfo
from backend.hardware.config import Hardware, SerialBusConfig, check_against, parse_hardware
from backend.hardware.registry import BUSES

#: The smallest turn (ticks) that tells the direction apart from reading noise.
MIN_TURN_TICKS = 20
#: How long calibration keeps asking its one servo (s) before saying it does not answer. A person waits
#: here, not a clock: a reply held up by a busy adapter or machine (a pty's far end is a process) is
#: worth waiting for, where the engine's bus gives up within a tick.
PATIENCE_S = 0.5

T = TypeVar("T")


def patiently(ask: Callable[[], T | None], patience_s: float = PATIENCE_S) -> T | None:
    """`ask()` again while it gives None or raises HardwareError, until `patience_s` (s) have passed;
    then its last answer (None), or its last HardwareError raised."""
    deadline = time.monotonic() + patience_s
    while True:
        try:
            got = ask()
        except HardwareError:
            if time.monotonic() >= deadline:
                raise
            continue
        if got is not None or time.monotonic() >= deadline:
            return got


def open_bus(kind: str, port: str, baudrate: int, **extra: Any) -> ServoBus:
    """An opened bus of `kind` on `port` with no joints configured (for scanning); HardwareError if the
    kind is unknown or the port cannot be opened."""
    if kind not in BUSES:
        raise HardwareError(f"unknown bus driver {kind!r} (known: {', '.join(sorted(BUSES))})")
    model = BUSES[kind].config_model
    fields: dict[str, Any] = {"driver": kind, "port": port, "baudrate": baudrate, "joints": {}, **extra}
    config = model.model_construct(**{k: v for k, v in fields.items() if k in model.model_fields})
    bus = BUSES[kind](config)
    bus.open()
    return bus


def scan(kind: str, port: str, baudrate: int, ids: range, **extra: Any) -> list[ServoInfo]:
    """Every servo that answers among `ids` on a serial bus, with its model and present position."""
    bus = open_bus(kind, port, baudrate, **extra)
    try:
        return bus.scan(ids)
    finally:
        bus.close()


@dataclass
class JointOnBus:
    """Where a joint of a hardware file is: its bus's index, config and the servo's id."""

    bus_index: int
    config: SerialBusConfig
    servo: int


def find_joint(hardware: Hardware, joint: str) -> JointOnBus:
    for i, config in enumerate(hardware.buses):
        if isinstance(config, SerialBusConfig) and joint in config.joints:
            return JointOnBus(i, config, config.joints[joint].id)
    raise HardwareError(
        f"{joint!r} is not on a serial bus of {hardware.path} (PWM joints: set pulse_us by hand)"
    )


class Calibration:
    """One joint's calibration, step by step (the CLI prompts between the steps).

    `start()` opens the bus and switches the servo's torque off so the joint can be moved by hand;
    `at_zero()` reads the position at 0 rad; `at_positive(angle)` reads it again after a turn to
    `angle` rad (> 0: the joint's positive direction) and returns the new zero, direction and the gear
    the two readings imply; `write()` saves the file (the old one as FILE.bak) after checking it.
    """

    def __init__(self, hardware: Hardware, emb: Embodiment, joint: str, bus: ServoBus | None = None):
        if hardware.path is None:
            raise HardwareError("calibration needs a hardware file to write")
        self.hardware, self.emb, self.joint = hardware, emb, joint
        self.where = find_joint(hardware, joint)
        self.bus = bus if bus is not None else BUSES[self.where.config.driver](self.where.config)
        self.zero: float | None = None
        self.direction: int | None = None
        self.gear: float | None = None

    def start(self) -> None:
        self.bus.open()
        found = patiently(lambda: self.bus.ping([self.where.servo]).get(self.where.servo))
        if found is None:
            raise HardwareError(f"{self.joint}: no answer from id {self.where.servo} on {self.bus.where}")
        patiently(lambda: self.bus.torque([self.where.servo], False) or True)

    def read(self) -> float:
        def position() -> float | None:
            value = float(self.bus.read_state([self.where.servo]).position[0])
            return None if math.isnan(value) else value

        value = patiently(position)
        if value is None:
            raise HardwareError(f"{self.joint}: id {self.where.servo} did not report its position")
        return value

    def at_zero(self) -> float:
        self.zero = round(self.read())
        return self.zero

    def at_positive(self, angle: float) -> tuple[float, int, float]:
        if self.zero is None:
            raise HardwareError("read the zero pose first")
        if not angle > 0:
            raise HardwareError(f"the second pose must be at a positive angle, got {angle:g}")
        turn = self.read() - self.zero
        if abs(turn) < MIN_TURN_TICKS:
            raise HardwareError(
                f"the servo turned only {turn:.0f} ticks: turn the joint further and try again"
            )
        self.direction = 1 if turn > 0 else -1
        per_rad = self.where.config.ticks_per_turn() / (2 * math.pi)
        self.gear = abs(turn) / (angle * per_rad)
        return self.zero, self.direction, self.gear

    def write(self, keep_gear: bool = True) -> Path:
        """Save zero and direction (and the measured gear unless `keep_gear`) into the file; the old file
        is kept as FILE.bak. HardwareError (nothing written) when the result fails the file's checks."""
        if self.zero is None or self.direction is None:
            raise HardwareError("nothing measured yet")
        path = Path(str(self.hardware.path))
        data = yaml.safe_load(path.read_text())
        entry = data["buses"][self.where.bus_index]["joints"][self.joint]
        entry["zero"], entry["direction"] = int(self.zero), int(self.direction)
        if not keep_gear and self.gear is not None:
            entry["gear"] = round(self.gear, 3)
        try:
            check_against(parse_hardware(data, path), self.emb)
        except ValueError as exc:
            raise HardwareError(f"not written: {exc}") from None
        shutil.copyfile(path, path.with_suffix(path.suffix + ".bak"))
        path.write_text(yaml.safe_dump(data, sort_keys=False, default_flow_style=None))
        return path

    def close(self) -> None:
        self.bus.close()
