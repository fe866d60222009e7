"""A bus of DYNAMIXEL X-series servos speaking Robotis Protocol 2.0, emulated on a pseudo-terminal.

Written from the published ROBOTIS e-Manual, "DYNAMIXEL Protocol 2.0"
(https://emanual.robotis.com/docs/en/dxl/protocol2/) and the X-series control tables (the XL430-W250
and XM430-W350 pages), not from any SDK: packets are `FF FF FD 00 | id | length (LE16) | instruction |
parameters | CRC (LE16)`; the length counts instruction, parameters (after byte stuffing) and CRC; the
instruction and parameters are byte-stuffed (`FF FF FD` -> `FF FF FD FD`); the CRC-16 (polynomial
0x8005, initial value 0, not reflected) covers every byte from the header to the last parameter as
sent. Status packets carry instruction 0x55 and an error byte: bit 7 (Alert) is set while the Hardware
Error Status (70) is non-zero; bits 0..6 hold the result fault code of the instruction.

Each emulated servo has a control table (a bytearray) and a simple motor: with torque on, its present
position moves toward the goal at most `speed` ticks/s (wall time); with torque off it stays where it
is (tests may push it: `set_position`). Fault injection: `missing` ids, `corrupt_replies`, `silence`,
`set_fault`. Counters: `counts` (instruction packets seen, by name), `bad_packets`, `replies`.
"""

from __future__ import annotations

import threading
import time
from collections import Counter
from collections.abc import Iterable, Mapping

from backend.hardware.emulator.pty_port import OnPty, PtyPort

HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE
STATUS = 0x55
PING, READ, WRITE, REBOOT, SYNC_READ, SYNC_WRITE = 0x01, 0x02, 0x03, 0x08, 0x82, 0x83
INSTRUCTION_NAMES = {
    PING: "ping",
    READ: "read",
    WRITE: "write",
    REBOOT: "reboot",
    SYNC_READ: "sync_read",
    SYNC_WRITE: "sync_write",
}
#: Status error byte: the result fault codes (bits 0..6) and the Alert bit.
(
    RESULT_FAIL,
    INSTRUCTION_ERROR,
    CRC_ERROR,
    DATA_RANGE_ERROR,
    DATA_LENGTH_ERROR,
    DATA_LIMIT_ERROR,
    ACCESS_ERROR,
) = range(1, 8)
ALERT = 0x80

# X-series control table addresses (bytes); multi-byte values are little-endian.
MODEL_NUMBER, FIRMWARE_VERSION, ID, BAUD_RATE, RETURN_DELAY, OPERATING_MODE = 0, 6, 7, 8, 9, 11
CURRENT_LIMIT, MAX_POSITION, MIN_POSITION, SHUTDOWN = 38, 48, 52, 63
TORQUE_ENABLE, HARDWARE_ERROR, GOAL_POSITION, MOVING = 64, 70, 116, 122
PRESENT_LOAD, PRESENT_VELOCITY, PRESENT_POSITION, PRESENT_VOLTAGE, PRESENT_TEMPERATURE = (
    126,
    128,
    132,
    144,
    146,
)
TABLE_SIZE = 256
POSITION_MODE, EXTENDED_POSITION_MODE = 3, 4
# Writable bytes: EEPROM (only while torque is off) and RAM; everything else is read-only.
_EEPROM_WRITABLE = frozenset([*range(7, 14), *range(20, 28), *range(31, 40), *range(44, 56), 63])
_RAM_WRITABLE = frozenset([64, 65, 68, *range(76, 92), 98, *range(100, 120)])

#: Hardware Error Status (70) bits, by fault word.
HARDWARE_ERROR_BITS = {"voltage": 0, "overheat": 2, "encoder": 3, "electrical": 4, "overload": 5}

#: model number -> (name, Current Limit default in the model's current units, or 0 when address 126 is
#: Present Load in 0.1 % rather than Present Current).
MODELS: dict[int, tuple[str, int]] = {
    1060: ("XL430-W250", 0),
    1090: ("2XL430-W250", 0),
    1070: ("XC430-W150", 0),
    1080: ("XC430-W240", 0),
    1020: ("XM430-W350", 1193),
    1030: ("XM430-W210", 1193),
    1120: ("XM540-W270", 2047),
    1130: ("XM540-W150", 2047),
    1010: ("XH430-W350", 648),
    1000: ("XH430-W210", 648),
}
_MODEL_BY_NAME = {name: number for number, (name, _) in MODELS.items()}


def crc16(data: bytes | bytearray) -> int:
    """The Protocol 2.0 CRC-16 (polynomial 0x8005, initial value 0, MSB first) of `data`."""
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
        crc &= 0xFFFF
    return crc


def stuff(body: bytes | bytearray) -> bytes:
    """Byte stuffing of an instruction/status body (instruction byte onward): FF FF FD -> FF FF FD FD."""
    out = bytearray()
    for byte in body:
        out.append(byte)
        # an inserted FD is preceded by FF FD, never FF FF, so it never triggers another insertion
        if byte == 0xFD and out[-3:-1] == b"\xff\xff":
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes | bytearray) -> bytes:
    """Remove byte stuffing from a received body: FF FF FD FD -> FF FF FD."""
    out = bytearray()
    i = 0
    while i < len(body):
        out.append(body[i])
        stuffed = body[i] == 0xFD and out[-3:-1] == b"\xff\xff" and i + 1 < len(body) and body[i + 1] == 0xFD
        i += 2 if stuffed else 1
    return bytes(out)


def packet(dxl_id: int, instruction: int, params: bytes | bytearray = b"") -> bytes:
    """A complete Protocol 2.0 packet (instruction or status): header, id, length, stuffed body, CRC."""
    body = stuff(bytes([instruction]) + bytes(params))
    head = HEADER + bytes([dxl_id]) + (len(body) + 2).to_bytes(2, "little") + body
    return head + crc16(head).to_bytes(2, "little")


class _Servo:
    """One servo's control table and motor state (guarded by the emulator's lock)."""

    def __init__(self, dxl_id: int, model: int, firmware: int):
        self.table = bytearray(TABLE_SIZE)
        self.put(MODEL_NUMBER, 2, model)
        self.table[FIRMWARE_VERSION] = firmware
        self.table[ID] = dxl_id
        self.table[BAUD_RATE] = 3  # 1 Mbps
        self.table[RETURN_DELAY] = 250  # 2 µs units: 500 µs
        self.table[OPERATING_MODE] = POSITION_MODE
        self.put(CURRENT_LIMIT, 2, MODELS.get(model, ("", 0))[1])
        self.put(MAX_POSITION, 4, 4095)
        self.put(MIN_POSITION, 4, 0)
        self.table[SHUTDOWN] = 0x34  # overheat, electrical shock, overload (the e-Manual's default)
        self.put(PRESENT_POSITION, 4, 2048)
        self.put(GOAL_POSITION, 4, 2048)
        self.put(PRESENT_VOLTAGE, 2, 120)  # 0.1 V units: 12.0 V
        self.table[PRESENT_TEMPERATURE] = 30  # °C
        self.position = 2048.0  # ticks, fractional between updates
        self.updated = time.monotonic()

    def get(self, addr: int, size: int, signed: bool = True) -> int:
        return int.from_bytes(self.table[addr : addr + size], "little", signed=signed)

    def put(self, addr: int, size: int, value: int) -> None:
        self.table[addr : addr + size] = int(value).to_bytes(size, "little", signed=value < 0)

    def advance(self, speed: float) -> None:
        """Move the present position toward the goal for the wall time elapsed (speed: ticks/s)."""
        now = time.monotonic()
        dt, self.updated = now - self.updated, now
        goal = self.get(GOAL_POSITION, 4)
        if self.table[TORQUE_ENABLE] and self.position != goal:
            step = max(-speed * dt, min(speed * dt, goal - self.position))
            self.position += step
            velocity = step / dt if dt > 0 else 0.0
        else:
            velocity = 0.0
        self.put(PRESENT_POSITION, 4, round(self.position))
        # Present Velocity unit: 0.229 rpm; 4096 ticks a turn
        self.put(PRESENT_VELOCITY, 4, round(velocity * 60.0 / 4096.0 / 0.229))
        self.table[MOVING] = int(velocity != 0.0)


class DynamixelEmulator(OnPty):
    """DYNAMIXEL X-series servos on one Protocol 2.0 bus, answering on a pty (`path`).

    servos: id -> model number (e.g. 1020) or name (`XM430-W350`); an unknown number is emulated as a
    generic X-series servo reporting that number. speed: the fastest the motor turns (ticks/s).
    missing: ids that never answer (editable set). Use as a context manager, or `start()`/`close()`.
    """

    def __init__(
        self,
        servos: Mapping[int, int | str],
        *,
        speed: float = 4096.0 * 2,
        missing: Iterable[int] = (),
        firmware: int = 52,
        name: str = "dynamixel",
    ):
        if speed <= 0:
            raise ValueError(f"speed must be positive (ticks/s), got {speed}")
        self.speed = float(speed)
        self._lock = threading.RLock()
        self._servos: dict[int, _Servo] = {}
        for dxl_id, model in servos.items():
            if not 0 <= dxl_id <= 252:
                raise ValueError(f"servos: id {dxl_id} is outside 0..252")
            if isinstance(model, str):
                if model not in _MODEL_BY_NAME:
                    raise ValueError(
                        f"servos[{dxl_id}]: unknown model {model!r} (known: {', '.join(_MODEL_BY_NAME)})"
                    )
                model = _MODEL_BY_NAME[model]
            self._servos[dxl_id] = _Servo(dxl_id, model, firmware)
        self.missing: set[int] = set(missing)
        self.counts: Counter[str] = Counter()
        self.bad_packets = 0
        self.replies = 0
        self._silent_until: dict[int, float] = {}
        self._corrupt: Counter[int | None] = Counter()
        self._buf = bytearray()
        self._last_rx = 0.0
        self._port = PtyPort(self._on_bytes, name)

    # -- servo state (thread-safe) -----------------------------------------------------------------
    def _servo(self, dxl_id: int) -> _Servo:
        if dxl_id not in self._servos:
            raise KeyError(f"no emulated servo with id {dxl_id}")
        servo = self._servos[dxl_id]
        servo.advance(self.speed)
        return servo

    def position(self, dxl_id: int) -> int:
        """Present position (ticks)."""
        with self._lock:
            return self._servo(dxl_id).get(PRESENT_POSITION, 4)

    def goal(self, dxl_id: int) -> int:
        """Goal position (ticks)."""
        with self._lock:
            return self._servo(dxl_id).get(GOAL_POSITION, 4)

    def torque(self, dxl_id: int) -> bool:
        with self._lock:
            return bool(self._servo(dxl_id).table[TORQUE_ENABLE])

    def hardware_error(self, dxl_id: int) -> int:
        """The Hardware Error Status byte (70)."""
        with self._lock:
            return self._servo(dxl_id).table[HARDWARE_ERROR]

    def state(self, dxl_id: int) -> dict[str, int]:
        """A snapshot: position and goal (ticks), torque (0/1), temperature (°C), load (raw, 126) and
        hardware_error (the byte at 70)."""
        with self._lock:
            servo = self._servo(dxl_id)
            return {
                "position": servo.get(PRESENT_POSITION, 4),
                "goal": servo.get(GOAL_POSITION, 4),
                "torque": servo.table[TORQUE_ENABLE],
                "temperature": servo.table[PRESENT_TEMPERATURE],
                "load": servo.get(PRESENT_LOAD, 2),
                "hardware_error": servo.table[HARDWARE_ERROR],
            }

    def set_position(self, dxl_id: int, ticks: int) -> None:
        """Push the shaft to `ticks` (e.g. by hand, torque off); with torque on it heads back to its goal."""
        with self._lock:
            servo = self._servo(dxl_id)
            servo.position = float(ticks)
            servo.put(PRESENT_POSITION, 4, int(ticks))

    def set_load(self, dxl_id: int, fraction: float) -> None:
        """Set the reported load as a fraction of the maximum (-1..1): 0.1 % units, or for current-sensing
        models the matching share of the Current Limit (38)."""
        with self._lock:
            servo = self._servo(dxl_id)
            limit = servo.get(CURRENT_LIMIT, 2, signed=False)
            servo.put(PRESENT_LOAD, 2, round(fraction * (limit or 1000)))

    def set_temperature(self, dxl_id: int, celsius: int) -> None:
        with self._lock:
            self._servo(dxl_id).table[PRESENT_TEMPERATURE] = int(celsius)

    def read_table(self, dxl_id: int, addr: int, size: int) -> bytes:
        with self._lock:
            return bytes(self._servo(dxl_id).table[addr : addr + size])

    def write_table(self, dxl_id: int, addr: int, data: bytes) -> None:
        """Write control table bytes directly (no access checks): e.g. position limits for a test."""
        with self._lock:
            servo = self._servo(dxl_id)
            servo.table[addr : addr + len(data)] = data
            if addr <= PRESENT_POSITION < addr + len(data):
                servo.position = float(servo.get(PRESENT_POSITION, 4))

    # -- fault injection ---------------------------------------------------------------------------
    def set_fault(self, dxl_id: int, fault: str) -> None:
        """Raise a hardware error (`overload`, `overheat`, `voltage`, `encoder`, `electrical`): sets its
        Hardware Error Status bit (Alert on every status until REBOOT) and, when the Shutdown byte (63)
        selects it, turns torque off."""
        if fault not in HARDWARE_ERROR_BITS:
            raise ValueError(f"fault must be one of {', '.join(HARDWARE_ERROR_BITS)}, got {fault!r}")
        bit = 1 << HARDWARE_ERROR_BITS[fault]
        with self._lock:
            servo = self._servo(dxl_id)
            servo.table[HARDWARE_ERROR] |= bit
            if servo.table[SHUTDOWN] & bit:
                servo.table[TORQUE_ENABLE] = 0

    def corrupt_replies(self, dxl_id: int | None, n: int = 1) -> None:
        """Send the next `n` status packets of `dxl_id` (None: of any servo) with a wrong CRC."""
        with self._lock:
            self._corrupt[dxl_id] += n

    def silence(self, dxl_id: int, seconds: float) -> None:
        """Make `dxl_id` ignore the bus (no reply, no action) for `seconds` of wall time."""
        with self._lock:
            self._silent_until[dxl_id] = time.monotonic() + seconds

    def _present(self, dxl_id: int) -> bool:
        return (
            dxl_id in self._servos
            and dxl_id not in self.missing
            and time.monotonic() >= self._silent_until.get(dxl_id, 0.0)
        )

    # -- the wire ----------------------------------------------------------------------------------
    def _on_bytes(self, data: bytes) -> None:
        replies: list[bytes] = []
        with self._lock:
            now = time.monotonic()
            if self._buf and now - self._last_rx > 0.05:
                # a packet left incomplete this long was cut off: servos drop it after a receive timeout
                self.bad_packets += 1
                self._buf.clear()
            self._last_rx = now
            self._buf += data
            while (found := self._take_packet()) is not None:
                replies += found
        for reply in replies:
            self._port.send(reply)

    def _take_packet(self) -> list[bytes] | None:
        """Parse one packet off the receive buffer and handle it; None when no complete packet is left."""
        buf = self._buf
        start = buf.find(HEADER)
        if start < 0:
            del buf[: max(0, len(buf) - 3)]  # keep what may be the start of a header
            return None
        del buf[:start]
        if len(buf) < 7:
            return None
        length = int.from_bytes(buf[5:7], "little")
        if length < 3:
            self.bad_packets += 1
            del buf[:1]
            return []
        total = 7 + length
        if len(buf) < total:
            return None
        raw = bytes(buf[:total])
        del buf[:total]
        dxl_id = raw[4]
        if crc16(raw[:-2]) != int.from_bytes(raw[-2:], "little"):
            self.bad_packets += 1
            return [self._status(dxl_id, CRC_ERROR)] if self._present(dxl_id) else []
        body = unstuff(raw[7:-2])
        return self._handle(dxl_id, body[0], body[1:])

    def _status(self, dxl_id: int, error: int = 0, params: bytes = b"") -> bytes:
        if self._servos[dxl_id].table[HARDWARE_ERROR]:
            error |= ALERT
        reply = packet(dxl_id, STATUS, bytes([error]) + params)
        self.replies += 1
        key = dxl_id if self._corrupt[dxl_id] > 0 else (None if self._corrupt[None] > 0 else -1)
        if key != -1:
            self._corrupt[key] -= 1
            reply = reply[:-2] + (int.from_bytes(reply[-2:], "little") ^ 0xFFFF).to_bytes(2, "little")
        return reply

    def _handle(self, dxl_id: int, inst: int, params: bytes) -> list[bytes]:
        self.counts[INSTRUCTION_NAMES.get(inst, f"0x{inst:02x}")] += 1
        if inst == PING:
            ids = sorted(self._servos) if dxl_id == BROADCAST_ID else [dxl_id]
            return [self._ping(i) for i in ids if self._present(i)]
        if inst in (SYNC_READ, SYNC_WRITE):
            return self._sync(inst, params) if dxl_id == BROADCAST_ID else []
        targets = sorted(self._servos) if dxl_id == BROADCAST_ID else [dxl_id]
        replies = []
        for target in (t for t in targets if self._present(t)):
            servo = self._servo(target)
            if inst == READ:
                error, data = self._read(servo, params)
            elif inst == WRITE:
                error, data = self._write(servo, params), b""
            elif inst == REBOOT:
                error, data = 0, b""
            else:
                error, data = INSTRUCTION_ERROR, b""
            if dxl_id != BROADCAST_ID:
                replies.append(self._status(target, error, data))
            if inst == REBOOT:
                self._reboot(servo)
        return replies

    def _ping(self, dxl_id: int) -> bytes:
        table = self._servo(dxl_id).table
        return self._status(
            dxl_id, 0, bytes(table[MODEL_NUMBER : MODEL_NUMBER + 2]) + bytes([table[FIRMWARE_VERSION]])
        )

    def _sync(self, inst: int, params: bytes) -> list[bytes]:
        if len(params) < 4:
            return []
        addr, size = int.from_bytes(params[0:2], "little"), int.from_bytes(params[2:4], "little")
        rest = params[4:]
        if inst == SYNC_READ:
            request = addr.to_bytes(2, "little") + size.to_bytes(2, "little")
            replies = []
            for dxl_id in rest:  # each listed servo answers in turn, in the order listed
                if self._present(dxl_id):
                    error, data = self._read(self._servo(dxl_id), request)
                    replies.append(self._status(dxl_id, error, data))
            return replies
        if size == 0 or len(rest) % (1 + size):
            return []  # a malformed SYNC WRITE is ignored: it has no status packet to report through
        for i in range(0, len(rest), 1 + size):
            dxl_id = rest[i]
            if self._present(dxl_id):
                self._write(self._servo(dxl_id), addr.to_bytes(2, "little") + rest[i + 1 : i + 1 + size])
        return []

    def _read(self, servo: _Servo, params: bytes) -> tuple[int, bytes]:
        if len(params) != 4:
            return DATA_LENGTH_ERROR, b""
        addr, size = int.from_bytes(params[0:2], "little"), int.from_bytes(params[2:4], "little")
        if addr + size > TABLE_SIZE:
            return ACCESS_ERROR, b""
        return 0, bytes(servo.table[addr : addr + size])

    def _write(self, servo: _Servo, params: bytes) -> int:
        """Apply a WRITE's parameters (address LE16 + data); the status error code."""
        if len(params) < 3:
            return DATA_LENGTH_ERROR
        addr, data = int.from_bytes(params[0:2], "little"), params[2:]
        span = range(addr, addr + len(data))
        torque_on = bool(servo.table[TORQUE_ENABLE])
        for a in span:
            if a not in _RAM_WRITABLE and (a not in _EEPROM_WRITABLE or torque_on):
                return ACCESS_ERROR
        if TORQUE_ENABLE in span:
            value = data[TORQUE_ENABLE - addr]
            if value > 1:
                return DATA_RANGE_ERROR
            if value and servo.table[HARDWARE_ERROR] & servo.table[SHUTDOWN]:
                return RESULT_FAIL  # after a shutdown only REBOOT brings torque back
        if addr <= GOAL_POSITION and addr + len(data) >= GOAL_POSITION + 4:
            goal = int.from_bytes(
                data[GOAL_POSITION - addr : GOAL_POSITION - addr + 4], "little", signed=True
            )
            if servo.table[OPERATING_MODE] == POSITION_MODE and not (
                servo.get(MIN_POSITION, 4) <= goal <= servo.get(MAX_POSITION, 4)
            ):
                return DATA_LIMIT_ERROR
        servo.table[addr : addr + len(data)] = data
        return 0

    def _reboot(self, servo: _Servo) -> None:
        servo.table[HARDWARE_ERROR] = 0
        servo.table[TORQUE_ENABLE] = 0
        servo.put(GOAL_POSITION, 4, servo.get(PRESENT_POSITION, 4))
