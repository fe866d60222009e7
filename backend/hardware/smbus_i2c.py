"""A Linux I2C bus (/dev/i2c-N) with the small `busio.I2C` interface the Adafruit CircuitPython drivers
use (try_lock/unlock, writeto, readfrom_into, writeto_then_readfrom, scan, deinit), over smbus2.

Why not Blinka's `board`/`busio`: on a plain Linux PC `import board` detects `GENERIC_LINUX_PC`, whose
SCL/SDA are None, and `busio.I2C(board.SCL, board.SDA)` then fails (`cannot import name 'i2cPorts'`);
on a terminal, `import board` may also offer to pip-install "missing platform dependencies". Opening
the bus by number works the same on a Raspberry Pi, a Jetson or a PC with a USB-I2C adapter.

Every transfer is one `SMBus.i2c_rdwr` (the kernel's I2C_RDWR: repeated start between messages, one
STOP at the end), so a register read is write-pointer + read in one transaction, as the chips expect.
"""

from __future__ import annotations

import errno
import threading
from typing import Any

#: 7-bit addresses `scan` probes (0x00-0x02 and 0x78-0x7F are reserved by the I2C specification).
SCAN_RANGE = range(0x03, 0x78)
#: Addresses probed with a one-byte read rather than a quick write, as i2cdetect does: a quick write
#: can corrupt an EEPROM's address pointer or lock some write-protected chips.
_READ_PROBED = (range(0x30, 0x38), range(0x50, 0x60))

_MISSING = "smbus2 is not installed: pip install 'nutty[pca9685]'"


def buffer_window(buffer: Any, start: int, end: int | None) -> memoryview:
    """buffer[start:end] as bytes, without a copy: how busio.I2C's methods take their buffers."""
    view = memoryview(buffer).cast("B")
    return view[start : len(view) if end is None else end]


class SMBusI2C:
    """/dev/i2c-`bus_number` as a `busio.I2C`. `smbus` injects an already-open smbus2-like object (for
    tests or another adapter); otherwise smbus2.SMBus(bus_number) is opened (OSError if it cannot be:
    no such bus, or no permission)."""

    def __init__(self, bus_number: int, *, smbus: Any = None):
        self.bus_number = bus_number
        try:
            # lazy: smbus2 is an optional extra, and the default install must still import this module
            from smbus2 import SMBus, i2c_msg
        except ImportError as exc:
            raise ImportError(_MISSING) from exc
        self._msg = i2c_msg
        self._bus: Any = smbus if smbus is not None else SMBus(bus_number)
        self._lock = threading.Lock()

    @property
    def _smbus(self) -> Any:
        if self._bus is None:
            raise OSError(errno.EBADF, f"/dev/i2c-{self.bus_number} is closed")
        return self._bus

    def __repr__(self) -> str:
        return f"SMBusI2C(/dev/i2c-{self.bus_number})"

    # -- busio.I2C's locking: the Adafruit drivers take it around each transfer -------------------------
    def try_lock(self) -> bool:
        """Take the bus without waiting; False if another thread holds it."""
        return self._lock.acquire(blocking=False)

    def unlock(self) -> None:
        """Release the bus (only its holder calls this)."""
        self._lock.release()

    # -- transfers ---------------------------------------------------------------------------------------
    def writeto(self, address: int, buffer: Any, *, start: int = 0, end: int | None = None) -> None:
        """Write buffer[start:end] to `address` then STOP; an empty write is a probe (quick write,
        which every adapter supports, where a zero-length I2C_RDWR message is refused by some).
        OSError when the device does not acknowledge."""
        data = bytes(buffer_window(buffer, start, end))
        if not data:
            self._smbus.write_quick(address)
            return
        self._smbus.i2c_rdwr(self._msg.write(address, data))

    def readfrom_into(self, address: int, buffer: Any, *, start: int = 0, end: int | None = None) -> None:
        """Read len(buffer[start:end]) bytes from `address` into that slice; OSError on a NACK."""
        out = buffer_window(buffer, start, end)
        if not len(out):
            return
        msg = self._msg.read(address, len(out))
        self._smbus.i2c_rdwr(msg)
        out[:] = bytes(msg)

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
        """Write buffer_out[out_start:out_end], repeated START, read into buffer_in[in_start:in_end]:
        one transaction (a register read). OSError on a NACK."""
        data = bytes(buffer_window(buffer_out, out_start, out_end))
        into = buffer_window(buffer_in, in_start, in_end)
        read = self._msg.read(address, len(into))
        self._smbus.i2c_rdwr(self._msg.write(address, data), read)
        into[:] = bytes(read)

    def scan(self) -> list[int]:
        """The 7-bit addresses that acknowledge (0x03..0x77), as i2cdetect probes them."""
        found = []
        for address in SCAN_RANGE:
            try:
                if any(address in r for r in _READ_PROBED):
                    self._smbus.read_byte(address)
                else:
                    self._smbus.write_quick(address)
            except OSError:
                continue
            found.append(address)
        return found

    def deinit(self) -> None:
        """Close the bus (idempotent)."""
        bus, self._bus = self._bus, None
        if bus is not None:
            bus.close()

    def __enter__(self) -> SMBusI2C:
        return self

    def __exit__(self, *exc: object) -> None:
        self.deinit()
