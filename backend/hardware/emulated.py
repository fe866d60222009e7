"""`nutty serve --hardware-emulator FILE`: the whole servo stack — the real SDKs, the driver, its
threads, reads and faults — against emulated buses instead of a robot (development, demos, tests).

Every serial bus of the file gets a bus emulator on a pseudo-terminal (backend.hardware.emulator:
written from the protocols' documents, independent of the SDKs), with a servo of the bus's usual model
at each configured id, standing at the robot's rest pose; every PCA9685 board gets the chip's register
model as its I2C bus. The emulators stop when the driver closes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from backend.drivers.registry import DriverOption
from backend.engine.embodiment import Embodiment
from backend.hardware.bus import ServoBus
from backend.hardware.config import (
    BusConfig,
    DynamixelBusConfig,
    FeetechBusConfig,
    Hardware,
    Pca9685BusConfig,
    load_hardware,
)
from backend.hardware.driver import HardwareDriver
from backend.hardware.dynamixel import DynamixelBus
from backend.hardware.feetech import FeetechBus
from backend.hardware.mapping import JointMap
from backend.hardware.pca9685 import Pca9685Bus

#: How long the buses wait for an emulated servo's reply (ms): the emulators are Python threads of this
#: process, which a busy clock or machine can hold off for longer than real servos ever take.
EMULATED_REPLY_MS = 40.0
#: The model an emulated servo is, per bus kind (model numbers from the makers' control tables).
DYNAMIXEL_MODEL = 1020  # XM430-W350
FEETECH_MODELS = {"sts": "STS3215", "scs": "SCS0009"}


def _emulated_bus(config: BusConfig, ids: list[int]) -> tuple[Any, ServoBus]:
    """(a started emulator, the bus that talks to it) for one bus entry."""
    from backend.hardware.emulator.dynamixel import DynamixelEmulator  # lazy: only when emulating
    from backend.hardware.emulator.feetech import FeetechEmulator  # lazy: only when emulating
    from backend.hardware.emulator.pca9685 import Pca9685Emulator  # lazy: only when emulating

    if isinstance(config, DynamixelBusConfig):
        dxl = DynamixelEmulator(dict.fromkeys(ids, DYNAMIXEL_MODEL)).start()
        on_pty = config.model_copy(update={"port": dxl.path})
        return dxl, DynamixelBus(on_pty, latency_ms=EMULATED_REPLY_MS / 2)
    if isinstance(config, FeetechBusConfig):
        sts = FeetechEmulator(dict.fromkeys(ids, FEETECH_MODELS[config.series]), series=config.series).start()
        on_pty = config.model_copy(update={"port": sts.path})
        return sts, FeetechBus(on_pty, reply_timeout_ms=EMULATED_REPLY_MS)
    if isinstance(config, Pca9685BusConfig):
        chip = Pca9685Emulator(config.address)
        return chip, Pca9685Bus(config, i2c=chip)
    raise ValueError(f"no emulator for bus kind {config.driver!r}")


def emulate(hardware: Hardware, emb: Embodiment) -> tuple[list[ServoBus], list[Any]]:
    """(the buses, on emulators; the emulators, started, their servos at the rest pose), one per bus."""
    rest = np.asarray(emb.joint_positions(emb.rest), dtype=float)
    buses: list[ServoBus] = []
    emulators: list[Any] = []
    for config in hardware.buses:
        jmap = JointMap(config, emb)
        emulator, bus = _emulated_bus(config, jmap.ids)
        if bus.reads_position:
            for servo, ticks in zip(jmap.ids, np.round(jmap.to_raw(rest)).astype(int).tolist()):
                emulator.set_position(servo, ticks)
        emulators.append(emulator)
        buses.append(bus)
    return buses, emulators


class EmulatedHardwareDriver(HardwareDriver):
    option = DriverOption(
        "hardware-emulator",
        metavar="FILE",
        help="like --hardware FILE, against emulated servo buses (no robot needed; docs/hardware.md)",
        needs_engine=True,
    )

    def __init__(self, embodiment: Embodiment, hardware: Hardware):
        buses, self.emulators = emulate(hardware, embodiment)
        super().__init__(embodiment, hardware, buses)

    @classmethod
    def from_option(cls, embodiment: Embodiment, path: str) -> EmulatedHardwareDriver:
        return cls(embodiment, load_hardware(path, embodiment))

    def hardware_status(self) -> dict[str, Any]:
        return {**super().hardware_status(), "emulated": True}

    def close(self, timeout: float = 2.0) -> None:
        try:
            super().close(timeout)
        finally:
            for emulator in self.emulators:
                emulator.close()
