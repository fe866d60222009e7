"""A PCA9685 16-channel 12-bit PWM controller on a stand-in I2C bus, for development and tests without a
board: an object with the `busio.I2C` interface (try_lock/unlock, writeto, readfrom_into,
writeto_then_readfrom, scan, deinit) that any I2C driver, the Adafruit one included, can be given.

It models the chip from NXP's PCA9685 product data sheet (rev. 4, "16-channel, 12-bit PWM Fm+ I2C-bus
LED controller"), not from any driver:
- register map (Table 3): MODE1 0x00 (RESTART bit 7, EXTCLK 6, AI 5, SLEEP 4, SUB1-3, ALLCALL 0),
  MODE2 0x01 (INVRT bit 4, OCH 3, OUTDRV 2, OUTNE 1:0), SUBADR1-3, ALLCALLADR, LEDn_ON_L/H and
  LEDn_OFF_L/H at 0x06 + 4n (bit 4 of the _H bytes: full on / full off; bits 7:5 reserved, read 0),
  ALL_LED_ON/OFF 0xFA-0xFD (write-only: they load every channel and read back 0), PRE_SCALE 0xFE;
  power-on values (MODE1 0x11: asleep, PRE_SCALE 0x1E: 200 Hz, every output full off);
- the control register (register pointer): the first byte of a write; with AI set it moves after each
  byte read or written, from LED15_OFF_H (0x45) back to MODE1, and from 0xFE back to MODE1; without AI
  it stays, so further bytes land on the same register;
- PRE_SCALE is writable only while SLEEP is 1 (writes are blocked otherwise); the hardware forces it to
  at least 3. Output frequency = oscillator / (4096 * (PRE_SCALE + 1)), 25 MHz internal oscillator;
- sleep and restart (7.3.1.1): going to sleep while a PWM output is active sets RESTART; the outputs
  stay stopped until RESTART is written 1 with SLEEP cleared for at least 500 µs, or a PWM register
  is written and the transaction ends (OCH = 0; OCH = 1: all four registers of a channel written);
- addressing: its own address, the LED All Call address (ALLCALLADR, 0x70 7-bit) while ALLCALL is set,
  the SWRST general call (address 0x00, byte 0x06) resets it; any other address is not acknowledged,
  which reaches the caller as OSError (EREMOTEIO), as a NACK does through Linux's i2c-dev.

Test helpers: `pulse_us(channel)`, `frequency`, `register(addr)`, `counts`, `write_log`; fault
injection: `present = False` (unplugged), `nack_next(n)`, `power_cycle()` (a brown-out reset).
"""

from __future__ import annotations

import errno
import os
import threading
import time
from collections import Counter, deque
from typing import Any

from backend.hardware.smbus_i2c import buffer_window

MODE1, MODE2, ALLCALLADR, LED0, ALL_LED, PRE_SCALE, TEST_MODE = 0x00, 0x01, 0x05, 0x06, 0xFA, 0xFE, 0xFF
LED_LAST = LED0 + 4 * 16 - 1  # LED15_OFF_H, 0x45
RESTART, AI, SLEEP, ALLCALL = 0x80, 0x20, 0x10, 0x01
INVRT, OCH = 0x10, 0x08
FULL = 0x10  # bit 4 of LEDn_ON_H / LEDn_OFF_H
OSCILLATOR_HZ = 25_000_000.0
#: After SLEEP is cleared the oscillator needs this long (s) before RESTART may be written.
WAKE_S = 500e-6
SWRST_BYTE = 0x06

_POWER_ON = {MODE1: 0x11, MODE2: 0x04, 0x02: 0xE2, 0x03: 0xE4, 0x04: 0xE8, ALLCALLADR: 0xE0, PRE_SCALE: 0x1E}


class Pca9685Emulator:
    """One PCA9685 at `address` (7-bit, default 0x40) on its own emulated I2C bus.

    oscillator_hz: the clock the PWM counts (Hz; the internal one is 25 MHz, ±some %). Thread-safe: the
    I2C methods and the helpers take one lock. `present = False` makes every transaction NACK.
    """

    def __init__(self, address: int = 0x40, *, oscillator_hz: float = OSCILLATOR_HZ):
        if not 0x03 <= address <= 0x77:
            raise ValueError(f"address: {address:#x} is not a 7-bit device address (0x03..0x77)")
        if not oscillator_hz > 0:
            raise ValueError(f"oscillator_hz: must be positive, got {oscillator_hz}")
        self.address = address
        self.oscillator_hz = float(oscillator_hz)
        self.present = True
        #: Transfers by kind: write (register data), pointer (control register only: a read's first
        #: half), read, probe (empty write), nack; and events: prescale_blocked, restart,
        #: restart_too_early, reset, reserved_write.
        self.counts: Counter[str] = Counter()
        #: (address, first register, bytes written) of each register write transaction, newest last.
        self.write_log: deque[tuple[int, int, bytes]] = deque(maxlen=10_000)
        self._state = threading.RLock()
        self._bus = threading.Lock()
        self._nacks = 0
        self._regs = bytearray(256)
        self._pointer = 0
        self._woke_at = 0.0
        self._reset()

    # -- the chip ------------------------------------------------------------------------------------------
    def _reset(self) -> None:
        self._regs[:] = bytes(256)
        for reg, value in _POWER_ON.items():
            self._regs[reg] = value
        for n in range(16):
            self._regs[LED0 + 4 * n + 3] = FULL
        self._pointer = 0
        self.counts["reset"] += 1

    def _next(self, reg: int) -> int:
        if not self._regs[MODE1] & AI:
            return reg
        return 0 if reg in (LED_LAST, PRE_SCALE, TEST_MODE) else reg + 1

    def _read(self, reg: int) -> int:
        if LED_LAST < reg < PRE_SCALE:  # reserved, and the write-only ALL_LED registers, read 0
            return 0
        return self._regs[reg]

    def _active(self) -> bool:
        """Whether any output is running a PWM (not full off, not stopped)."""
        return any(not self._regs[LED0 + 4 * n + 3] & FULL for n in range(16))

    def _write_mode1(self, value: int) -> None:
        old = self._regs[MODE1]
        new = (value & ~RESTART) | (old & RESTART)
        if not old & SLEEP and value & SLEEP and self._active():
            new |= RESTART  # the outputs stop; RESTART remembers they were running
        if old & SLEEP and not value & SLEEP:
            self._woke_at = time.monotonic()
        if value & RESTART and old & RESTART and not value & SLEEP:
            if time.monotonic() - self._woke_at >= WAKE_S:
                new &= ~RESTART
                self.counts["restart"] += 1
            else:
                self.counts["restart_too_early"] += 1
        self._regs[MODE1] = new & 0xFF

    def _write(self, reg: int, value: int) -> None:
        if reg == MODE1:
            self._write_mode1(value)
        elif reg == MODE2:
            self._regs[reg] = value & 0x1F
        elif reg < LED0:
            self._regs[reg] = value
        elif reg <= LED_LAST:
            self._regs[reg] = value & 0x1F if (reg - LED0) % 2 else value
        elif ALL_LED <= reg < PRE_SCALE:
            byte = reg - ALL_LED
            for n in range(16):
                self._regs[LED0 + 4 * n + byte] = value & 0x1F if byte % 2 else value
        elif reg == PRE_SCALE:
            if self._regs[MODE1] & SLEEP:
                self._regs[reg] = max(3, value)
            else:
                self.counts["prescale_blocked"] += 1
        else:  # reserved registers, TestMode: the data sheet warns against writing them
            self.counts["reserved_write"] += 1

    def _end_of_write(self, written: set[int]) -> None:
        """STOP after a write: a PWM register write clears a pending RESTART (7.3.1.1)."""
        if not self._regs[MODE1] & RESTART or self._regs[MODE1] & SLEEP:
            return
        pwm = {r for r in written if LED0 <= r <= LED_LAST or ALL_LED <= r < PRE_SCALE}
        if self._regs[MODE2] & OCH:
            channels = {(r - LED0) // 4 for r in pwm if r <= LED_LAST}
            whole = any(all(LED0 + 4 * c + i in written for i in range(4)) for c in channels)
            done = whole or all(ALL_LED + i in written for i in range(4))
        else:
            done = bool(pwm)
        if done:
            self._regs[MODE1] &= ~RESTART & 0xFF

    # -- addressing ----------------------------------------------------------------------------------------
    def _acks(self, address: int) -> bool:
        if not self.present:
            return False
        if self._nacks:
            self._nacks -= 1
            return False
        allcall = self._regs[MODE1] & ALLCALL and address == self._regs[ALLCALLADR] >> 1
        return address == self.address or bool(allcall)

    def _nack(self, address: int) -> OSError:
        self.counts["nack"] += 1
        return OSError(errno.EREMOTEIO, f"{os.strerror(errno.EREMOTEIO)} (no ACK from {address:#04x})")

    def _transfer_out(self, address: int, data: bytes) -> None:
        if address == 0 and data == bytes([SWRST_BYTE]) and self.present:
            self._reset()  # the SWRST general call
            return
        if not self._acks(address):
            raise self._nack(address)
        if not data:
            self.counts["probe"] += 1
            return
        self._pointer = data[0]
        if len(data) == 1:
            self.counts["pointer"] += 1  # the write half of a register read
            return
        self.counts["write"] += 1
        self.write_log.append((address, data[0], bytes(data[1:])))
        written = set()
        for value in data[1:]:
            self._write(self._pointer, value)
            written.add(self._pointer)
            self._pointer = self._next(self._pointer)
        self._end_of_write(written)

    def _transfer_in(self, address: int, into: memoryview) -> None:
        if not self._acks(address):
            raise self._nack(address)
        self.counts["read"] += 1
        for i in range(len(into)):
            into[i] = self._read(self._pointer)
            self._pointer = self._next(self._pointer)

    # -- busio.I2C -------------------------------------------------------------------------------------------
    def try_lock(self) -> bool:
        """Take the bus without waiting; False if another thread holds it."""
        return self._bus.acquire(blocking=False)

    def unlock(self) -> None:
        """Release the bus."""
        self._bus.release()

    def writeto(self, address: int, buffer: Any, *, start: int = 0, end: int | None = None) -> None:
        """START, address+W, buffer[start:end] (control register then data), STOP. OSError on a NACK."""
        with self._state:
            self._transfer_out(address, bytes(buffer_window(buffer, start, end)))

    def readfrom_into(self, address: int, buffer: Any, *, start: int = 0, end: int | None = None) -> None:
        """START, address+R, read from the current register pointer into buffer[start:end], STOP."""
        with self._state:
            self._transfer_in(address, buffer_window(buffer, start, end))

    def writeto_then_readfrom(
        self,
        address: int,
        buffer_out: Any,
        buffer_in: Any,
        *,
        out_start: int = 0,
        out_end: int | None = None,
        in_start: int = 0,
        in_end: int | None = None,
    ) -> None:
        """Write, repeated START, read: one transaction (how a register is read)."""
        with self._state:
            self._transfer_out(address, bytes(buffer_window(buffer_out, out_start, out_end)))
            self._transfer_in(address, buffer_window(buffer_in, in_start, in_end))

    def scan(self) -> list[int]:
        """The addresses that acknowledge: the chip's, and the All Call address while ALLCALL is set."""
        with self._state:
            if not self.present:
                return []
            found = {self.address}
            if self._regs[MODE1] & ALLCALL:
                found.add(self._regs[ALLCALLADR] >> 1)
            return sorted(found)

    def deinit(self) -> None:
        """Nothing to release (the chip keeps its registers, as a real one does)."""

    def close(self) -> None:
        """Same as deinit."""

    def __enter__(self) -> Pca9685Emulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- helpers for tests and tools ----------------------------------------------------------------------
    def register(self, reg: int) -> int:
        """A register's value as a read would return it (without moving the pointer)."""
        with self._state:
            return self._read(reg & 0xFF)

    @property
    def prescale(self) -> int:
        with self._state:
            return self._regs[PRE_SCALE]

    @property
    def frequency(self) -> float:
        """The PWM frequency the outputs run at (Hz): oscillator / (4096 * (PRE_SCALE + 1))."""
        with self._state:
            return self.oscillator_hz / (4096 * (self._regs[PRE_SCALE] + 1))

    @property
    def running(self) -> bool:
        """Whether the outputs run: awake, and not waiting for a RESTART."""
        with self._state:
            return not self._regs[MODE1] & (SLEEP | RESTART)

    def channel_counts(self, channel: int) -> tuple[int, int, bool, bool]:
        """Channel's (ON count, OFF count, full on, full off) as its four registers hold them."""
        if not 0 <= channel < 16:
            raise ValueError(f"channel: {channel} is not 0..15")
        with self._state:
            on_l, on_h, off_l, off_h = self._regs[LED0 + 4 * channel : LED0 + 4 * channel + 4]
            return (
                on_l | (on_h & 0x0F) << 8,
                off_l | (off_h & 0x0F) << 8,
                bool(on_h & FULL),
                bool(off_h & FULL),
            )

    def high_ticks(self, channel: int) -> int:
        """How many of the 4096 counts of each period the output is high (0: no pulses)."""
        on, off, full_on, full_off = self.channel_counts(channel)
        with self._state:
            if not self.running or full_off:
                return 0  # asleep or stopped: outputs off (full off has priority over full on)
            high = 4096 if full_on else (off - on) % 4096
            return 4096 - high if self._regs[MODE2] & INVRT else high

    def pulse_us(self, channel: int) -> float:
        """The width of the pulse channel outputs each period (µs); 0.0 when it outputs none."""
        with self._state:
            return self.high_ticks(channel) * (self._regs[PRE_SCALE] + 1) * 1e6 / self.oscillator_hz

    def nack_next(self, n: int = 1) -> None:
        """Do not acknowledge the next n transactions (a glitch on the wires)."""
        with self._state:
            self._nacks = max(0, int(n))

    def power_cycle(self) -> None:
        """A brown-out: every register back to its power-on value (asleep, 200 Hz, outputs off)."""
        with self._state:
            self._reset()
