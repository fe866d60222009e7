"""A plain `nutty serve --no-previz` (no clients) measured over a window: /api/status after `seconds`,
the profile reset when the window opens and the clock's overruns counted within it
(`overruns_in_window`). For benchmarks that compare the served clock with and without a driver."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx
from bench_fleet import free_port

ROOT = Path(__file__).resolve().parents[1]


def served_status(extra: list[str], seconds: float, warmup: float) -> dict[str, Any]:
    """/api/status of `nutty serve --no-previz *extra` after `warmup` + `seconds` s."""
    port = free_port()
    cmd = [sys.executable, "-m", "backend.cli", "serve", "--no-previz", "--port", str(port), *extra]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.time() + 120
        while True:
            try:
                if httpx.get(f"{url}/api/status", timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                if time.time() > deadline:
                    raise
            time.sleep(0.2)
        time.sleep(warmup)
        httpx.delete(f"{url}/api/profile", timeout=5)
        before = httpx.get(f"{url}/api/status", timeout=5).json()
        time.sleep(seconds)
        after = httpx.get(f"{url}/api/status", timeout=5).json()
        after["overruns_in_window"] = after["overruns"] - before["overruns"]
        return after
    finally:
        proc.terminate()
        proc.wait(20)
