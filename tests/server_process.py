"""Start a real `nutty serve` on a free port for tests, and stop it (bounded in time, always killed)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from contextlib import contextmanager

from backend.client import NuttyClient


def stop_process(proc: subprocess.Popen) -> None:
    """Terminate a child process, and kill it if it has not exited within 15 s."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def running_server(*args: str, start_timeout: float = 120.0):
    """Yield (url, port, client) of a `nutty serve` subprocess started with `args`."""
    with running_server_proc(*args, start_timeout=start_timeout) as server:
        yield server.url, server.port, server.client


class ServerProcess:
    """A started `nutty serve` subprocess whose output is read continuously (a full pipe never blocks
    the server), for tests that signal it and wait for its exit."""

    def __init__(self, args: tuple[str, ...], port: int):
        import threading

        self.port = port
        self.url = f"http://127.0.0.1:{port}"
        self.ws_url = f"ws://127.0.0.1:{port}"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "backend.cli", "serve", "--port", str(port), *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self.client = NuttyClient(self.url, timeout=2.0)

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)

    @property
    def output(self) -> str:
        return "".join(self.lines)

    def wait_ready(self, timeout: float = 120.0) -> None:
        deadline = time.time() + timeout  # generous: a busy machine compiles the NMF kernels at start-up
        while True:
            try:
                self.client.status()
                return
            except Exception:
                if self.proc.poll() is not None or time.time() > deadline:
                    self.kill()
                    raise RuntimeError(f"nutty serve did not start: {self.output}") from None
                time.sleep(0.3)

    def signal(self, sig: int) -> None:
        self.proc.send_signal(sig)

    def wait_exit(self, timeout: float) -> bool:
        """Whether the process exits within `timeout` seconds (its output is then read to the end)."""
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return False
        self._reader.join(5)
        return True

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10)

    def close(self) -> None:
        self.client.close()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.kill()
        self._reader.join(5)


@contextmanager
def server_process(*args: str, start_timeout: float = 120.0):
    """Yield a ready `ServerProcess` running `nutty serve --port <free> *args`; always stopped after."""
    server = ServerProcess(args, free_port())
    try:
        server.wait_ready(start_timeout)
        yield server
    finally:
        server.close()


@contextmanager
def running_server_proc(*args: str, start_timeout: float = 120.0):
    """Like `running_server`, but yield a namespace with `url`, `port`, `client` and `proc` (the
    subprocess, e.g. for its pid: the sockets it listens on, its thread count)."""
    import tempfile
    from types import SimpleNamespace

    port = free_port()
    log = tempfile.TemporaryFile(mode="w+")  # a file, not a pipe: a chatty server never blocks on it
    proc = subprocess.Popen(
        [sys.executable, "-m", "backend.cli", "serve", "--port", str(port), *args],
        stdout=log,
        stderr=subprocess.STDOUT,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    url = f"http://127.0.0.1:{port}"
    client = NuttyClient(url, timeout=5.0)
    deadline = time.time() + start_timeout
    try:
        while True:
            try:
                client.status()
                break
            except Exception:
                if proc.poll() is not None or time.time() > deadline:
                    proc.kill()
                    proc.wait(10)
                    log.seek(0)
                    raise RuntimeError(
                        f"nutty serve {' '.join(args)} did not start: {log.read()[-4000:]}"
                    ) from None
                time.sleep(0.3)
        yield SimpleNamespace(url=url, port=port, client=client, proc=proc)
    finally:
        client.close()
        stop_process(proc)
        log.close()


@contextmanager
def running_app(
    app,
    *,
    port: int | None = None,
    timeout_graceful_shutdown: float | None = 30.0,
    start_timeout: float = 60.0,
):
    """Serve an ASGI `app` (e.g. `backend.api.create_app(...)`) with a real uvicorn on `port` (default:
    a free one) in a thread, in this process; yield (server, thread, port). Stopped (bounded) afterwards."""
    import threading

    import uvicorn

    port = port or free_port()
    server = uvicorn.Server(
        uvicorn.Config(
            app,
            host="127.0.0.1",
            port=port,
            log_level="warning",
            timeout_graceful_shutdown=timeout_graceful_shutdown,
        )
    )
    thread = threading.Thread(target=server.run, name=f"uvicorn-{port}", daemon=True)
    thread.start()
    deadline = time.time() + start_timeout
    while not server.started:
        if not thread.is_alive() or time.time() > deadline:
            raise RuntimeError("uvicorn did not start")
        time.sleep(0.02)
    try:
        yield server, thread, port
    finally:
        server.should_exit = True
        thread.join(30)
