"""The Blender add-on's ghost and Check limits as a user meets them: the first POST /api/filter and
/api/analyze (a bundled clip, at 24 fps, computed at the engine's rate) right after `nutty serve`
answers, with numba's cache empty (cold: every kernel compiles, as on a fresh install) and filled.
The peer is the same request once everything is compiled, measured in the same run; the goal is a
first answer within 3 s on a cold cache.

    .venv/bin/python benchmarks/bench_previews.py
"""

from __future__ import annotations

import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import httpx
from results import headline, recorded
from served import ROOT, Server

CLIP = json.loads((ROOT / "robots" / "nutty_desk" / "clips" / "wave.json").read_text())
ROUTES = ("/api/filter", "/api/analyze")


def _timed(url: str, route: str) -> float:
    start = time.perf_counter()
    r = httpx.post(f"{url}{route}", json={"rate": 24, "clip": CLIP}, timeout=120.0)
    r.raise_for_status()
    return time.perf_counter() - start


def first_answers(cache_dir: str) -> tuple[dict[str, float], dict[str, float]]:
    """({route: s of its first answer}, {route: median s of 5 later ones}) on a fresh server."""
    server = Server("--no-previz", env={"NUMBA_CACHE_DIR": cache_dir})
    try:
        server.wait_ready()
        first = {route: _timed(server.url, route) for route in ROUTES}
        warm = {route: statistics.median(_timed(server.url, route) for _ in range(5)) for route in ROUTES}
        return first, warm
    finally:
        server.close()


def main() -> None:
    with tempfile.TemporaryDirectory() as cache:
        for label in ("cold cache", "warm cache"):
            first, warm = first_answers(cache)
            for route in ROUTES:
                print(
                    f"{label:10}  {route:13}  first {first[route] * 1000:7.0f} ms   "
                    f"warm {warm[route] * 1000:6.1f} ms   first / warm {first[route] / warm[route]:6.1f}x"
                )
                if label == "warm cache":
                    headline(
                        f"{route} after `nutty serve` starts: first answer {first[route] * 1000:.0f} ms, "
                        f"then {warm[route] * 1000:.1f} ms"
                    )


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    with recorded("bench_previews", "Ghost and Check limits: the first answers after `nutty serve` starts"):
        main()
