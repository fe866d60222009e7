"""The one interface every servo bus implements, whatever its protocol: a serial port of Dynamixel or
Feetech servos, or an I2C PWM board. The hardware driver (backend.hardware.driver) talks only to it.

Positions on a bus are *raw* units: encoder ticks for serial servos, pulse widths (µs) for PWM servos.
`backend.hardware.mapping.JointMap` converts them to and from joint values (rad or m). A bus is used
from one thread at a time (its driver's bus thread), so it needs no locks of its own.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

#: The faults a servo can report (its status or hardware-error flags), plus the driver's own
#: `no_answer` (no valid reply for the configured timeout, 100 ms by default).
FAULTS = ("overload", "overheat", "voltage", "encoder", "electrical", "no_answer")


#: pyserial's read timeout (s) while a vendor SDK waits for a reply. Both SDKs open the port
#: non-blocking and poll it in a tight loop while they wait, holding a core and the interpreter lock
#: the engine's clock needs; 1 ms makes each poll sleep in the kernel, adding at most 1 ms to a timeout.
SERIAL_TIMEOUT_S = 0.001


class HardwareError(RuntimeError):
    """A bus or servo that cannot be used; the message names the port, the id and the joint if known,
    and is meant to be shown as one line."""


@dataclass(frozen=True)
class ServoInfo:
    """A servo that answered a ping.

    id: its bus id. model: the model number it reported. model_name: e.g. `XM430-W350`, `STS3215`.
    position: its present position (raw units), None when not read. raw_min/raw_max: the goal range
    the model accepts in position mode (raw units). ticks_per_turn: raw units per revolution (serial
    servos: encoder resolution; PWM: 0, the mapping comes from the configured pulse widths).
    """

    id: int
    model: int
    model_name: str
    position: float | None = None
    raw_min: float = 0.0
    raw_max: float = 4095.0
    ticks_per_turn: int = 4096


@dataclass
class BusReading:
    """One read of a bus's servos, in the order of the ids asked for.

    position: present positions (raw units; NaN where no valid reply came: a timeout, a bad CRC, a
    servo that cannot report, like a PWM servo). effort: the load as a fraction of the servo's maximum
    torque (-1..1; NaN: unknown). faults: id -> one of FAULTS for the servos that flagged one.
    """

    position: np.ndarray
    effort: np.ndarray
    faults: dict[int, str] = field(default_factory=dict)


class ServoBus(ABC):
    """A bus of servos of one protocol (one serial port, or one PWM board).

    Subclasses set `kind` (the `driver:` name in hardware.yaml and the `nutty.hardware` entry point's
    name) and `config_model` (the pydantic model of its hardware.yaml entry, a `BusConfig`), and are
    made from that entry: `Bus(config)`. `open()` must be called before anything else; `close()` closes
    the port (torque is the driver's business, not close's).
    """

    kind: ClassVar[str]
    config_model: ClassVar[type[Any]]
    #: Whether the servos report their position (False: hobby PWM servos, which start where they are
    #: told to, so the driver cannot start from their measured pose).
    reads_position: ClassVar[bool] = True
    #: The raw units' name, for messages (`ticks`, `µs`).
    raw_unit: ClassVar[str] = "ticks"

    def __init__(self, config: Any):
        self.config = config

    @property
    def where(self) -> str:
        """Where the bus is, for messages (`/dev/ttyUSB0`, `i2c-1 @ 0x40`)."""
        return str(getattr(self.config, "port", self.kind))

    @abstractmethod
    def open(self) -> None:
        """Open the port at the configured rate; HardwareError saying why not."""

    @abstractmethod
    def close(self) -> None:
        """Close the port (idempotent)."""

    @abstractmethod
    def ping(self, ids: Sequence[int]) -> dict[int, ServoInfo | None]:
        """Each id's ServoInfo (with its present position), or None when it did not answer."""

    def scan(self, ids: Iterable[int] = range(253)) -> list[ServoInfo]:
        """Every servo that answers among `ids` (default: all of a serial bus), with its position."""
        return [info for info in self.ping(list(ids)).values() if info is not None]

    @abstractmethod
    def torque(self, ids: Sequence[int], on: bool) -> None:
        """Enable or disable the servos' torque (position mode); HardwareError if a servo refuses."""

    @abstractmethod
    def write_goals(self, ids: Sequence[int], raw: np.ndarray) -> None:
        """Send goal positions (raw units, one per id) in one bus transaction where the protocol has one
        (SYNC WRITE). Never waits for replies."""

    @abstractmethod
    def read_state(self, ids: Sequence[int]) -> BusReading:
        """Present positions, loads and fault flags of `ids`, in one transaction where the protocol has
        one (SYNC READ). Never raises for a servo that does not answer: its position is NaN."""


def open_serial(port: Any, baudrate: int, where: str) -> None:
    """Open a vendor SDK's PortHandler (Dynamixel's and Feetech's share its API) at `baudrate`, with
    SERIAL_TIMEOUT_S as its read timeout; HardwareError naming `where` when it cannot."""
    try:
        opened = port.setBaudRate(baudrate)  # opens the port at that rate
    except (OSError, ValueError) as exc:  # pyserial's SerialException is an OSError
        raise HardwareError(f"{where}: cannot open the port: {exc}") from None
    if not opened:
        raise HardwareError(f"{where}: cannot open the port at {baudrate} baud, not a rate the SDK supports")
    port.ser.timeout = SERIAL_TIMEOUT_S


def goal_vector(ids: Sequence[int], raw: Any) -> np.ndarray:
    """`write_goals`' goals as floats, one finite position per id; ValueError naming the servo if not."""
    goals = np.asarray(raw, dtype=float)
    if goals.shape != (len(ids),):
        raise ValueError(
            f"write_goals: raw has shape {goals.shape}, expected ({len(ids)},) for ids {tuple(ids)}"
        )
    bad = ~np.isfinite(goals)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"write_goals: raw[{i}] (servo id {ids[i]}) is {goals[i]}, not a finite position")
    return goals
