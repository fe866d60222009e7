"""The importers' data: source channels read from a file (`SourceChannel`, with their rest pose), the
robot DoF(s) each drives (`ChannelMap` of `DofTarget`s), a parsed mapping file (`MappingSpec`), and the
one error an import reports (`ClipImportError`).

These are re-exported by `backend.importers.mapping`, where the importers import them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from backend.importers.rotations import IDENTITY


class ClipImportError(ValueError):
    """A file that cannot be imported (missing, unknown format, malformed, bad data, nothing to map)."""


@dataclass
class SourceChannel:
    """One animated channel of a source file.

    kind: "rotation" (values (N, 4) quaternions x, y, z, w: the node's *local* rotation, as stored),
    "translation" (values (N, 3), local), "scale" or "scalar" (values (N,) numbers, or option names
    for CSV enum columns).
    interp: "STEP", "LINEAR" or "CUBICSPLINE"; for CUBICSPLINE `in_tangents`/`out_tangents` have the
    shape of `values` (derivatives per second, as glTF stores them).
    Rest pose, in the source's world axes: a rotation's change from rest, in world axes, is
    `pre * q * post` (pre: the parent's rest world rotation; post: the inverse of the node's own
    rest world rotation); a translation's is `pre * (p - rest)`.
    unit: how a sample is named in messages ("frame" for BVH, "key" for glTF, "row" for CSV).
    """

    name: str
    kind: str
    times: np.ndarray
    values: Any
    interp: str = "LINEAR"
    in_tangents: np.ndarray | None = None
    out_tangents: np.ndarray | None = None
    path: str = ""  # source path label: rotation, translation, weights[0], column, ...
    decimate: bool = False  # keys may be dropped where linear interpolation reproduces them
    detail: str = ""  # for the report
    pre: np.ndarray = field(default_factory=lambda: IDENTITY.copy())
    post: np.ndarray = field(default_factory=lambda: IDENTITY.copy())
    rest: np.ndarray | None = None  # translation at rest (local)
    unit: str = "key"
    rest_note: str = ""

    @property
    def label(self) -> str:
        return f"{self.name}.{self.path}" if self.path else self.name


@dataclass
class DofTarget:
    """One DoF a channel drives: the rotation about (or translation along) `axis` (robot frame)."""

    dof: str
    axis: np.ndarray | None
    scale: float = 1.0
    offset: float = 0.0
    axis_given: bool = False


@dataclass
class ChannelMap:
    """How one source channel drives one DoF, or several (a rotation split in the listed order)."""

    targets: list[DofTarget]
    how: str = "exact name"
    key: str | None = None  # the mapping file's entry

    @property
    def dof(self) -> str:
        return self.targets[0].dof

    @property
    def axis(self) -> np.ndarray | None:
        return self.targets[0].axis

    @property
    def axes(self) -> list[np.ndarray]:
        """Every target's axis: a rotation or translation channel's targets all have one (resolution
        makes sure of it, `mapping._finish`)."""
        axes = [t.axis for t in self.targets if t.axis is not None]
        if len(axes) != len(self.targets):
            raise ValueError(f"channel map of '{self.dof}': a target has no axis")
        return axes

    @property
    def scale(self) -> float:
        return self.targets[0].scale

    @property
    def offset(self) -> float:
        return self.targets[0].offset


@dataclass
class MappingSpec:
    """A parsed mapping file: source name -> list of entries (None means: ignore the channel)."""

    joints: dict[str, list[dict[str, Any]] | None] = field(default_factory=dict)
    path: str = ""
