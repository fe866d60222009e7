"""The parts of a robot's embodiment: DoFs (dimension, type, channels, limits, rest) and the URDF
joints they drive, with the documented defaults for limits a URDF does not give.

Units: positions in rad (revolute joints, rotation axes) or m (prismatic joints, linear axes);
display channels unitless (colours in [0, 1], enum indices); limits per s, s² and s³.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum, StrEnum
from typing import Any

# Documented defaults used when a URDF (or embodiment.yaml) gives no acceleration/jerk limit:
#   acceleration = ACC_PER_VEL * velocity limit   [1/s]
#   jerk         = JERK_PER_ACC * acceleration limit [1/s]
ACC_PER_VEL = 4.0
JERK_PER_ACC = 10.0
# Velocity used when a URDF joint declares none (rad/s for revolute, m/s for prismatic).
DEFAULT_VELOCITY = {"revolute": 2.0, "continuous": 2.0, "prismatic": 0.5}
# Limits of display channels: colours live in [0, 1]; changes are allowed to be fast but finite.
COLOUR_VELOCITY, COLOUR_ACCELERATION, COLOUR_JERK = 20.0, 400.0, 20000.0


class Dimension(StrEnum):
    stationary = "stationary"
    spatial = "spatial"
    display = "display"
    audible = "audible"


class DofType(StrEnum):
    continuous = "continuous"  # one float channel: a position (rad, m, or unitless for display)
    enum = "enum"  # one channel holding an index into `options`
    colour = "colour"  # three channels r, g, b in [0, 1]
    event = "event"  # no channel; carries payloads (speech text, sound clip names)


class ChannelKind(int, Enum):
    continuous = 0
    enum = 1
    colour = 2


SPATIAL_AXES = ("x", "y", "z", "yaw", "pitch", "roll")


class EmbodimentError(ValueError):
    """An embodiment (URDF or embodiment.yaml) is inconsistent; the message says where and why."""


@dataclass(frozen=True)
class Dof:
    """One DoF of the embodiment, as resolved from the URDF and embodiment.yaml."""

    name: str
    dimension: Dimension
    type: DofType
    channels: slice  # channels of this DoF in frame vectors (empty for events)
    min: float
    max: float
    velocity: float
    acceleration: float
    jerk: float
    rest: float | tuple[float, ...]
    joint: str | None = None  # real URDF joint (stationary)
    drives: dict[str, float] | None = None  # symbolic DoF: joint -> coefficient
    axis: str | None = None  # spatial axis
    group: str | None = None
    options: tuple[str, ...] | None = None
    links: tuple[str, ...] = ()
    kind: str | None = None  # audible: speech | sound
    sounds: tuple[str, ...] = ()
    description: str = ""

    @property
    def symbolic(self) -> bool:
        return self.drives is not None

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly description (used by `nutty embodiment --json` and the API)."""
        d: dict[str, Any] = {
            "name": self.name,
            "dimension": self.dimension.value,
            "type": self.type.value,
            "min": _json_float(self.min),
            "max": _json_float(self.max),
            "velocity": _json_float(self.velocity),
            "acceleration": _json_float(self.acceleration),
            "jerk": _json_float(self.jerk),
            "rest": list(self.rest) if isinstance(self.rest, tuple) else _json_float(self.rest),
            "channels": [self.channels.start, self.channels.stop],
        }
        if self.joint is not None:
            d["joint"] = self.joint
        if self.drives is not None:
            d["drives"] = dict(self.drives)
        if self.axis is not None:
            d["axis"] = self.axis
        if self.group is not None:
            d["group"] = self.group
        if self.options is not None:
            d["options"] = list(self.options)
        if self.links:
            d["links"] = list(self.links)
        if self.kind is not None:
            d["kind"] = self.kind
        if self.sounds:
            d["sounds"] = list(self.sounds)
        if self.description:
            d["description"] = self.description
        return d


def _json_float(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


@dataclass
class UrdfJoint:
    """What the engine needs of one actuated URDF joint."""

    name: str
    type: str
    lower: float
    upper: float
    velocity: float
    child: str = ""
