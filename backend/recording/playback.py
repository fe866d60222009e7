"""Recordings read back as frames of one robot, for `nutty play` (backend/commands/play.py).

- an MCAP with `/nutty/channels` (backend/recording/mcap_recorder.py): every channel exactly, and the
  events of `/nutty/events`;
- a foreign MCAP (rosbag2, Foxglove) with only `/joint_states`: the joints that have their own DoF set
  that DoF's channel (the rest stay at rest), resampled to a fixed rate; the joints it could not map
  are named in `Recording.unmapped`;
- a JSON-lines recording (`--record FILE.jsonl`): every DoF by name, and the events.

Errors (`RecordingError`) say what is wrong in words a person can act on: a missing or unreadable
file, a recording of a robot whose channels differ from the chosen robot's (which ones), no frames.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from backend.engine.embodiment import DofType, Embodiment
from backend.engine.frames import FrameEvent

#: The MCAP topics a play reads (backend/recording/mcap_recorder.py writes them).
PLAYED_TOPICS = ("/nutty/channels", "/nutty/events", "/joint_states")
#: Fallback rate (Hz) for a recording with a single frame and no rate of its own.
DEFAULT_RATE = 100.0


class RecordingError(Exception):
    """A recording that cannot be played on the chosen robot; the message says why."""


@dataclass
class Recording:
    """Frames of one robot at a fixed tick `dt` (s): `times` (T,) s from the first frame, `positions`
    (T, C) every channel, `events` per frame. `source` says what they were rebuilt from (`channels`,
    `joint_states` or `jsonl`); `unmapped` the recorded joints without a DoF of their own."""

    path: Path
    source: str
    dt: float
    times: np.ndarray
    positions: np.ndarray
    events: list[list[FrameEvent]]
    robot: str | None = None
    unmapped: list[str] = field(default_factory=list)

    @property
    def duration(self) -> float:
        """Seconds from the first frame to the end of the last one."""
        return float(self.times[-1]) + self.dt if len(self.times) else 0.0


def read_recording(path: str | Path, emb: Embodiment) -> Recording:
    """The recording at `path` (.mcap or .jsonl) as frames of `emb`; RecordingError when it cannot be."""
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"no recording at '{path}'")
    suffix = path.suffix.lower()
    if suffix == ".jsonl":
        rec = _read_jsonl(path, emb)
    elif suffix == ".mcap":
        rec = _read_mcap(path, emb)
    else:
        raise RecordingError(f"'{path}' is not a recording: expected FILE.mcap or FILE.jsonl")
    if not len(rec.times):
        raise RecordingError(f"'{path}' holds no frames")
    return _fill_gaps(rec, emb)


def _fill_gaps(rec: Recording, emb: Embodiment) -> Recording:
    """The recording on its regular tick grid: frames a recorder dropped (a gap of several ticks) are
    filled in, continuous channels linearly and the others holding their last value, so the player's
    one-frame-per-tick keeps the recording's own times."""
    ticks = np.round(rec.times / rec.dt).astype(np.int64)
    if len(ticks) < 2 or ticks[-1] == len(ticks) - 1 or np.any(np.diff(ticks) < 1):
        return rec
    grid = np.arange(ticks[-1] + 1)
    held = np.searchsorted(ticks, grid, side="right") - 1  # the last recorded frame at or before each tick
    positions = rec.positions[held]
    for c in np.flatnonzero(emb.continuous_mask):  # per channel once at load time, not per tick
        positions[:, c] = np.interp(grid, ticks, rec.positions[:, c])
    events: list[list[FrameEvent]] = [[] for _ in grid]
    for k, tick in enumerate(ticks):
        events[tick] = rec.events[k]
    rec.times, rec.positions, rec.events = grid * rec.dt, positions, events
    return rec


def _regular_dt(times: np.ndarray, rate: float | None = None) -> float:
    """The tick (s): the recording's own rate when it says, else the median step between frames."""
    if rate:
        return 1.0 / rate
    steps = np.diff(times)
    steps = steps[steps > 0]
    return float(np.median(steps)) if len(steps) else 1.0 / DEFAULT_RATE


# --- JSON lines ------------------------------------------------------------------------------------


def _read_jsonl(path: Path, emb: Embodiment) -> Recording:
    try:
        docs = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RecordingError(f"'{path}' is not a readable JSON-lines recording: {exc}") from None
    if not docs:
        raise RecordingError(f"'{path}' holds no frames")
    try:
        return _frames_from_docs(path, docs, emb)
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise RecordingError(f"'{path}' is not a frame recording (a line lacks {exc})") from None


def _frames_from_docs(path: Path, docs: list[dict[str, Any]], emb: Embodiment) -> Recording:
    names = {d.name for d in emb.dofs if d.type is not DofType.event}
    recorded = set(docs[0]["dofs"])
    if recorded != names:
        raise RecordingError(_mismatch(path, docs[0].get("embodiment"), emb, recorded, names))
    positions = np.tile(emb.rest, (len(docs), 1))
    for d in emb.dofs:  # one pass per DoF over all frames, not per frame
        if d.type is DofType.event:
            continue
        col = [doc["dofs"][d.name] for doc in docs]
        sl = d.channels
        if d.type is DofType.continuous:
            positions[:, sl.start] = [v["position"] for v in col]
        elif d.type is DofType.enum:
            positions[:, sl.start] = [v["index"] for v in col]
        elif d.type is DofType.colour:
            positions[:, sl] = [v["rgb"] for v in col]
    times = np.array([doc["t"] for doc in docs], dtype=float)
    events = [
        [FrameEvent(e["dof"], e["kind"], dict(e.get("payload", {}))) for e in doc["events"]] for doc in docs
    ]
    dt = float(docs[0].get("dt") or _regular_dt(times))
    return Recording(path, "jsonl", dt, times - times[0], positions, events, robot=docs[0].get("embodiment"))


def _mismatch(path: Path, robot: str | None, emb: Embodiment, recorded: set[str], names: set[str]) -> str:
    """Which channels (or DoFs) a recording has that the robot lacks, and the other way round."""
    parts = []
    if missing := sorted(names - recorded):
        parts.append(f"the recording lacks {', '.join(missing)}")
    if extra := sorted(recorded - names):
        parts.append(f"the robot has no {', '.join(extra)}")
    if not parts:
        parts.append("the channels are in another order")
    of = f" of robot '{robot}'" if robot else ""
    return f"'{path}' is a recording{of} whose channels differ from robot '{emb.name}': {'; '.join(parts)}"


# --- MCAP ------------------------------------------------------------------------------------------


def _read_mcap(path: Path, emb: Embodiment) -> Recording:
    try:
        # lazy: the optional 'mcap' extra (mcap, rosbags), needed only for .mcap files
        from mcap.exceptions import McapError
        from mcap.reader import make_reader
        from rosbags.serde import SerdeError

        from backend.ros2 import cdr  # lazy: needs rosbags, as above
    except ImportError as exc:
        raise RecordingError(
            f"reading .mcap needs the 'mcap' extra (pip install -e '.[mcap]'): {exc}"
        ) from None
    try:
        with path.open("rb") as fh:
            meta = {m.name: dict(m.metadata) for m in make_reader(fh).iter_metadata()}
            fh.seek(0)
            by_topic: dict[str, list[tuple[int, Any]]] = {}
            for schema, channel, message in make_reader(fh).iter_messages(topics=list(PLAYED_TOPICS)):
                if channel.message_encoding == "cdr" and schema is not None:
                    decoded = cdr.decode(message.data, schema.name)
                    by_topic.setdefault(channel.topic, []).append((message.log_time, decoded))
    except (McapError, SerdeError, OSError, ValueError, KeyError, IndexError, struct.error) as exc:
        # KeyError: a type rosbags does not know; struct.error, IndexError: CDR shorter than its type
        raise RecordingError(
            f"'{path}' is not a readable MCAP recording: {type(exc).__name__}: {exc}"
        ) from None
    nutty = meta.get("nutty", {})
    rate = float(nutty["rate"]) if nutty.get("rate") else None
    if "/nutty/channels" in by_topic:
        return _from_channels(path, emb, by_topic, nutty.get("embodiment"), rate)
    if "/joint_states" in by_topic:
        return _from_joint_states(path, emb, by_topic["/joint_states"])
    raise RecordingError(f"'{path}' has neither /nutty/channels nor /joint_states: nothing to play")


def _from_channels(
    path: Path,
    emb: Embodiment,
    by_topic: dict[str, list[tuple[int, Any]]],
    robot: str | None,
    rate: float | None,
) -> Recording:
    msgs = sorted(by_topic["/nutty/channels"], key=lambda m: m[0])
    labels = [d.label for d in msgs[0][1].layout.dim]
    if labels != list(emb.channel_names):
        raise RecordingError(_mismatch(path, robot, emb, set(labels), set(emb.channel_names)))
    stamps = np.array([m[0] for m in msgs], dtype=np.int64)
    positions = np.stack([np.asarray(m[1].data, dtype=float) for m in msgs])
    index = {int(ns): k for k, ns in enumerate(stamps)}
    events: list[list[FrameEvent]] = [[] for _ in msgs]
    for ns, msg in by_topic.get("/nutty/events", []):
        k = index.get(int(ns))
        if k is None:
            continue  # an event whose frame was not recorded (dropped): nowhere to play it
        e = json.loads(msg.data)
        events[k].append(FrameEvent(e["dof"], e["kind"], dict(e.get("payload", {}))))
    times = (stamps - stamps[0]) / 1e9
    return Recording(path, "channels", _regular_dt(times, rate), times, positions, events, robot=robot)


def _from_joint_states(path: Path, emb: Embodiment, msgs: list[tuple[int, Any]]) -> Recording:
    """Frames from a foreign bag's joint states: each joint with its own DoF drives that DoF's channel
    (so that the joint composes to the recorded value with every other channel at rest), resampled at
    the bag's median rate."""
    from backend.engine.joint_net import JointLimits  # lazy: only foreign bags need the joint map

    own = JointLimits(emb, emb.continuous_mask).own
    index = {name: j for j, name in enumerate(emb.joint_names)}
    msgs = sorted(msgs, key=lambda m: _stamp_ns(m))
    names = list(msgs[0][1].name)
    mapped = [(k, index[n]) for k, n in enumerate(names) if n in index and own[index[n]] >= 0]
    unmapped = [n for n in names if n not in index or own[index[n]] < 0]
    if not mapped:
        raise RecordingError(
            f"'{path}': none of the recorded joints ({', '.join(names)}) is a joint of robot '{emb.name}' "
            "with a DoF of its own"
        )
    cols = np.array([k for k, _ in mapped])
    joints = np.array([j for _, j in mapped])
    # only the messages naming the same joints with a position for each (a bag may mix publishers)
    usable = [m for m in msgs if list(m[1].name) == names and len(m[1].position) == len(names)]
    if not usable:
        raise RecordingError(f"'{path}': no /joint_states message has a position for each of its joints")
    q = np.stack([np.asarray(m[1].position, dtype=float) for m in usable])[:, cols]  # (T, mapped joints)
    times = np.array([_stamp_ns(m) for m in usable], dtype=np.int64)
    times = (times - times[0]) / 1e9
    dt = _regular_dt(times)
    grid = np.arange(0.0, times[-1] + dt / 2, dt)
    channels = own[joints]
    # channel = rest + (joint - joint at rest) / coefficient: the joint composes to the recorded value.
    q_rest = emb.joint_positions(emb.rest)[joints]
    coef = emb.joint_matrix[joints, channels]
    positions = np.tile(emb.rest, (len(grid), 1))
    for c, (ch, jq) in enumerate(zip(channels, q.T, strict=True)):  # per joint at load time, not per tick
        positions[:, ch] = emb.rest[ch] + (np.interp(grid, times, jq) - q_rest[c]) / coef[c]
    events: list[list[FrameEvent]] = [[] for _ in grid]
    return Recording(path, "joint_states", dt, grid, positions, events, unmapped=unmapped)


def _stamp_ns(message: tuple[int, Any]) -> int:
    """A joint state's header stamp (ns), or its log time when the header has none."""
    stamp = message[1].header.stamp
    ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
    return ns if ns else int(message[0])
