"""The clip editor's preview pose: a pose shown on the Pre-Viz robot that the robot itself never takes.

The editor sends the pose at its playhead (`PUT /api/previz/preview`) while a clip is open; the Pre-Viz
shows it on the solid robot, labelled as a preview, with the live robot as the ghost beside it. A preview
is a *lease*: it lapses `LEASE` seconds after the last PUT, so a closed or crashed editor never leaves the
Pre-Viz showing a pose the robot does not have. Nothing here reaches the engine or a driver.

Posing in the Pre-Viz goes the other way: while a preview shows, a click on a link puts a ring on its
joint; turning it changes that joint's DoF (`grab`), which the editor reads back (`state()["grabbed"]`,
with a `revision` that counts the turns) to set its pose sliders.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any

import numpy as np

from backend.engine.blocks.core import pose_vector
from backend.engine.embodiment import DofType, Embodiment
from backend.errors import DomainError

LEASE = 3.0  # s a preview shows after its last refresh
MAX_LABEL = 120


class PosePreview:
    """The preview pose and the Pre-Viz grabs of one server. Thread-safe: routes set it, the Pre-Viz's
    link thread reports grabs."""

    def __init__(self, embodiment: Embodiment, previz: Any = None, lease: float = LEASE):
        self.emb = embodiment
        self.previz = previz  # PreViz or PreVizProcess (both have set_preview), or None
        self.lease = float(lease)
        self._lock = threading.Lock()
        self._values: dict[str, Any] = {}
        self._label = ""
        self._until = 0.0
        self._grabbed: dict[str, float] = {}
        self._revision = 0

    def _vector(self, values: dict[str, Any]) -> np.ndarray:
        """The full channel vector of a pose (rest for the DoFs it leaves out); DomainError naming the
        DoF (`values.<dof>`) when one is unknown or its value does not fit."""
        try:
            return pose_vector(self.emb, values)[0]
        except ValueError:
            for name, value in values.items():
                try:
                    pose_vector(self.emb, {name: value})
                except ValueError as exc:
                    raise DomainError(str(exc), code="invalid_pose", field=f"values.{name}") from exc
            raise

    def show(self, values: dict[str, Any] | None, label: str = "") -> dict[str, Any]:
        """Show `values` ({dof: value}: rad or m, [r, g, b], an option name) on the Pre-Viz for the next
        `lease` seconds, or stop showing a preview (None). Returns {"preview": shown, "expires_in": s}."""
        if values is None:
            with self._lock:
                self._values, self._until, self._grabbed = {}, 0.0, {}
            if self.previz is not None:
                self.previz.set_preview(None, "", 0.0)
            return {"preview": False, "expires_in": 0.0}
        vector = self._vector(values)
        label = str(label)[:MAX_LABEL]
        with self._lock:
            self._values, self._label = dict(values), label
            self._until = time.monotonic() + self.lease
        if self.previz is None:
            return {"preview": False, "expires_in": 0.0}
        self.previz.set_preview(vector, label, self.lease)
        return {"preview": True, "expires_in": self.lease}

    @property
    def active(self) -> bool:
        return time.monotonic() < self._until

    def grab(self, dof: str, value: float) -> float | None:
        """A Pre-Viz turn of `dof`'s joint to `value` (rad or m): clamped to the DoF's limits, recorded
        for the editor. Ignored (None) when no preview shows or the DoF is not a continuous one."""
        if not self.active or not self.emb.has_dof(dof) or not math.isfinite(value):
            return None
        d = self.emb.dof(dof)
        if d.type is not DofType.continuous:
            return None
        value = min(max(float(value), d.min), d.max)
        with self._lock:
            self._grabbed[dof] = value
            self._values[dof] = value
            self._revision += 1
        return value

    def state(self) -> dict[str, Any]:
        """{"active", "label", "values" (the pose shown), "grabbed" ({dof: value} turned in the Pre-Viz
        since the preview began), "revision" (counts the turns)}."""
        with self._lock:
            return {
                "active": self.active,
                "label": self._label if self.active else "",
                "values": dict(self._values) if self.active else {},
                "grabbed": dict(self._grabbed),
                "revision": self._revision,
            }
