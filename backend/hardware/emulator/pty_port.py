"""A pseudo-terminal pair for a serial-bus emulator: the driver opens `path` (the slave) like a USB
adapter; the emulator reads and writes the master end on its own thread."""

from __future__ import annotations

import contextlib
import os
import pty
import select
import threading
import tty
from collections.abc import Callable
from typing import Self


class PtyPort:
    """Open a pty in raw mode and call `on_bytes(data)` for every chunk the driver writes; `send(data)`
    writes to the driver. `path` is what a driver opens. Close with `close()` (or use as a context)."""

    def __init__(self, on_bytes: Callable[[bytes], None], name: str = "servo-bus"):
        self.master, self.slave = pty.openpty()
        tty.setraw(self.master)
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self._on_bytes = on_bytes
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._loop, name=f"emulator-{name}", daemon=True)

    def start(self) -> PtyPort:
        self._thread.start()
        return self

    def send(self, data: bytes) -> None:
        if not self._closed.is_set():
            os.write(self.master, data)

    def _loop(self) -> None:
        while not self._closed.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.05)
            if not ready:
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:  # the other end went away: the emulator stops
                return
            if data:
                self._on_bytes(data)

    def close(self) -> None:
        if self._closed.is_set():
            return
        self._closed.set()
        if self._thread.is_alive():
            self._thread.join(1.0)
        for fd in (self.master, self.slave):
            with contextlib.suppress(OSError):  # already closed
                os.close(fd)

    def __enter__(self) -> PtyPort:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()


class OnPty:
    """What a serial-bus emulator listening on a `PtyPort` (its `_port`) offers for its lifetime: the
    `path` a driver opens, `start`, `close`, and use as a context."""

    _port: PtyPort

    @property
    def path(self) -> str:
        """The serial device a driver opens (the pty's slave end)."""
        return self._port.path

    def start(self) -> Self:
        self._port.start()
        return self

    def close(self) -> None:
        self._port.close()

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
