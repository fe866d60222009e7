"""An emulated bus of Feetech STS/SCS serial servos on a pseudo-terminal.

Written from FEETECH's published "SCS/STS series communication protocol" manual and the STS memory
table, not from the vendor SDK: an instruction packet is `FF FF id length instruction params checksum`
with length = len(params) + 2 and checksum = ~(id + length + instruction + sum(params)) & 0xFF; no byte
stuffing. A servo answers `FF FF id length error params checksum` (length = len(params) + 2). Broadcast
id 0xFE: every servo acts, none answers (except SYNC READ, where the listed servos answer in turn).
Instructions: PING 0x01, READ 0x02, WRITE 0x03, REG WRITE 0x04, ACTION 0x05, SYNC READ 0x82, SYNC WRITE
0x83. Words are 16-bit: little-endian on STS (4096 ticks a turn), big-endian on SCS (0..1023 over 300°).
Signed words (present position, speed) are sign-magnitude with bit 15 as the sign; the load's
direction is bit 10. The status error byte: bit 0 voltage, 1 sensor (encoder), 2 temperature, 3 current
(electrical), 5 overload; an overload, overheat or over-current unloads the servo (torque off).

`nutty hardware emulate` runs one; tests drive the real SDK against it.
"""

from __future__ import annotations

import threading
import time
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

from backend.hardware.emulator.pty_port import OnPty, PtyPort

HEADER = b"\xff\xff"
BROADCAST = 0xFE
INSTRUCTIONS = {
    0x01: "ping",
    0x02: "read",
    0x03: "write",
    0x04: "reg_write",
    0x05: "action",
    0x82: "sync_read",
    0x83: "sync_write",
}

# The memory table's addresses (bytes; 2-byte words start at the given address).
MODEL, ID, BAUD, RETURN_DELAY, RESPONSE_LEVEL, MIN_ANGLE, MAX_ANGLE = 3, 5, 6, 7, 8, 9, 11
TORQUE_ENABLE, ACCELERATION, GOAL_POSITION, GOAL_TIME, GOAL_SPEED = 40, 41, 42, 44, 46
PRESENT_POSITION, PRESENT_SPEED, PRESENT_LOAD, PRESENT_VOLTAGE, PRESENT_TEMPERATURE = 56, 58, 60, 62, 63
STATUS, MOVING, PRESENT_CURRENT = 65, 66, 69
LOCK = {"sts": 55, "scs": 48}
# The servo's own measurements and identity: writes there are ignored, as on the real servo.
READ_ONLY = frozenset({3, 4, *range(PRESENT_POSITION, PRESENT_CURRENT + 2)})
MEMORY_SIZE = 128

ERROR_BITS = {"voltage": 0x01, "encoder": 0x02, "overheat": 0x04, "electrical": 0x08, "overload": 0x20}
#: Faults after which the servo unloads (turns its torque off) until the fault clears.
SHUTDOWN_FAULTS = frozenset({"overload", "overheat", "electrical"})

#: model name -> (model number at address 3, series).
MODELS = {
    "STS3215": (777, "sts"),
    "STS3250": (2825, "sts"),
    "STS3095": (2569, "sts"),
    "SM8512BL": (11272, "sts"),
    "SCS0009": (1284, "scs"),
}
Series = Literal["sts", "scs"]


def checksum(body: bytes | bytearray) -> int:
    """The protocol's checksum of everything between the header and the checksum byte."""
    return ~sum(body) & 0xFF


def _word(value: int, series: str, signed: bool = False) -> bytes:
    """A 16-bit word in the series' byte order; signed values as sign-magnitude (bit 15)."""
    raw = (0x8000 | min(-value, 0x7FFF)) if signed and value < 0 else min(max(value, 0), 0xFFFF)
    lo, hi = raw & 0xFF, raw >> 8
    return bytes((lo, hi)) if series == "sts" else bytes((hi, lo))


def _unword(data: bytes | bytearray, series: str, signed: bool = False) -> int:
    raw = data[0] | data[1] << 8 if series == "sts" else data[1] | data[0] << 8
    return -(raw & 0x7FFF) if signed and raw & 0x8000 else raw


@dataclass(frozen=True)
class ServoState:
    """A snapshot of one emulated servo. position/goal: ticks; speed: ticks/s; load: -1..1 of its
    maximum torque; temperature: °C; voltage: V; error: the status error byte."""

    id: int
    model: int
    position: float
    goal: int
    torque: bool
    speed: float
    load: float
    temperature: int
    voltage: float
    error: int


class _Servo:
    """One servo: its memory table plus the motor model's continuous state."""

    def __init__(self, sid: int, model: int, series: str, position: float, speed: float):
        self.series, self.speed_limit = series, speed
        self.mem = bytearray(MEMORY_SIZE)
        self.position, self.speed, self.load = float(position), 0.0, 0.0
        self.error, self.corrupt, self.silent_until = 0, 0, 0.0
        self.registered: tuple[int, bytes] | None = None
        self.last = time.monotonic()
        top = 4095 if series == "sts" else 1023
        self.mem[MODEL : MODEL + 2] = _word(model, series)
        self.mem[ID], self.mem[RESPONSE_LEVEL] = sid, 1
        self.mem[MIN_ANGLE : MIN_ANGLE + 2] = _word(0, series)
        self.mem[MAX_ANGLE : MAX_ANGLE + 2] = _word(top, series)
        self.mem[GOAL_POSITION : GOAL_POSITION + 2] = _word(round(position), series, signed=True)
        self.mem[PRESENT_VOLTAGE], self.mem[PRESENT_TEMPERATURE] = 74, 30

    def word(self, address: int, signed: bool = False) -> int:
        return _unword(self.mem[address : address + 2], self.series, signed)

    def advance(self, now: float) -> None:
        """Move toward the goal (at most `speed_limit` ticks/s, within the angle limits) since the last
        call, and refresh the present-value registers."""
        dt, self.last = max(now - self.last, 0.0), now
        if self.mem[TORQUE_ENABLE]:
            lo, hi = self.word(MIN_ANGLE), self.word(MAX_ANGLE)
            goal = self.word(GOAL_POSITION, signed=True)
            goal = min(max(goal, lo), hi) if hi > lo else goal  # both 0: multi-turn, no limit
            step = min(max(goal - self.position, -self.speed_limit * dt), self.speed_limit * dt)
            self.position += step
            self.speed = step / dt if dt > 0 else 0.0
        else:
            self.speed = 0.0
        self.mem[PRESENT_POSITION : PRESENT_POSITION + 2] = _word(round(self.position), self.series, True)
        self.mem[PRESENT_SPEED : PRESENT_SPEED + 2] = _word(round(self.speed), self.series, True)
        load = min(round(abs(self.load) * 1000), 1000) | (0x400 if self.load < 0 else 0)
        self.mem[PRESENT_LOAD : PRESENT_LOAD + 2] = _word(load, self.series)
        self.mem[STATUS], self.mem[MOVING] = self.error, int(abs(self.speed) > 0.5)

    def write(self, address: int, data: bytes) -> int | None:
        """Store `data` from `address`; return the new id if the id was written."""
        new_id = None
        for i, byte in enumerate(data):
            at = address + i
            if at >= MEMORY_SIZE or at in READ_ONLY:
                continue
            if at == ID:
                new_id = byte
            self.mem[at] = byte
        shutdown = any(self.error & ERROR_BITS[f] for f in SHUTDOWN_FAULTS)
        if shutdown:  # an unloaded servo refuses torque until its fault clears
            self.mem[TORQUE_ENABLE] = 0
        return new_id


class FeetechEmulator(OnPty):
    """Feetech servos answering on a pty (`path`), from `servos`: id -> model number or name (e.g.
    `{1: "STS3215", 2: 777}`). All servos share `series` ("sts" or "scs"); `speed` is the motor model's
    top speed (ticks/s; default two turns a second); `position` where they all start (ticks; default
    mid-range). Fault injection: `missing` (a set of ids that neither obey nor answer; change it at any
    time), `corrupt_replies`, `silence`, `set_fault`. `counters` counts packets per instruction and
    `bad_packets` the ones dropped (a bad checksum, a malformed or unfinished packet)."""

    #: a packet whose bytes stop coming for this long is dropped (s), as a servo's receiver resets.
    packet_gap = 0.01

    def __init__(
        self,
        servos: dict[int, int | str],
        series: Series = "sts",
        speed: float | None = None,
        missing: Iterable[int] = (),
        position: float | None = None,
    ):
        if series not in ("sts", "scs"):
            raise ValueError(f"series must be 'sts' or 'scs', not {series!r}")
        self.series: Series = series
        self.speed = float(speed if speed is not None else (8192.0 if series == "sts" else 2048.0))
        start = position if position is not None else (2048.0 if series == "sts" else 512.0)
        self._servos: dict[int, _Servo] = {}
        for sid, model in servos.items():
            if not 0 <= sid <= 252:
                raise ValueError(f"servos: id {sid} is outside 0..252")
            self._servos[sid] = _Servo(sid, self._model_number(model), series, start, self.speed)
        self.missing: set[int] = set(missing)
        self._counters: Counter[str] = Counter()
        self._bad_packets = 0
        self._corrupt_any = 0
        self._lock = threading.RLock()
        self._buf = bytearray()
        self._last_rx = 0.0
        self._port = PtyPort(self._on_bytes, name=f"feetech-{series}")

    def _model_number(self, model: int | str) -> int:
        if isinstance(model, int):
            return model
        if model.upper() not in MODELS:
            raise ValueError(f"servos: unknown model {model!r} (known: {', '.join(MODELS)})")
        number, series = MODELS[model.upper()]
        if series != self.series:
            raise ValueError(f"servos: {model} is an {series.upper()} servo, not {self.series.upper()}")
        return number

    # -- inspection and fault injection (thread-safe) ------------------------------------------------
    @property
    def ids(self) -> list[int]:
        with self._lock:
            return sorted(self._servos)

    def _servo(self, sid: int) -> _Servo:
        if sid not in self._servos:
            raise ValueError(f"no emulated servo with id {sid} (ids: {sorted(self._servos)})")
        return self._servos[sid]

    def state(self, sid: int) -> ServoState:
        """Servo `sid`'s present state (its motion brought up to now)."""
        with self._lock:
            s = self._servo(sid)
            s.advance(time.monotonic())
            return ServoState(
                id=sid,
                model=s.word(MODEL),
                position=s.position,
                goal=s.word(GOAL_POSITION, signed=True),
                torque=bool(s.mem[TORQUE_ENABLE]),
                speed=s.speed,
                load=s.load,
                temperature=s.mem[PRESENT_TEMPERATURE],
                voltage=s.mem[PRESENT_VOLTAGE] / 10.0,
                error=s.error,
            )

    def set_position(self, sid: int, ticks: float) -> None:
        """Put servo `sid` at `ticks` (pushed by hand; with torque on it then returns to its goal)."""
        with self._lock:
            s = self._servo(sid)
            s.advance(time.monotonic())
            s.position = float(ticks)
            s.advance(time.monotonic())

    def set_load(self, sid: int, fraction: float) -> None:
        """The load servo `sid` reports: -1..1 of its maximum torque (the sign is the direction)."""
        with self._lock:
            self._servo(sid).load = max(-1.0, min(1.0, float(fraction)))

    def set_temperature(self, sid: int, celsius: int) -> None:
        with self._lock:
            self._servo(sid).mem[PRESENT_TEMPERATURE] = max(0, min(255, int(celsius)))

    def set_fault(self, sid: int, fault: str | None) -> None:
        """Raise `fault` (one of ERROR_BITS: overload, overheat, voltage, encoder, electrical) on servo
        `sid`, or clear its faults with None. A shutdown fault turns its torque off, as the servo does."""
        if fault is not None and fault not in ERROR_BITS:
            raise ValueError(f"fault must be one of {', '.join(ERROR_BITS)} or None, not {fault!r}")
        with self._lock:
            s = self._servo(sid)
            s.advance(time.monotonic())
            s.error = 0 if fault is None else s.error | ERROR_BITS[fault]
            if fault in SHUTDOWN_FAULTS:
                s.mem[TORQUE_ENABLE] = 0
            s.advance(time.monotonic())

    def corrupt_replies(self, sid: int | None, n: int = 1) -> None:
        """Give the next `n` replies of servo `sid` (None: of any servo) a wrong checksum."""
        with self._lock:
            if sid is None:
                self._corrupt_any += n
            else:
                self._servo(sid).corrupt += n

    def silence(self, sid: int, seconds: float) -> None:
        """Servo `sid` answers nothing for `seconds` (it still obeys what it hears)."""
        with self._lock:
            self._servo(sid).silent_until = time.monotonic() + seconds

    @property
    def counters(self) -> Counter[str]:
        """A copy of the packets seen so far, per instruction name (`sync_write`, `read`...)."""
        with self._lock:
            return Counter(self._counters)

    @property
    def bad_packets(self) -> int:
        """Packets dropped: a bad checksum, a malformed or unfinished packet."""
        with self._lock:
            return self._bad_packets

    def reset_counters(self) -> None:
        with self._lock:
            self._counters.clear()
            self._bad_packets = 0

    # -- the protocol --------------------------------------------------------------------------------
    def _on_bytes(self, data: bytes) -> None:
        with self._lock:
            now = time.monotonic()
            if self._buf and now - self._last_rx > self.packet_gap:
                self._bad_packets += 1  # an unfinished packet: the sender gave up on it
                self._buf.clear()
            self._last_rx = now
            self._buf += data
            replies = []
            while (packet := self._next_packet()) is not None:
                replies.append(self._handle(*packet))
            out = b"".join(replies)
        if out:
            self._port.send(out)

    def _next_packet(self) -> tuple[int, int, bytes] | None:
        """The next complete, well-formed packet in the buffer as (id, instruction, params)."""
        buf = self._buf
        while True:
            start = buf.find(HEADER)
            if start < 0:
                del buf[: len(buf) - 1 if buf.endswith(b"\xff") else len(buf)]
                return None
            del buf[:start]
            if len(buf) < 4:
                return None
            if buf[2] == 0xFF:  # a longer run of 0xFF: the header is its last two bytes
                del buf[0]
                continue
            length = buf[3]
            if length < 2:
                self._bad_packets += 1
                del buf[:2]
                continue
            if len(buf) < length + 4:
                return None
            packet = bytes(buf[: length + 4])
            if checksum(packet[2:-1]) != packet[-1]:
                self._bad_packets += 1
                del buf[:2]  # resynchronise on the next header
                continue
            del buf[: length + 4]
            return packet[2], packet[4], packet[5:-1]

    def _status(self, s: _Servo, params: bytes = b"") -> bytes:
        sid = s.mem[ID]
        body = bytes((sid, len(params) + 2, s.error)) + params
        chk = checksum(body)
        if s.corrupt or self._corrupt_any:
            if s.corrupt:
                s.corrupt -= 1
            else:
                self._corrupt_any -= 1
            chk ^= 0xFF
        return HEADER + body + bytes((chk,))

    def _answers(self, sid: int, now: float) -> _Servo | None:
        """The servo that would answer as `sid` now (None: absent, missing or silenced)."""
        s = self._servos.get(sid)
        if s is None or sid in self.missing or now < s.silent_until:
            return None
        return s

    def _handle(self, sid: int, instruction: int, params: bytes) -> bytes:
        now = time.monotonic()
        name = INSTRUCTIONS.get(instruction, "unknown")
        self._counters[name] += 1
        for s in self._servos.values():
            s.advance(now)
        if instruction == 0x82:
            return self._sync_read(params, now)
        if instruction == 0x83:
            self._sync_write(params)
            return b""
        if sid == BROADCAST:
            targets = [self._servos[i] for i in sorted(self._servos)]
        else:
            targets = [s] if (s := self._servos.get(sid)) is not None else []
        replies = []
        for s in targets:
            if s.mem[ID] in self.missing:
                continue
            reply = self._instruction(s, instruction, params)
            s.advance(now)
            quiet = s.mem[RESPONSE_LEVEL] == 0 and instruction not in (0x01, 0x02)
            # A broadcast gets no reply but to PING (every servo answers: on a real bus, keep one
            # servo connected when pinging the broadcast id to learn its id).
            if (
                reply is not None
                and not quiet
                and now >= s.silent_until
                and (sid != BROADCAST or instruction == 0x01)
            ):
                replies.append(self._status(s, reply))
        return b"".join(replies)

    def _instruction(self, s: _Servo, instruction: int, params: bytes) -> bytes | None:
        """Carry out one instruction on `s`: the reply's params, or None for no reply."""
        if instruction == 0x01:
            return b""
        if instruction == 0x02 and len(params) == 2:
            address, count = params
            return bytes(s.mem[address : address + count]).ljust(count, b"\x00")
        if instruction in (0x03, 0x04) and params:
            if instruction == 0x04:
                s.registered = (params[0], params[1:])
            else:
                self._write(s, params[0], params[1:])
            return b""
        if instruction == 0x05 and s.registered is not None:
            self._write(s, *s.registered)
            s.registered = None
            return b""
        return None

    def _write(self, s: _Servo, address: int, data: bytes) -> None:
        old = s.mem[ID]
        new = s.write(address, data)
        if new is not None and new != old and new not in self._servos:
            self._servos[new] = self._servos.pop(old)
        elif new is not None and new != old:
            s.mem[ID] = old  # the id is taken: a real bus would have two servos answering; refuse

    def _sync_write(self, params: bytes) -> None:
        if len(params) < 2 or params[1] == 0 or (len(params) - 2) % (params[1] + 1):
            self._bad_packets += 1
            return
        address, count = params[0], params[1]
        for at in range(2, len(params), count + 1):
            s = self._servos.get(params[at])
            if s is not None and params[at] not in self.missing:
                self._write(s, address, params[at + 1 : at + 1 + count])

    def _sync_read(self, params: bytes, now: float) -> bytes:
        if len(params) < 3:
            self._bad_packets += 1
            return b""
        address, count = params[0], params[1]
        out = []
        for sid in params[2:]:
            s = self._answers(sid, now)
            if s is not None:
                out.append(self._status(s, bytes(s.mem[address : address + count]).ljust(count, b"\x00")))
        return b"".join(out)
