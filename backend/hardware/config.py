"""hardware.yaml: which servos move which joints, on which buses (the pydantic models are the schema).

    buses:
      - driver: dynamixel
        port: /dev/ttyUSB0
        baudrate: 1000000
        joints:
          head_yaw: {id: 3, zero: 2048, direction: 1}   # ticks at 0 rad, +1 or -1; gear optional
      - driver: pca9685
        i2c_bus: 1
        joints:
          eyelid_left: {channel: 0, pulse_us: {0.0: 1000, 1.3: 2000}}   # µs at two angles (rad)
    torque_on_exit: false

`load_hardware(path, embodiment)` reads and checks a file: every entry against its bus kind's model,
every joint against the robot (an actuated URDF joint, configured once), and every joint's whole URDF
range against what its servo can reach. Errors name the field (`buses[0].joints.head_yaw.zero`) and say
why, in one HardwareConfigError.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from backend.engine.embodiment import Embodiment
from backend.hardware.mapping import JointMap


class HardwareConfigError(ValueError):
    """A hardware.yaml that cannot be used; the message names the field and the reason."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class ServoJoint(_Strict):
    """One joint on a serial servo: joint value q (rad or m) -> ticks = zero + direction * gear * q *
    ticks_per_turn / 2π."""

    id: int = Field(ge=0, le=252, description="the servo's bus id (0..252)")
    zero: float = Field(description="the servo's position (ticks) when the joint is at 0 rad")
    direction: Literal[1, -1] = Field(1, description="+1: the servo turns with the joint; -1: against it")
    gear: float = Field(1.0, gt=0, description="servo turns per joint turn (1: direct drive)")
    kp: float | None = Field(None, gt=0, description="position gain for a physics preview (N·m/rad)")
    kd: float | None = Field(None, ge=0, description="damping for a physics preview (N·m·s/rad)")
    effort: float | None = Field(
        None, gt=0, description="the servo's stall torque (N·m), for a physics preview"
    )


def _one_joint_each(joints: dict[str, Any], field: str) -> None:
    """ValueError when two joints name the same servo (`field`: its `id`, or its PWM `channel`)."""
    seen: dict[int, str] = {}
    for name, joint in joints.items():
        value = getattr(joint, field)
        if value in seen:
            raise ValueError(f"joints {seen[value]} and {name} both use {field} {value}")
        seen[value] = name


class BusConfig(_Strict):
    """What every bus entry has: its `driver` (the bus kind) and its joints."""

    driver: Any = Field(description="the bus kind (each kind's model narrows it to its own word)")

    def raw_range(self) -> tuple[float, float]:
        """The goal positions the bus's servos accept (raw units)."""
        raise NotImplementedError

    def joint_map(self) -> dict[str, tuple[int, float, float]]:
        """joint -> (servo id or channel, offset, scale): raw = offset + scale * q."""
        raise NotImplementedError


class SerialBusConfig(BusConfig):
    """A serial bus of servos (TTL or RS-485 through a USB adapter)."""

    port: str = Field(description="the serial device, e.g. /dev/ttyUSB0")
    baudrate: int = Field(1_000_000, gt=0, description="bits per second (the servos' configured rate)")
    joints: dict[str, ServoJoint] = Field(min_length=1)

    @model_validator(mode="after")
    def _unique_ids(self) -> SerialBusConfig:
        _one_joint_each(self.joints, "id")
        return self

    def ticks_per_turn(self) -> float:
        return 4096.0

    def raw_range(self) -> tuple[float, float]:
        return 0.0, 4095.0

    def joint_map(self) -> dict[str, tuple[int, float, float]]:
        per_rad = self.ticks_per_turn() / (2 * math.pi)
        return {n: (j.id, j.zero, j.direction * j.gear * per_rad) for n, j in self.joints.items()}


class DynamixelBusConfig(SerialBusConfig):
    """Dynamixel X-series (and MX with Protocol 2.0 firmware) in position mode: 4096 ticks a turn."""

    driver: Literal["dynamixel"] = "dynamixel"
    protocol: Literal[2] = Field(2, description="Robotis protocol version (2.0 only)")


class FeetechBusConfig(SerialBusConfig):
    """Feetech STS (4096 ticks a turn, little-endian) or SCS (1024 ticks over 300°, big-endian)."""

    driver: Literal["feetech"] = "feetech"
    series: Literal["sts", "scs"] = Field("sts", description="sts: STS/SMS servos; scs: SCS servos")

    def ticks_per_turn(self) -> float:
        return 4096.0 if self.series == "sts" else 1024.0 * 360.0 / 300.0

    def raw_range(self) -> tuple[float, float]:
        return (0.0, 4095.0) if self.series == "sts" else (0.0, 1023.0)


class PwmJoint(_Strict):
    """One joint on a hobby servo: the pulse widths (µs) at two joint values (rad), linear between."""

    channel: int = Field(ge=0, le=15, description="the board's output (0..15)")
    pulse_us: dict[float, float] = Field(description="{angle (rad): pulse width (µs)} at two angles")

    @field_validator("pulse_us")
    @classmethod
    def _two_points(cls, value: dict[float, float]) -> dict[float, float]:
        if len(value) != 2:
            raise ValueError(f"give the pulse width at exactly two angles, got {len(value)}")
        (a0, u0), (a1, u1) = sorted(value.items())
        if not (math.isfinite(a0) and math.isfinite(a1) and math.isfinite(u0) and math.isfinite(u1)):
            raise ValueError("angles and pulse widths must be finite")
        if u0 == u1:
            raise ValueError("the two pulse widths are equal: the servo would not move")
        return value


class Pca9685BusConfig(BusConfig):
    """A PCA9685 16-channel PWM board on a Linux I2C bus (/dev/i2c-N)."""

    driver: Literal["pca9685"] = "pca9685"
    i2c_bus: int = Field(1, ge=0, description="the Linux I2C bus number (/dev/i2c-N)")
    address: int = Field(0x40, ge=0x03, le=0x77, description="the board's I2C address")
    frequency: float = Field(50.0, ge=24.0, le=1526.0, description="PWM frequency (Hz); hobby servos: 50")
    min_us: float = Field(500.0, gt=0, description="the shortest pulse any of its servos may get (µs)")
    max_us: float = Field(2500.0, gt=0, description="the longest pulse any of its servos may get (µs)")
    joints: dict[str, PwmJoint] = Field(min_length=1)

    @model_validator(mode="after")
    def _check(self) -> Pca9685BusConfig:
        if self.min_us >= self.max_us:
            raise ValueError(f"min_us ({self.min_us:g}) must be below max_us ({self.max_us:g})")
        if self.max_us >= 1e6 / self.frequency:
            raise ValueError(f"max_us {self.max_us:g} does not fit a {self.frequency:g} Hz period")
        _one_joint_each(self.joints, "channel")
        return self

    @property
    def port(self) -> str:
        return f"/dev/i2c-{self.i2c_bus} @ {self.address:#04x}"

    def raw_range(self) -> tuple[float, float]:
        return self.min_us, self.max_us

    def joint_map(self) -> dict[str, tuple[int, float, float]]:
        out = {}
        for name, joint in self.joints.items():
            (a0, u0), (a1, u1) = sorted(joint.pulse_us.items())
            scale = (u1 - u0) / (a1 - a0)
            out[name] = (joint.channel, u0 - scale * a0, scale)
        return out


class HardwareFile(_Strict):
    """A robot's hardware.yaml."""

    buses: list[dict[str, Any]] = Field(
        min_length=1, description="one entry per bus (its `driver` says which kind)"
    )
    torque_on_exit: bool = Field(False, description="keep torque on after parking at shutdown")
    read_hz: float = Field(50.0, ge=20.0, le=1000.0, description="how often present positions are read (Hz)")
    no_answer_ms: float = Field(
        100.0, ge=10.0, le=2000.0, description="a servo silent this long is a fault (ms)"
    )


class Hardware:
    """A checked hardware.yaml: the file's settings and each bus's config (its kind's model)."""

    def __init__(self, file: HardwareFile, buses: list[BusConfig], path: Path | None = None):
        self.file, self.buses, self.path = file, buses, path

    @property
    def torque_on_exit(self) -> bool:
        return self.file.torque_on_exit


def _where(loc: tuple[Any, ...]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _first_error(exc: ValidationError, prefix: str) -> str:
    err = exc.errors()[0]
    where = _where((*(p for p in (prefix,) if p), *err["loc"]))
    msg = err["msg"].removeprefix("Value error, ")
    return f"{where}: {msg}" if where else msg


def parse_hardware(data: Any, path: Path | None = None) -> Hardware:
    """Validate hardware.yaml's data (no robot check): HardwareConfigError naming the first bad field."""
    from backend.hardware.registry import BUSES  # lazy: the registry imports every bus kind's SDK

    try:
        file = HardwareFile.model_validate(data)
    except ValidationError as exc:
        raise HardwareConfigError(_first_error(exc, "")) from None
    buses: list[BusConfig] = []
    for i, entry in enumerate(file.buses):
        kind = entry.get("driver")
        if kind not in BUSES:
            known = ", ".join(sorted(BUSES))
            raise HardwareConfigError(f"buses[{i}].driver: unknown bus driver {kind!r} (known: {known})")
        try:
            buses.append(BUSES[kind].config_model.model_validate(entry))
        except ValidationError as exc:
            raise HardwareConfigError(_first_error(exc, f"buses[{i}]")) from None
    return Hardware(file, buses, path)


def raw_unit(bus: BusConfig) -> str:
    """The name of a bus's raw units, for messages: `ticks`, `µs`."""
    from backend.hardware.registry import BUSES  # lazy: the registry imports every bus kind's module

    kind = BUSES.get(bus.driver)
    return kind.raw_unit if kind is not None else "raw units"


def check_against(hardware: Hardware, emb: Embodiment) -> None:
    """Every configured joint is an actuated joint of the robot, configured once, and its servo reaches
    its whole URDF range; HardwareConfigError otherwise."""
    joints = set(emb.joint_names)
    owner: dict[str, str] = {}
    for i, bus in enumerate(hardware.buses):
        for name in bus.joint_map():
            where = f"buses[{i}].joints.{name}"
            if name not in joints:
                known = ", ".join(emb.joint_names)
                raise HardwareConfigError(
                    f"{where}: {emb.name} has no actuated joint {name!r} (it has: {known})"
                )
            if name in owner:
                raise HardwareConfigError(f"{where}: the joint is already configured at {owner[name]}")
            owner[name] = where
        jmap = JointMap(bus, emb)
        lo, hi = jmap.urdf_span()
        beyond = np.flatnonzero((lo < jmap.raw_lo - 1e-9) | (hi > jmap.raw_hi + 1e-9))
        if beyond.size:
            k = int(beyond[0])
            raise HardwareConfigError(
                f"buses[{i}].joints.{jmap.names[k]}: the joint's URDF range [{jmap.lower[k]:g}, "
                f"{jmap.upper[k]:g}] needs {raw_unit(bus)} [{lo[k]:.0f}, {hi[k]:.0f}], beyond what the servo "
                f"accepts [{jmap.raw_lo:g}, {jmap.raw_hi:g}]: check zero, direction and gear"
            )


def load_hardware(path: str | Path, emb: Embodiment) -> Hardware:
    """Read, validate and check `path` against the robot; HardwareConfigError saying what is wrong."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise HardwareConfigError(f"cannot read {path}: {exc.strerror or exc}") from None
    except yaml.YAMLError as exc:
        raise HardwareConfigError(f"{path} is not valid YAML: {exc}") from None
    hardware = parse_hardware(data, path)
    check_against(hardware, emb)
    return hardware
