"""Per-node cook times: how long each block of a running program takes per tick, measured by the APU.

Timing every block on every tick would cost two clock reads per block per tick, and a timed tick runs
the blocks' own ticks one by one instead of the compiled core (backend/engine/core): the APU times one
tick in `every` (`sample_every(rate)`: 1 in 10, and at most 10 per second at higher rates) and the
other ticks run the untimed path. The last `window` sampled ticks are kept per node (a ring of
nanosecond counts) and summarised on demand, off the clock thread, as mean / p99 / max in µs.

The summary (`CookTimes.summary`) is what `GET /api/profile`, the `profile` field of `/ws/telemetry`
messages and `nutty run --profile` show (shape: `backend.api_types.Profile`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Ticks between two timed ticks at most (1 = every tick, what `nutty run --profile` uses).
SAMPLE_EVERY = 10
#: Timed ticks per second at most: a timed tick costs about the core-off tick (1.3-1.6x the core's on
#: the interactive program), so at 500 Hz one in 10 added ~5 % to the clock's mean load for a
#: panel that refreshes a few times a second.
SAMPLES_PER_SECOND = 10.0
#: Timed ticks kept per node: 30 s with the default sampling.
WINDOW = 300


def sample_every(rate: float) -> int:
    """Ticks between two timed ticks at `rate` Hz by default: 10, or more above 100 Hz."""
    return max(SAMPLE_EVERY, round(rate / SAMPLES_PER_SECOND))


class CookTimes:
    """A ring of per-node cook times (ns) for the `n` steps of one APU.

    `record(row)` is called by the clock thread with one timed tick's costs (int64 ns per step, plus
    the whole APU tick in the last column); `summary` may be called from any thread (it reads a copy,
    so a row being written at that moment at worst mixes two ticks' samples).
    """

    def __init__(
        self, node_ids: list[str], types: list[str], every: int = SAMPLE_EVERY, window: int = WINDOW
    ):
        if every < 1 or window < 1:
            raise ValueError("every and window must be >= 1")
        self.node_ids, self.types = list(node_ids), list(types)
        self.every, self.window = int(every), int(window)
        self._ring = np.zeros((self.window, len(node_ids) + 1), dtype=np.int64)
        self.row = np.zeros(len(node_ids) + 1, dtype=np.int64)  # the clock thread fills this, then records it
        self.samples = 0  # timed ticks recorded since the start (or the last reset)

    def record(self) -> None:
        """Keep `self.row` (just filled by a timed tick) in the ring."""
        self._ring[self.samples % self.window] = self.row
        self.samples += 1

    def reset(self) -> None:
        """Forget every sample (a new measurement window starts)."""
        self.samples = 0

    def summary(self) -> dict[str, Any]:
        """Mean, p50, p99 and max cook time (µs) per node over the window, the nodes in the program's
        tick order, and the whole APU tick's figures; `share` is each node's part of the mean APU tick
        (0..1). The mean includes the rare ticks the OS interrupts; p50 is the typical cost."""
        n = min(self.samples, self.window)
        out: dict[str, Any] = {"every": self.every, "window": self.window, "samples": n}
        if n == 0:
            out["apu"] = {"mean_us": 0.0, "p50_us": 0.0, "p99_us": 0.0, "max_us": 0.0}
            out["nodes"] = [
                {
                    "node": i,
                    "type": t,
                    "mean_us": 0.0,
                    "p50_us": 0.0,
                    "p99_us": 0.0,
                    "max_us": 0.0,
                    "share": 0.0,
                }
                for i, t in zip(self.node_ids, self.types)
            ]
            return out
        us = self._ring[:n].astype(float) * 1e-3
        mean, top = us.mean(axis=0), us.max(axis=0)
        p50, p99 = np.percentile(us, [50, 99], axis=0)
        total = float(mean[-1]) or 1.0
        out["apu"] = {
            "mean_us": float(mean[-1]),
            "p50_us": float(p50[-1]),
            "p99_us": float(p99[-1]),
            "max_us": float(top[-1]),
        }
        out["nodes"] = [
            {
                "node": node,
                "type": kind,
                "mean_us": float(mean[k]),
                "p50_us": float(p50[k]),
                "p99_us": float(p99[k]),
                "max_us": float(top[k]),
                "share": float(mean[k]) / total,
            }
            for k, (node, kind) in enumerate(zip(self.node_ids, self.types))
        ]
        return out


def format_table(summary: dict[str, Any]) -> str:
    """The summary as a text table, the most expensive node (by mean) first: what `nutty run --profile`
    prints."""
    nodes = sorted(summary["nodes"], key=lambda r: -r["mean_us"])
    width = max([len(r["node"]) for r in nodes] + [8])
    kind = max([len(r["type"]) for r in nodes] + [4])
    cols = ("mean_us", "p50_us", "p99_us", "max_us")
    lines = [
        f"{'node':<{width}}  {'type':<{kind}}  "
        + "  ".join(f"{c[:-3] + ' µs':>9}" for c in cols)
        + f"  {'share':>6}"
    ]
    for r in nodes:
        lines.append(
            f"{r['node']:<{width}}  {r['type']:<{kind}}  "
            + "  ".join(f"{r[c]:>9.1f}" for c in cols)
            + f"  {100 * r['share']:>5.1f}%"
        )
    apu = summary["apu"]
    lines.append(
        f"{'APU tick':<{width}}  {'':<{kind}}  "
        + "  ".join(f"{apu[c]:>9.1f}" for c in cols)
        + f"  ({summary['samples']} timed ticks, 1 in {summary['every']})"
    )
    return "\n".join(lines)
