"""DYNAMIXEL X-series servos on one serial port (Robotis Protocol 2.0), through the vendor's
dynamixel-sdk (`pip install 'nutty[dynamixel]'`), imported when the bus is opened.

One tick's goals go out in one SYNC WRITE of Goal Position (116, 4 bytes); the bus is read with one
SYNC READ of Present Load/Current, Velocity and Position (126..135, 10 bytes), every servo's status
packet parsed by the SDK and matched to its id, so a servo that does not answer (or answers with a bad
CRC) costs only its own reading. The Alert bit of a status packet means the servo's Hardware Error
Status (70) is non-zero: it is read once and reported as a FAULTS word until the servo clears it.

The SDK waits for a reply for its transmission time plus twice the USB adapter's latency timer plus
2 ms, assuming the 16 ms FTDI default; this bus uses the adapter's actual latency timer (sysfs, for
/dev/ttyUSB*) or `default_latency_ms`, so a missing servo stalls a read for ~10 ms, not ~35 ms.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from backend.hardware.bus import BusReading, HardwareError, ServoBus, ServoInfo, goal_vector, open_serial
from backend.hardware.config import DynamixelBusConfig

# Control table addresses (X-series, Protocol 2.0) and sizes (bytes).
OPERATING_MODE, CURRENT_LIMIT, MAX_POSITION, MIN_POSITION = 11, 38, 48, 52
TORQUE_ENABLE, HARDWARE_ERROR, GOAL_POSITION, PRESENT_LOAD, PRESENT_POSITION = 64, 70, 116, 126, 132
STATE_SIZE = 10  # Present Load/Current (2), Velocity (4), Position (4)
POSITION_MODE, EXTENDED_POSITION_MODE = 3, 4
EXTENDED_RANGE = 1_048_575  # ticks either side of 0 in extended position mode
ALERT = 0x80
RESULT_CODES = {
    1: "result fail",
    2: "instruction error",
    3: "CRC error",
    4: "data range error",
    5: "data length error",
    6: "data limit error",
    7: "access error",
}
#: Hardware Error Status bit -> FAULTS word, most serious first (one word is reported per servo).
HARDWARE_FAULTS = ((5, "overload"), (2, "overheat"), (4, "electrical"), (3, "encoder"), (0, "voltage"))

#: model number -> (name, whether address 126 is Present Current (in Current Limit's units) rather than
#: Present Load in 0.1 %).
MODELS: dict[int, tuple[str, bool]] = {
    1060: ("XL430-W250", False),
    1090: ("2XL430-W250", False),
    1070: ("XC430-W150", False),
    1080: ("XC430-W240", False),
    1020: ("XM430-W350", True),
    1030: ("XM430-W210", True),
    1120: ("XM540-W270", True),
    1130: ("XM540-W150", True),
    1010: ("XH430-W350", True),
    1000: ("XH430-W210", True),
    1110: ("XH540-W270", True),
    1100: ("XH540-W150", True),
}

_STATE = np.dtype([("load", "<i2"), ("velocity", "<i4"), ("position", "<i4")])
_INT32 = (-(2**31), 2**31 - 1)


def _sdk() -> Any:
    try:
        import dynamixel_sdk  # lazy: an optional extra, only needed once a Dynamixel bus is opened
    except ImportError as exc:
        raise HardwareError(
            f"the dynamixel driver needs the Dynamixel SDK: pip install 'nutty[dynamixel]' ({exc})"
        ) from None
    return dynamixel_sdk


def usb_latency_ms(port: str) -> float | None:
    """The USB-serial adapter's latency timer (ms) from sysfs (FTDI adapters such as the U2D2), or None."""
    name = Path(os.path.realpath(port)).name
    try:
        return float(Path(f"/sys/bus/usb-serial/devices/{name}/latency_timer").read_text())
    except (OSError, ValueError):
        return None


def _port_handler(sdk: Any, path: str, latency_ms: float) -> Any:
    """An SDK PortHandler whose reply timeout uses `latency_ms` instead of the SDK's fixed 16 ms."""

    class _Port(sdk.PortHandler):
        def setPacketTimeout(self, packet_length: int) -> None:
            self.packet_start_time = self.getCurrentTime()
            self.packet_timeout = self.tx_time_per_byte * packet_length + 2.0 * latency_ms + 2.0

    return _Port(path)


class DynamixelBus(ServoBus):
    """DYNAMIXEL X-series servos (Protocol 2.0) in position mode on one serial port."""

    kind: ClassVar[str] = "dynamixel"
    config_model: ClassVar[type[Any]] = DynamixelBusConfig
    #: USB latency assumed when sysfs does not give it (ms): CDC-ACM boards and ptys answer within ~1 ms.
    default_latency_ms: ClassVar[float] = 4.0
    #: Tries of a PING or a torque WRITE before a servo counts as not answering: one lost reply should
    #: not stop the robot from starting.
    attempts: ClassVar[int] = 2

    def __init__(self, config: DynamixelBusConfig, *, latency_ms: float | None = None):
        """latency_ms: the adapter's reply latency to allow for (ms); default: sysfs's, else
        `default_latency_ms`."""
        super().__init__(config)
        if latency_ms is not None and not latency_ms >= 0:
            raise ValueError(f"latency_ms must be >= 0 (ms), got {latency_ms}")
        self.latency_ms = latency_ms
        self._sdk: Any = None
        self._port: Any = None
        self._ph: Any = None
        self._names = {joint.id: name for name, joint in config.joints.items()}
        self._modes: dict[int, int] = {}
        self._limits: dict[int, tuple[float, float]] = {}
        self._effort_scale: dict[int, float] = {}
        self._faults: dict[int, str] = {}
        self._writers: dict[tuple[int, ...], tuple[Any, np.ndarray, np.ndarray]] = {}
        self._readers: dict[tuple[int, ...], tuple[Any, np.ndarray, dict[int, int]]] = {}

    # -- port --------------------------------------------------------------------------------------
    def open(self) -> None:
        sdk = self._sdk = _sdk()
        latency = self.latency_ms if self.latency_ms is not None else usb_latency_ms(self.config.port)
        port = _port_handler(sdk, self.config.port, self.default_latency_ms if latency is None else latency)
        open_serial(port, self.config.baudrate, self.where)
        self._port, self._ph = port, sdk.PacketHandler(2.0)
        self._writers.clear()
        self._readers.clear()

    def close(self) -> None:
        if self._port is not None:
            self._port.closePort()
            self._port = None

    def _who(self, dxl_id: int) -> str:
        name = self._names.get(dxl_id)
        return f"{self.where}: servo {dxl_id}" + (f" ({name})" if name else "")

    def _why(self, result: int, error: int) -> str:
        if result == self._sdk.COMM_RX_TIMEOUT:
            return "no answer"
        if result == self._sdk.COMM_RX_CORRUPT:
            return "corrupt reply"
        if result != self._sdk.COMM_SUCCESS:
            return self._ph.getTxRxResult(result).removeprefix("[TxRxResult] ")
        return RESULT_CODES.get(error & 0x7F, f"error {error:#04x}")

    def _need_open(self) -> None:
        if self._port is None:
            raise HardwareError(f"{self.where}: the bus is not open")

    # -- discovery ---------------------------------------------------------------------------------
    def ping(self, ids: Sequence[int]) -> dict[int, ServoInfo | None]:
        self._need_open()
        out: dict[int, ServoInfo | None] = {}
        for dxl_id in ids:
            model, result = 0, self._sdk.COMM_RX_FAIL
            for _ in range(self.attempts):
                model, result, _ = self._ph.ping(self._port, dxl_id)
                if result == self._sdk.COMM_SUCCESS:
                    break
            out[dxl_id] = self._info(dxl_id, model) if result == self._sdk.COMM_SUCCESS else None
        return out

    def _info(self, dxl_id: int, model: int) -> ServoInfo:
        if model not in MODELS:
            known = ", ".join(f"{name} ({number})" for number, (name, _) in MODELS.items())
            raise HardwareError(
                f"{self._who(dxl_id)} reports model number {model}, not a DYNAMIXEL X-series model this "
                f"driver knows ({known})"
            )
        name, current_sensing = MODELS[model]
        size = PRESENT_POSITION + 4 - OPERATING_MODE
        data, result, error = [], self._sdk.COMM_RX_FAIL, 0
        for _ in range(2):  # one retry: a single corrupt reply should not fail a scan
            data, result, error = self._ph.readTxRx(self._port, dxl_id, OPERATING_MODE, size)
            if result == self._sdk.COMM_SUCCESS and not error & 0x7F and len(data) == size:
                break
        else:
            raise HardwareError(
                f"{self._who(dxl_id)} answered a ping but not a read: {self._why(result, error)}"
            )
        table = bytes(data)

        def value(addr: int, n: int) -> int:
            return int.from_bytes(
                table[addr - OPERATING_MODE : addr - OPERATING_MODE + n], "little", signed=True
            )

        mode = value(OPERATING_MODE, 1)
        if mode == EXTENDED_POSITION_MODE:
            lo, hi = -EXTENDED_RANGE, EXTENDED_RANGE
        else:
            lo, hi = value(MIN_POSITION, 4), value(MAX_POSITION, 4)
        limit = value(CURRENT_LIMIT, 2)
        self._modes[dxl_id], self._limits[dxl_id] = mode, (lo, hi)
        self._effort_scale[dxl_id] = 1.0 / limit if current_sensing and limit > 0 else 1.0 / 1000.0
        self._writers.clear()  # their goal clipping ranges and effort scales may have changed
        self._readers.clear()
        return ServoInfo(dxl_id, model, name, float(value(PRESENT_POSITION, 4)), float(lo), float(hi), 4096)

    def scan(self, ids: Iterable[int] = range(253)) -> list[ServoInfo]:
        """Every X-series servo among `ids`: broadcast PINGs find who is there (~0.8 s each at 1 Mbps
        whatever the number of ids), then each is pinged for its details."""
        self._need_open()
        wanted = list(ids)
        if len(wanted) > 8:
            # `attempts` rounds, their answers united: a reply lost in one round (a busy adapter, a
            # late servo) is found in another
            seen: set[int] = set()
            results = []
            for _ in range(self.attempts):
                found, result = self._ph.broadcastPing(self._port)
                results.append(result)
                if result == self._sdk.COMM_SUCCESS:
                    seen.update(found)
            if all(r == self._sdk.COMM_RX_TIMEOUT for r in results):
                return []
            if self._sdk.COMM_SUCCESS in results and all(
                r in (self._sdk.COMM_SUCCESS, self._sdk.COMM_RX_TIMEOUT) for r in results
            ):
                wanted = [i for i in wanted if i in seen]
            # otherwise replies collided or were corrupt: ask every id in turn
        return [info for info in self.ping(wanted).values() if info is not None]

    # -- torque and goals --------------------------------------------------------------------------
    def torque(self, ids: Sequence[int], on: bool) -> None:
        self._need_open()
        for dxl_id in ids:
            mode = self._modes.get(dxl_id, POSITION_MODE)
            if on and mode not in (POSITION_MODE, EXTENDED_POSITION_MODE):
                raise HardwareError(
                    f"{self._who(dxl_id)} is in operating mode {mode}, not position mode (3): set its "
                    "Operating Mode (11) to 3 with torque off"
                )
            result, error = self._sdk.COMM_RX_FAIL, 0
            for _ in range(self.attempts):
                result, error = self._ph.write1ByteTxRx(self._port, dxl_id, TORQUE_ENABLE, int(on))
                if result == self._sdk.COMM_SUCCESS:
                    break
            if on and error & ALERT:
                fault = self._read_fault(dxl_id) or "a hardware error"
                raise HardwareError(
                    f"{self._who(dxl_id)} reports {fault}: cannot enable torque until it is rebooted"
                )
            if result != self._sdk.COMM_SUCCESS or error & 0x7F:
                state = "on" if on else "off"
                raise HardwareError(f"{self._who(dxl_id)}: torque {state} failed: {self._why(result, error)}")

    def _writer(self, key: tuple[int, ...]) -> tuple[Any, np.ndarray, np.ndarray]:
        if key not in self._writers:
            group = self._sdk.GroupSyncWrite(self._port, self._ph, GOAL_POSITION, 4)
            for dxl_id in key:
                group.addParam(dxl_id, [0, 0, 0, 0])
            lo = np.array([self._limits.get(i, _INT32)[0] for i in key], dtype=float)
            hi = np.array([self._limits.get(i, _INT32)[1] for i in key], dtype=float)
            self._writers[key] = (group, lo, hi)
        return self._writers[key]

    def write_goals(self, ids: Sequence[int], raw: np.ndarray) -> None:
        """One SYNC WRITE of Goal Position (ticks, rounded and clipped to each servo's position limits,
        which a servo would otherwise answer by ignoring the goal)."""
        self._need_open()
        key = tuple(ids)
        goals = goal_vector(key, raw)
        if not key:
            return
        group, lo, hi = self._writer(key)
        rows = np.clip(np.rint(goals), lo, hi).astype("<i4").view(np.uint8).reshape(-1, 4).tolist()
        for dxl_id, row in zip(key, rows, strict=True):
            group.changeParam(dxl_id, row)
        result = group.txPacket()
        if result != self._sdk.COMM_SUCCESS:
            raise HardwareError(f"{self.where}: sync write failed: {self._why(result, 0)}")

    # -- reading -----------------------------------------------------------------------------------
    def _reader(self, key: tuple[int, ...]) -> tuple[Any, np.ndarray, dict[int, int]]:
        if key not in self._readers:
            group = self._sdk.GroupSyncRead(self._port, self._ph, PRESENT_LOAD, STATE_SIZE)
            for dxl_id in key:
                group.addParam(dxl_id)
            scale = np.array([self._effort_scale.get(i, 1.0 / 1000.0) for i in key])
            self._readers[key] = (group, scale, {dxl_id: i for i, dxl_id in enumerate(key)})
        return self._readers[key]

    def read_state(self, ids: Sequence[int]) -> BusReading:
        self._need_open()
        key = tuple(ids)
        if not key:
            return BusReading(np.zeros(0), np.zeros(0))
        group, scale, index = self._reader(key)
        result = group.txPacket()
        if result != self._sdk.COMM_SUCCESS:
            raise HardwareError(f"{self.where}: sync read failed: {self._why(result, 0)}")
        data = bytearray(len(key) * STATE_SIZE)
        valid = np.zeros(len(key), dtype=bool)
        errors: dict[int, int] = {}
        while len(errors) < len(key):
            packet, result = self._ph.rxPacket(self._port, False)
            if result != self._sdk.COMM_SUCCESS:
                if self._port.isPacketTimeout():
                    break
                continue  # a corrupt status packet: that servo's reading is lost, the others follow
            i = index.get(packet[4])
            if i is None or packet[4] in errors:
                continue
            errors[packet[4]] = packet[8]
            if int.from_bytes(bytes(packet[5:7]), "little") == STATE_SIZE + 4 and not packet[8] & 0x7F:
                data[i * STATE_SIZE : (i + 1) * STATE_SIZE] = bytes(packet[9 : 9 + STATE_SIZE])
                valid[i] = True
        state = np.frombuffer(bytes(data), dtype=_STATE)
        position = np.where(valid, state["position"].astype(float), np.nan)
        effort = np.where(valid, np.clip(state["load"] * scale, -1.0, 1.0), np.nan)
        return BusReading(position, effort, self._fault_words(errors))

    def _fault_words(self, errors: dict[int, int]) -> dict[int, str]:
        faults: dict[int, str] = {}
        for dxl_id, error in errors.items():
            if not error & ALERT:
                self._faults.pop(dxl_id, None)
                continue
            word = self._faults.get(dxl_id) or self._read_fault(dxl_id)
            if word is not None:
                faults[dxl_id] = word
        return faults

    def _read_fault(self, dxl_id: int) -> str | None:
        """The FAULTS word of a servo's Hardware Error Status (70), cached until its Alert clears; None
        when the read fails (tried again next time)."""
        value, result, _ = self._ph.read1ByteTxRx(self._port, dxl_id, HARDWARE_ERROR)
        if result != self._sdk.COMM_SUCCESS:
            return None
        word = next((word for bit, word in HARDWARE_FAULTS if value & (1 << bit)), None)
        if word is not None:
            self._faults[dxl_id] = word
        return word
