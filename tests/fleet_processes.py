"""Processes and Zenoh settings for the fleet tests: loopback only, multicast scouting off, so a test
never depends on the network or on another test's engines."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tests.server_process import free_port

LOCAL_ONLY = "{ scouting: { multicast: { enabled: false } } }\n"  # peers found through endpoints only


def local_config(folder: Path) -> str:
    """A Zenoh config file that keeps discovery to the endpoints given on the command line."""
    path = Path(folder) / "zenoh-local.json5"
    path.write_text(LOCAL_ONLY)
    return str(path)


def poll(predicate, timeout: float = 10.0, what: str = "the condition", step: float = 0.05):
    """`predicate()`'s first truthy value, tried every `step` s; AssertionError after `timeout` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(step)
    raise AssertionError(f"not within {timeout:g} s: {what}")


def loopback() -> str:
    return f"tcp/127.0.0.1:{free_port()}"


class NuttyProcess:
    """`python -m backend.cli ARGS` with its output in a file (a chatty process never blocks on a pipe)."""

    def __init__(self, *args: str):
        self.args = args
        self._log = tempfile.TemporaryFile(mode="w+")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "backend.cli", *args],
            stdout=self._log,
            stderr=subprocess.STDOUT,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )

    @property
    def output(self) -> str:
        self._log.flush()
        self._log.seek(0)
        return self._log.read()

    def wait_output(self, text: str, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.output:
                return True
            if self.proc.poll() is not None:
                return text in self.output
            time.sleep(0.2)
        return False

    def signal(self, sig: int) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)

    def wait_exit(self, timeout: float) -> int | None:
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return None

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            if self.wait_exit(15) is None:
                self.proc.kill()
                self.proc.wait(10)
        self._log.close()
