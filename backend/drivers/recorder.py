"""A recorder that writes every frame to a JSONL file, replayable by `nutty run`-style tools and the editor.

One JSON object per line: `AnimationFrame.to_dict` (continuous values with derivatives, enum options,
colours, events). `read_recording` loads it back as arrays.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from backend.drivers.registry import DriverOption
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink


class FrameRecorder(Sink[AnimationFrame]):
    option = DriverOption("record", metavar="FILE.jsonl", help="record every frame to a JSONL file")

    def __init__(self, embodiment: Embodiment, path: str | Path, decimate: int = 1):
        self.emb = embodiment
        self.path = Path(path)
        self._fh = self.path.open("w")
        self.frames = 0
        super().__init__(f"recorder:{self.path.name}", max_queue=1024, decimate=decimate, batch=0.01)

    @classmethod
    def from_option(cls, embodiment: Embodiment, path: str) -> FrameRecorder:
        return cls(embodiment, path)

    def consume(self, frame: AnimationFrame) -> None:
        self._fh.write(json.dumps(frame.to_dict(self.emb)) + "\n")
        self.frames += 1

    def close(self, timeout: float = 2.0) -> None:
        super().close(timeout)
        self._fh.close()


def read_recording(path: str | Path) -> tuple[np.ndarray, dict[str, np.ndarray], list[dict]]:
    """(times (T,), {continuous DoF: positions (T,)}, events with their time) from a recording."""
    times, series, events = [], {}, []
    for line in Path(path).read_text().splitlines():
        if not line.strip():
            continue
        doc = json.loads(line)
        times.append(doc["t"])
        for name, v in doc["dofs"].items():
            if "position" in v:
                series.setdefault(name, []).append(v["position"])
        events += [{"t": doc["t"], **e} for e in doc["events"]]
    return np.array(times), {k: np.array(v) for k, v in series.items()}, events
