"""Hobby PWM servos on a PCA9685 16-channel board (`driver: pca9685` in hardware.yaml).

A "servo id" is the board's channel (0..15) and a raw position is a pulse width in µs. The chip is set
up by Adafruit's CircuitPython driver (adafruit_pca9685: reset, PRE_SCALE for the configured frequency)
on a plain Linux I2C bus (`SMBusI2C`, no Blinka board detection); goals go out as one auto-increment
write of the LEDn_ON/OFF registers spanning the channels whose pulse changed (none when nothing did),
so a tick is at most one I2C transaction.

Hobby servos cannot report anything: positions and efforts read NaN, the only fault is the board
itself not answering (`no_answer` for all its channels). Torque off is "no pulses" (full off): the
servo goes limp. A board that browned out (it wakes asleep at 200 Hz, outputs off) is set up again on
the next read_state and its running channels get their pulses back.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from backend.hardware.bus import BusReading, HardwareError, ServoBus, ServoInfo
from backend.hardware.config import Pca9685BusConfig

CHANNELS = 16
MODEL, MODEL_NAME = 9685, "PCA9685 PWM"
_MISSING = "the PCA9685 driver is not installed: pip install 'nutty[pca9685]'"
_LED0, _MODE1 = 0x06, 0x00
_AI, _SLEEP = 0x20, 0x10
_FULL_OFF_ROW = np.array([0, 0, 0, 0x10], dtype=np.uint8)  # LEDn_OFF_H bit 4: output held low


class Pca9685Bus(ServoBus):
    """A PCA9685 board: channels are ids, raw units are pulse widths (µs).

    `i2c`: an object with the busio.I2C interface to use instead of opening /dev/i2c-N (an emulator,
    or another adapter); it is not closed by close().
    """

    kind = "pca9685"
    config_model = Pca9685BusConfig
    reads_position = False
    raw_unit = "µs"

    def __init__(self, config: Pca9685BusConfig, *, i2c: Any = None):
        super().__init__(config)
        self.config: Pca9685BusConfig = config
        self._given_i2c = i2c
        self._i2c: Any = None
        self._pca: Any = None
        #: The PWM frequency the chip really runs at after PRE_SCALE rounding (Hz); NaN before open.
        self.frequency = float("nan")
        #: Times the board was found reset (brown-out) and set up again.
        self.resets = 0
        # What the LEDn registers hold, as last written or read (None: unknown, rewrite everything).
        self._regs: np.ndarray | None = None
        self._goal_us = np.full(CHANNELS, np.nan)  # last goal per channel (µs), NaN: none yet
        self._on = np.zeros(CHANNELS, dtype=bool)  # channels given pulses ("torque on")

    # -- lifecycle -----------------------------------------------------------------------------------------
    def open(self) -> None:
        """Open /dev/i2c-N (HardwareError if it cannot be) and set the board up if it answers; a board
        that does not answer is not an error here: ping reports its channels missing."""
        if self._given_i2c is not None:
            self._i2c = self._given_i2c
        else:
            # lazy: smbus2 is an optional extra; the module imports without it
            from backend.hardware.smbus_i2c import SMBusI2C

            try:
                self._i2c = SMBusI2C(self.config.i2c_bus)
            except OSError as exc:
                raise HardwareError(
                    f"cannot open /dev/i2c-{self.config.i2c_bus}: {exc.strerror or exc} (is I2C enabled, "
                    "e.g. `dtparam=i2c_arm=on` on a Raspberry Pi, and is the user in group i2c?)"
                ) from None
        self._connect()

    def close(self) -> None:
        """Forget the board and close /dev/i2c-N if this bus opened it (the outputs keep running)."""
        i2c, self._i2c, self._pca = self._i2c, None, None
        if i2c is not None and i2c is not self._given_i2c:
            i2c.deinit()

    def _connect(self) -> bool:
        """Set the chip up (reset, PRE_SCALE, auto-increment) and read its outputs; False if it does not
        answer."""
        try:
            # lazy: adafruit-circuitpython-pca9685 is an optional extra
            from adafruit_pca9685 import PCA9685
        except ImportError as exc:
            raise ImportError(_MISSING) from exc
        if self._i2c is None:
            raise HardwareError(f"{self.where}: the bus is not open")
        try:
            pca = PCA9685(self._i2c, address=self.config.address)
            pca.frequency = self.config.frequency
            self.frequency = float(pca.frequency)  # what PRE_SCALE's rounding gives, not what was asked
            self._pca = pca
            self._regs = self._read_leds()
        except (OSError, ValueError):  # the library reports an absent device as ValueError
            self._pca, self._regs = None, None
            return False
        return True

    def _chip(self) -> Any:
        """The library's PCA9685, connecting first if needed; None when the board does not answer."""
        if self._pca is None:
            self._connect()
        return self._pca

    def _read_leds(self) -> np.ndarray:
        """The 64 LEDn registers, in one auto-increment read: (16, 4) bytes."""
        buf = bytearray(1 + 4 * CHANNELS)
        buf[0] = _LED0
        with self._pca.i2c_device as dev:
            dev.write_then_readinto(buf, buf, out_end=1, in_start=1)
        return np.frombuffer(bytes(buf[1:]), dtype=np.uint8).reshape(CHANNELS, 4).copy()

    def _mode1(self) -> int | None:
        """MODE1, or None when the board does not answer."""
        pca = self._chip()
        if pca is None:
            return None
        try:
            return int(pca.mode1_reg)
        except OSError:
            self._regs = None  # it may come back reset: rewrite everything then
            return None

    # -- ServoBus --------------------------------------------------------------------------------------------
    def ping(self, ids: Sequence[int]) -> dict[int, ServoInfo | None]:
        """Every existing channel answers when the board does (position None: hobby servos cannot say)."""
        answers = self._mode1() is not None
        lo, hi = self.config.min_us, self.config.max_us
        return {
            i: ServoInfo(i, MODEL, MODEL_NAME, None, lo, hi, 0) if answers and 0 <= i < CHANNELS else None
            for i in ids
        }

    def torque(self, ids: Sequence[int], on: bool) -> None:
        """on: the channels output their last goal's pulse (or start at their first goal); off: no pulses,
        so the servos go limp. HardwareError if the board does not answer."""
        ch = self._channels(ids)
        self._on[ch] = on
        if not self._push(ch):
            raise HardwareError(f"{self.where}: the PCA9685 does not answer (torque {'on' if on else 'off'})")

    def write_goals(self, ids: Sequence[int], raw: np.ndarray) -> None:
        """Pulse widths (µs), clipped to [min_us, max_us]; a NaN keeps the channel's previous goal. Only
        channels with torque on get pulses. Never raises for a board that does not answer: read_state
        reports it."""
        ch = self._channels(ids)
        us = np.asarray(raw, dtype=float).reshape(-1)
        if us.shape[0] != ch.shape[0]:
            raise ValueError(f"raw: {us.shape[0]} goals for {ch.shape[0]} channels")
        ok = np.isfinite(us)
        self._goal_us[ch[ok]] = np.clip(us[ok], self.config.min_us, self.config.max_us)
        self._push(ch)

    def read_state(self, ids: Sequence[int]) -> BusReading:
        """NaN positions and efforts (hobby servos report nothing); `no_answer` for every id when the
        board does not answer. A board found reset is set up again and given its pulses back."""
        n = len(ids)
        reading = BusReading(np.full(n, np.nan), np.full(n, np.nan))
        mode1 = self._mode1()
        if mode1 is not None and (mode1 & (_AI | _SLEEP)) != _AI:
            # a power-on reset (brown-out) left it asleep at 200 Hz, outputs off, without auto-increment
            self.resets += 1
            if self._connect():
                self._push(np.arange(CHANNELS))
            else:
                mode1 = None
        if mode1 is None:
            reading.faults = dict.fromkeys(ids, "no_answer")
        return reading

    # -- the registers -------------------------------------------------------------------------------------
    def _channels(self, ids: Sequence[int]) -> np.ndarray:
        ch = np.asarray(list(ids), dtype=int).reshape(-1)
        bad = ch[(ch < 0) | (ch >= CHANNELS)]
        if bad.size:
            raise HardwareError(f"{self.where}: channel {int(bad[0])} does not exist (a PCA9685 has 0..15)")
        return ch

    def counts(self, us: np.ndarray) -> np.ndarray:
        """12-bit OFF counts (ON at 0) for pulse widths `us` (µs) at the chip's real frequency."""
        ticks = np.rint(np.asarray(us, dtype=float) * self.frequency * 4096 / 1e6)
        return np.clip(ticks, 1, 4095).astype(np.uint16)

    def _rows(self, ch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The channels among `ch` to write and their 4 LEDn register bytes."""
        on = self._on[ch]
        goal = self._goal_us[ch]
        pulsing = on & np.isfinite(goal)
        keep = pulsing | ~on  # on without a goal yet: nothing to output
        rows = np.tile(_FULL_OFF_ROW, (ch.shape[0], 1))
        off = self.counts(np.where(pulsing, goal, self.config.min_us))
        rows[pulsing, 2] = (off[pulsing] & 0xFF).astype(np.uint8)
        rows[pulsing, 3] = (off[pulsing] >> 8).astype(np.uint8)
        return ch[keep], rows[keep]

    def _push(self, ch: np.ndarray) -> bool:
        """Write the channels whose registers change, in one auto-increment write spanning them (the
        unchanged channels in between are rewritten with what they hold). False if the board did not
        answer."""
        pca = self._chip()
        if pca is None:
            return False
        try:
            if self._regs is None:  # after a failed write nobody knows what the chip holds: ask it
                self._regs = self._read_leds()
            which, rows = self._rows(ch)
            changed = which[np.any(self._regs[which] != rows, axis=1)]
            if not changed.size:
                return True
            target = self._regs.copy()
            target[which] = rows
            lo, hi = int(changed.min()), int(changed.max())
            with pca.i2c_device as dev:
                dev.write(bytes([_LED0 + 4 * lo]) + target[lo : hi + 1].tobytes())
        except OSError:
            self._regs = None
            return False
        self._regs = target
        return True
