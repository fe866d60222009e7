"""A compiled entry point loaded once per process on a thread of its own, for code the clock calls
every tick but can do without until it is there (it runs a slower path meanwhile).

Loading a kernel from numba's cache takes tens of milliseconds (its compilation, on a fresh clone,
seconds): no start waits for it and no tick pays for it.
"""

from __future__ import annotations

import logging
from typing import Any

from backend.engine.compiled import entry_point
from backend.engine.warm_up import OnceInBackground

log = logging.getLogger(__name__)


class LazyEntry:
    """`entry` is the machine-code entry of `dispatcher` for `signature` once loaded (else None)."""

    def __init__(self, dispatcher: Any, signature: tuple, what: str):
        self.dispatcher, self.signature, self.what = dispatcher, signature, what
        self.entry: Any = None
        self._loading = OnceInBackground(self._load, f"nutty-load-{what}")

    def start(self) -> None:
        """Start loading (once)."""
        self._loading.start()

    def _load(self) -> None:
        try:
            self.entry = entry_point(self.dispatcher, self.signature)
        except Exception:  # the slower path goes on: a kernel is a speed-up, never a requirement
            log.exception("%s did not load; its slower path stays in use", self.what)

    def wait(self, timeout: float | None = None) -> bool:
        """Start loading if need be and wait; whether the entry is there."""
        self._loading.wait(timeout)
        return self.entry is not None


class LoadOnSecondAsk:
    """Whether `lazy` is there, for one owner that asks once a tick: its second ask starts the loading.
    An owner that is only checked, never ticked, never loads it, and the loading thread's claim on the
    interpreter lock never delays a first frame (90 ms measured on nutty_desk)."""

    def __init__(self, lazy: LazyEntry):
        self.lazy = lazy
        self.asked = 0  # asks before the entry loaded

    def ready(self) -> bool:
        if self.lazy.entry is not None:
            return True
        self.asked += 1
        if self.asked > 1:
            self.lazy.start()
        return False
