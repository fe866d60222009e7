"""Start a real `nutty serve` on a free port for tests, and stop it (bounded in time, always killed)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from contextlib import contextmanager

from backend.client import NuttyClient


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def running_server(*args: str, start_timeout: float = 120.0):
    """Yield (url, port, client) of a `nutty serve` subprocess started with `args`."""
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "backend.cli", "serve", "--port", str(port), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    url = f"http://127.0.0.1:{port}"
    client = NuttyClient(url, timeout=2.0)
    deadline = time.time() + start_timeout  # generous: a busy machine compiles the NMF kernels at start-up
    try:
        while True:
            try:
                client.status()
                break
            except Exception:
                if proc.poll() is not None or time.time() > deadline:
                    proc.kill()
                    raise RuntimeError(f"nutty serve did not start: {proc.stdout.read() if proc.stdout else ''}")
                time.sleep(0.3)
        yield url, port, client
    finally:
        client.close()
        proc.terminate()
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
