"""Feetech STS/SCS serial servos (SO-100, LeKiwi) through FEETECH's Python SDK (`scservo_sdk`, from
`pip install 'nutty[feetech]'`): position mode, one SYNC WRITE of goal positions (address 42) per call,
one SYNC READ of present position, speed and load (addresses 56..61) per read.

STS words are little-endian, 4096 ticks a turn; SCS words are big-endian, 0..1023 over 300°. A present
position with bit 15 set is negative (sign-magnitude, STS multi-turn). The present load is 0..1000
(0.1 % of the maximum torque) with bit 10 as its direction. The status error byte of each reply gives
the faults: bit 0 voltage, 1 encoder, 2 overheat, 3 electrical (over-current), 5 overload.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any, ClassVar

import numpy as np

from backend.hardware.bus import BusReading, HardwareError, ServoBus, ServoInfo, goal_vector, open_serial
from backend.hardware.config import FeetechBusConfig

#: model number (at address 3) -> (name, series).
MODELS: dict[int, tuple[str, str]] = {
    777: ("STS3215", "sts"),
    2825: ("STS3250", "sts"),
    2569: ("STS3095", "sts"),
    11272: ("SM8512BL", "sts"),
    1284: ("SCS0009", "scs"),
}
#: status error bits, most serious first (a servo flagging several reports the first).
FAULT_BITS = (
    ("overload", 0x20),
    ("overheat", 0x04),
    ("electrical", 0x08),
    ("voltage", 0x01),
    ("encoder", 0x02),
)
SHUTDOWN_BITS = 0x20 | 0x04 | 0x08

ADDR_MODEL, ADDR_TORQUE_ENABLE, ADDR_GOAL_POSITION, ADDR_PRESENT_POSITION = 3, 40, 42, 56
STATE_LENGTH = 6  # present position, present speed, present load: three words
BAUDRATES = (4800, 9600, 14400, 19200, 38400, 57600, 115200, 128000, 250000, 500000, 1000000)
COMM_SUCCESS = 0  # scservo_sdk's result code for a valid reply


def _sdk() -> Any:
    try:
        # lazy: the SDK is an optional extra; backend.hardware imports without it
        import scservo_sdk
    except ImportError:
        raise HardwareError(
            "the feetech bus needs FEETECH's SDK: pip install 'nutty[feetech]' (ftservo-python-sdk)"
        ) from None
    return scservo_sdk


def _port_handler(sdk: Any, path: str, reply_timeout_ms: float) -> Any:
    """The SDK's PortHandler, waiting `reply_timeout_ms` (plus the bytes' transfer time) for a reply
    instead of the SDK's fixed 50 ms, so a missing servo stalls a read only that long."""

    class PortHandler(sdk.PortHandler):
        # the SDK's own method name (camelCase), overridden
        def setPacketTimeout(self, packet_length: int) -> None:
            self.packet_start_time = self.getCurrentTime()
            self.packet_timeout = self.tx_time_per_byte * (packet_length + 3) + reply_timeout_ms

    return PortHandler(path)


def decode_words(data: np.ndarray, series: str) -> np.ndarray:
    """(n, 2k) bytes -> (n, k) unsigned 16-bit words in the series' byte order."""
    lo, hi = (data[:, 0::2], data[:, 1::2]) if series == "sts" else (data[:, 1::2], data[:, 0::2])
    return lo.astype(np.int64) | (hi.astype(np.int64) << 8)


def sign_magnitude(words: np.ndarray, bit: int) -> np.ndarray:
    """Words whose bit `bit` is a sign (set: negative) -> signed values."""
    sign = (words >> bit) & 1
    return np.where(sign == 1, -(words & ((1 << bit) - 1)), words)


def fault_of(error: int) -> str | None:
    """The most serious fault a status error byte flags (None: none)."""
    return next((name for name, bit in FAULT_BITS if error & bit), None)


class FeetechBus(ServoBus):
    """A serial bus of Feetech servos of one series (`series: sts|scs` in hardware.yaml)."""

    kind: ClassVar[str] = "feetech"
    config_model: ClassVar[type[Any]] = FeetechBusConfig
    #: how long to wait for a servo's reply beyond its transfer time (ms): long enough for a USB
    #: adapter's latency (CH340: ~1 ms; an FTDI at its 16 ms default is slower, set it to 1 ms), short
    #: enough that a missing servo stalls a read only this long.
    REPLY_TIMEOUT_MS: ClassVar[float] = 20.0

    def __init__(self, config: FeetechBusConfig, reply_timeout_ms: float | None = None):
        super().__init__(config)
        self.config: FeetechBusConfig = config
        self.reply_timeout_ms = self.REPLY_TIMEOUT_MS if reply_timeout_ms is None else float(reply_timeout_ms)
        if not self.reply_timeout_ms > 0:
            raise ValueError(f"reply_timeout_ms must be positive, not {reply_timeout_ms}")
        self._port: Any = None
        self._packets: Any = None
        self._writers: dict[tuple[int, ...], Any] = {}
        self._readers: dict[tuple[int, ...], Any] = {}

    @property
    def series(self) -> str:
        return self.config.series

    # -- port ---------------------------------------------------------------------------------------
    def open(self) -> None:
        sdk = _sdk()
        if self.config.baudrate not in BAUDRATES:
            rates = ", ".join(str(b) for b in BAUDRATES)
            raise HardwareError(
                f"{self.where}: baudrate {self.config.baudrate} is not a Feetech rate ({rates})"
            )
        port = _port_handler(sdk, self.config.port, self.reply_timeout_ms)
        open_serial(port, self.config.baudrate, self.where)
        self._port = port
        self._packets = sdk.protocol_packet_handler(port, 0 if self.series == "sts" else 1)

    def close(self) -> None:
        if self._port is not None and self._port.is_open:
            self._port.closePort()
        self._port = self._packets = None
        self._writers.clear()
        self._readers.clear()

    def _handler(self) -> Any:
        if self._packets is None:
            raise HardwareError(f"{self.where}: the bus is not open")
        return self._packets

    def _transact(self, call: Any, *args: Any) -> Any:
        """Run one SDK call; a port that fails (unplugged) -> HardwareError."""
        try:
            return call(*args)
        except OSError as exc:
            raise HardwareError(f"{self.where}: the port failed: {exc}") from None
        finally:
            self._port.is_using = False  # the SDK leaves its port busy when a call raises

    # -- servos -------------------------------------------------------------------------------------
    def _info(self, sid: int, model: int) -> ServoInfo:
        if model not in MODELS:
            swapped = ((model & 0xFF) << 8) | (model >> 8)
            hint = ""
            if swapped in MODELS:
                name, series = MODELS[swapped]
                hint = f" (read in the other byte order it is a {name}: set `series: {series}`)"
            raise HardwareError(
                f"{self.where}: servo id {sid} reports model {model}, not a known Feetech model{hint}"
            )
        name, series = MODELS[model]
        if series != self.series:
            raise HardwareError(f"{self.where}: servo id {sid} is a {name}: set `series: {series}`")
        lo, hi = self.config.raw_range()
        per_turn = round(self.config.ticks_per_turn())
        return ServoInfo(
            id=sid, model=model, model_name=name, raw_min=lo, raw_max=hi, ticks_per_turn=per_turn
        )

    def ping(self, ids: Sequence[int]) -> dict[int, ServoInfo | None]:
        packets = self._handler()
        out: dict[int, ServoInfo | None] = {}
        for sid in ids:
            model, result, _ = self._transact(packets.ping, sid)
            if result != COMM_SUCCESS:
                out[sid] = None
                continue
            info = self._info(sid, model)
            word, result, _ = self._transact(packets.read2ByteTxRx, sid, ADDR_PRESENT_POSITION)
            if result == COMM_SUCCESS:
                position = (
                    float(sign_magnitude(np.array([word]), 15)[0]) if self.series == "sts" else float(word)
                )
                info = replace(info, position=position)
            out[sid] = info
        return out

    def torque(self, ids: Sequence[int], on: bool) -> None:
        packets = self._handler()
        refused = []
        for sid in ids:  # one acknowledged WRITE each, so a servo that refuses is named
            result, error = self._transact(packets.write1ByteTxRx, sid, ADDR_TORQUE_ENABLE, int(on))
            if result != COMM_SUCCESS:
                refused.append(f"id {sid}: no answer")
            elif on and error & SHUTDOWN_BITS:
                refused.append(f"id {sid}: {fault_of(error & SHUTDOWN_BITS)}")
        if refused:
            raise HardwareError(f"{self.where}: torque {'on' if on else 'off'} failed: {'; '.join(refused)}")

    def write_goals(self, ids: Sequence[int], raw: np.ndarray) -> None:
        packets = self._handler()
        goals = goal_vector(ids, raw)
        key = tuple(ids)
        writer = self._writers.get(key)
        if writer is None:
            writer = _sdk().GroupSyncWrite(packets, ADDR_GOAL_POSITION, 2)
            for sid in key:
                writer.addParam(sid, [0, 0])
            self._writers[key] = writer
        lo, hi = self.config.raw_range()
        ticks = np.clip(np.rint(goals), lo, hi).astype(np.int64)
        low, high = ticks & 0xFF, ticks >> 8
        first, second = (low, high) if self.series == "sts" else (high, low)
        for sid, a, b in zip(key, first.tolist(), second.tolist(), strict=True):
            writer.changeParam(sid, [a, b])
        self._transact(writer.txPacket)

    def _reader(self, key: tuple[int, ...]) -> Any:
        reader = self._readers.get(key)
        if reader is None:
            reader = _sdk().GroupSyncRead(self._handler(), ADDR_PRESENT_POSITION, STATE_LENGTH)
            for sid in key:
                reader.addParam(sid)
            self._readers[key] = reader
        return reader

    def read_state(self, ids: Sequence[int]) -> BusReading:
        key = tuple(ids)
        n = len(key)
        position, effort = np.full(n, math.nan), np.full(n, math.nan)
        if n == 0:
            return BusReading(position, effort)
        reader = self._reader(key)
        for sid in key:  # the SDK keeps the last reply when a read gets none: never report it again
            reader.data_dict[sid] = []
        self._transact(reader.txRxPacket)
        rows, errors, found = [], [], []
        for i, sid in enumerate(key):
            ok, error = reader.isAvailable(sid, ADDR_PRESENT_POSITION, STATE_LENGTH)
            if ok:
                found.append(i)
                errors.append(error)
                rows.append(reader.data_dict[sid][1 : 1 + STATE_LENGTH])
        faults = {key[i]: f for i, e in zip(found, errors, strict=True) if (f := fault_of(e)) is not None}
        if not found:
            return BusReading(position, effort, faults)
        words = decode_words(np.asarray(rows, dtype=np.int64), self.series)
        pos = sign_magnitude(words[:, 0], 15) if self.series == "sts" else words[:, 0]
        load = sign_magnitude(words[:, 2], 10)
        position[found] = pos
        effort[found] = np.clip(load / 1000.0, -1.0, 1.0)
        return BusReading(position, effort, faults)
