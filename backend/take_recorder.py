"""Recording a take: the live motion of chosen DoFs, captured frame by frame and reduced to a clip.

A performer moves the robot (the editor's pose sliders in live mode, the Blender live link, a gamepad:
all through the program's puppet layer) while a `TakeRecorder` — a sink of the engine, so the clock
never waits for it — keeps the chosen DoFs' values of every frame: `source="output"` records what the
motors get (after stage 2 and the safety net), `"program"` the program's frame before the safety net,
`"stage1"` the program's pose before stage 2.

`finish` turns the samples into a `nutty-clip/1` document with the importer's key reduction
(`backend.importers.keys.hermite_keys`: a smooth curve through the samples, dropping every sample the
curve reproduces within `tolerance`), and measures how far the clip strays from the performance (the
compiled clip evaluated at every sample time: `max_error`, rad or m).
"""

from __future__ import annotations

import threading
import time
from typing import Any, Literal

import numpy as np

from backend.engine.clips import CLIP_FORMAT, compile_clip
from backend.engine.embodiment import DofType, Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink
from backend.errors import DomainError
from backend.importers.keys import hermite_keys

REFINE = 6  # halvings of a take's key tolerance (at most 64x finer) to keep its curve within limits
MAX_SECONDS = 600.0  # a take longer than ten minutes stops recording (what was recorded is kept)
QUEUE = 4096  # frames the sink may hold while its thread catches up (4 s at 1 kHz)
Source = Literal["output", "program", "stage1"]


def recordable(emb: Embodiment, dofs: list[str]) -> list[int]:
    """The channel of each DoF a take may record (continuous DoFs), or DomainError naming the field."""
    if not dofs:
        raise DomainError("name at least one DoF to record", code="invalid_take", field="dofs")
    channels = []
    for i, name in enumerate(dofs):
        if not emb.has_dof(name):
            raise DomainError(
                f"robot '{emb.name}' has no DoF '{name}'", code="invalid_take", field=f"dofs.{i}"
            )
        dof = emb.dof(name)
        if dof.type is not DofType.continuous:
            raise DomainError(
                f"DoF '{name}' is a {dof.type.value} DoF: a take records continuous DoFs (joints, symbolic "
                "and spatial DoFs, face parameters)",
                code="invalid_take",
                field=f"dofs.{i}",
            )
        if name in dofs[:i]:
            raise DomainError(f"DoF '{name}' is named twice", code="invalid_take", field=f"dofs.{i}")
        channels.append(dof.channels.start)
    return channels


class TakeRecorder(Sink[AnimationFrame]):
    """Keeps the values of `dofs` (continuous DoFs) from every frame offered, for at most MAX_SECONDS."""

    def __init__(self, emb: Embodiment, dofs: list[str], source: Source = "output"):
        self.emb = emb
        self.dofs = list(dofs)
        self.source = source
        self._columns = np.array(recordable(emb, self.dofs), dtype=int)
        self._times: list[float] = []
        self._values: list[np.ndarray] = []
        self._lock = threading.Lock()
        self.started_at = time.time()
        super().__init__("take-recorder", max_queue=QUEUE, batch=0.02)

    def consume(self, frame: AnimationFrame) -> None:
        pose = {"stage1": frame.stage1, "program": frame.program}.get(self.source)
        pose = frame.position if pose is None else pose
        with self._lock:
            if self._times and frame.t - self._times[0] > MAX_SECONDS:
                return
            self._times.append(float(frame.t))
            self._values.append(pose[self._columns].copy())

    @property
    def samples(self) -> int:
        return len(self._times)

    @property
    def elapsed(self) -> float:
        """Frame time covered so far (s)."""
        with self._lock:
            return self._times[-1] - self._times[0] if len(self._times) > 1 else 0.0

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(times from the first sample (s), values (samples, DoFs))."""
        with self._lock:
            t = np.array(self._times, dtype=float)
            v = np.array(self._values, dtype=float).reshape(len(self._times), len(self.dofs))
        return (t - t[0] if len(t) else t), v

    def finish(self, name: str, tolerance: float, robot: str) -> dict[str, Any]:
        """The take as a clip document and its figures: {"clip", "samples", "keys" ({dof: count}),
        "duration" (s), "max_error" (rad or m: the clip against the recorded samples), "dropped"}."""
        t, v = self.arrays()
        if len(t) < 2 or t[-1] <= 0.0:
            raise DomainError(
                "the take holds fewer than two frames: record for longer", code="empty_take", field="name"
            )
        keep = np.concatenate([[True], np.diff(t) > 1e-9])  # a repeated frame time would stop the keys
        t, v = t[keep], v[keep]
        keyed = {dof: self._keys(dof, t, v[:, i], tolerance) for i, dof in enumerate(self.dofs)}
        tracks = {dof: keys for dof, (keys, _) in keyed.items()}
        doc = {
            "format": CLIP_FORMAT,
            "name": name,
            "robot": robot,
            "description": f"A recorded take of {', '.join(self.dofs)} ({self.source}).",
            "duration": round(float(t[-1]), 6),
            "tracks": tracks,
            "source": {"recorded": self.source, "samples": len(t), "tolerance": tolerance},
        }
        played = np.column_stack([played for _, played in keyed.values()])
        return {
            "clip": doc,
            "samples": len(t),
            "keys": {dof: len(keys) for dof, keys in tracks.items()},
            "duration": float(t[-1]),
            "max_error": float(np.max(np.abs(played - v))),
            "dropped": int(self.dropped),
        }

    def _keys(
        self, name: str, t: np.ndarray, v: np.ndarray, tolerance: float
    ) -> tuple[list[dict[str, Any]], np.ndarray]:
        """Keys of DoF `name`'s samples within `tolerance`, and what the engine plays of them at the
        samples' times. Refined (the tolerance halved, at most REFINE times) while the keyed curve is
        faster, or accelerates or jerks harder, than both the DoF's limit and the performance itself:
        a Hermite curve is smooth in velocity only, so few keys over a motion that rides the limits put
        jerk spikes at the keys that the samples did not have."""
        dof = self.emb.dof(name)
        keys = hermite_keys(t, v, tolerance)
        played = self._played(name, keys, t)
        for _ in range(REFINE if tolerance > 0 else 0):
            if len(keys) >= len(t) or _as_gentle(played, t, v, dof):
                break
            tolerance /= 2
            keys = hermite_keys(t, v, tolerance)
            played = self._played(name, keys, t)
        return keys, played

    def _played(self, name: str, keys: list[dict[str, Any]], t: np.ndarray) -> np.ndarray:
        """The track `keys` of DoF `name` at times `t`, by the engine's playback code."""
        curves = compile_clip({"tracks": {name: keys}}, self.emb).curves
        return np.array([curves.evaluate(float(tj))[0] for tj in t])


def _peaks(x: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """Peak |velocity|, |acceleration|, |jerk| of samples x at steps dt (finite differences, as the
    engine computes its frames' derivatives)."""
    out = []
    for _ in range(3):
        x = np.diff(x) / dt[: len(x) - 1]
        out.append(float(np.max(np.abs(x))) if len(x) else 0.0)
    return np.array(out)


def _as_gentle(played: np.ndarray, t: np.ndarray, v: np.ndarray, dof: Any) -> bool:
    """Whether a keyed curve (`played` at the samples' times `t`) stays within the DoF's velocity,
    acceleration and jerk limits, or else no further over them than the recorded samples `v`."""
    dt = np.diff(t)
    limits = np.array([dof.velocity, dof.acceleration, dof.jerk], dtype=float)
    allowed = np.maximum(limits, _peaks(v, dt)) * (1 + 1e-6)
    return bool(np.all(_peaks(played, dt) <= allowed))
