"""A recorder that writes every frame to a JSONL file, replayable by `nutty run`-style tools and the editor.

One JSON object per line: `AnimationFrame.to_dict` (continuous values with derivatives, enum options,
colours, events). `read_recording` loads it back as arrays. `--record FILE.mcap` makes a rosbag2-style
MCAP recorder instead (backend/recording/mcap_recorder.py); any other suffix is refused at parse time.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
from pathlib import Path

import numpy as np

from backend.drivers.registry import DriverOption
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink

SUFFIXES = (".jsonl", ".mcap")


def recording_path(text: str) -> str:
    """The --record value: a path ending in .jsonl or .mcap (the latter needs the 'mcap' extra)."""
    suffix = Path(text).suffix.lower()
    if suffix not in SUFFIXES:
        raise argparse.ArgumentTypeError(
            f"a recording is FILE.jsonl (JSON lines) or FILE.mcap (ROS 2 / MCAP), got '{text}'"
        )
    if suffix == ".mcap" and importlib.util.find_spec("mcap") is None:
        raise argparse.ArgumentTypeError(
            "recording to .mcap needs the 'mcap' extra: pip install -e '.[mcap]' (mcap, rosbags)"
        )
    return text


class FrameRecorder(Sink[AnimationFrame]):
    option = DriverOption(
        "record",
        metavar="FILE.jsonl|FILE.mcap",
        help="record every frame: JSON lines (.jsonl) or a rosbag2-compatible MCAP (.mcap: "
        "/joint_states, /tf, /robot_description, /nutty/events, /nutty/channels)",
        parse=recording_path,
    )

    def __init__(self, embodiment: Embodiment, path: str | Path, decimate: int = 1):
        self.emb = embodiment
        self.path = Path(path)
        self._fh = self.path.open("w")
        self.frames = 0
        super().__init__(f"recorder:{self.path.name}", max_queue=1024, decimate=decimate, batch=0.01)

    @classmethod
    def from_option(cls, embodiment: Embodiment, path: str) -> Sink[AnimationFrame]:
        """The JSONL recorder, or the MCAP one for a path ending in .mcap."""
        if Path(path).suffix.lower() == ".mcap":
            from backend.recording.mcap_recorder import McapRecorder  # lazy: the optional 'mcap' extra

            return McapRecorder(embodiment, path)
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
