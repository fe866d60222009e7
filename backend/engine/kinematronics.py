"""Kinematronics: the schema of `embodiment.yaml` and how it (or a bare URDF) becomes the robot's
DoFs, each with its channels, limits and rest value.

Limits a file does not give get documented defaults: a URDF joint's position and velocity limits
(a symbolic DoF: what its joints allow for its coefficients), acceleration = ACC_PER_VEL x velocity,
jerk = JERK_PER_ACC x acceleration; base axes 1 m / pi rad and 0.3 m/s / 1 rad/s; colours in [0, 1]
at COLOUR_VELOCITY/ACCELERATION/JERK. Errors say where (`stationary[2] 'neck'`) and why.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from backend.engine.dofs import (
    ACC_PER_VEL,
    COLOUR_ACCELERATION,
    COLOUR_JERK,
    COLOUR_VELOCITY,
    DEFAULT_VELOCITY,
    JERK_PER_ACC,
    Dimension,
    Dof,
    DofType,
    EmbodimentError,
    UrdfJoint,
)
from backend.engine.urdf_table import UrdfReadError, urdf_table


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class DofLimits(_Model):
    """Optional limit overrides. Units: rad (or m) for positions, per s, per s², per s³."""

    min: float | None = None
    max: float | None = None
    velocity: float | None = Field(default=None, gt=0)
    acceleration: float | None = Field(default=None, gt=0)
    jerk: float | None = Field(default=None, gt=0)
    rest: float | None = None


class StationaryDofConfig(DofLimits):
    """A stationary DoF: a URDF joint (`joint`, default: the DoF's name) or a symbolic DoF (`drives`)."""

    name: str
    joint: str | None = None
    drives: dict[str, float] | None = Field(
        default=None,
        description="symbolic DoF: URDF joint name -> coefficient (joint += coefficient * value)",
    )
    group: str | None = None
    description: str = ""


class SpatialDofConfig(DofLimits):
    """One axis of the base: x, y, z in m; yaw, pitch, roll in rad."""

    name: str
    axis: Literal["x", "y", "z", "yaw", "pitch", "roll"]
    group: str | None = Field(
        default=None, description="DoFs sharing a group are limited by their vector norm"
    )
    description: str = ""


class DisplayDofConfig(DofLimits):
    """An LED or LED group (`colour`), a face/screen expression (`enum`) or a face parameter (`continuous`)."""

    name: str
    type: Literal["colour", "enum", "continuous"]
    links: list[str] = Field(default_factory=list, description="URDF links where the display is shown")
    options: list[str] | None = None
    rest_colour: tuple[float, float, float] | None = None
    rest_option: str | None = None
    description: str = ""

    @model_validator(mode="after")
    def _check(self) -> DisplayDofConfig:
        if self.type == "enum" and not self.options:
            raise ValueError(f"display DoF '{self.name}' of type enum needs a non-empty 'options' list")
        if self.rest_option is not None and (not self.options or self.rest_option not in self.options):
            raise ValueError(
                f"display DoF '{self.name}': rest_option '{self.rest_option}' is not one of its options"
            )
        if self.rest_colour is not None and not all(0.0 <= c <= 1.0 for c in self.rest_colour):
            raise ValueError(f"display DoF '{self.name}': rest_colour components must be in [0, 1]")
        return self


class AudibleDofConfig(_Model):
    """A speech (TTS) channel or a sound player: carries events, not curves."""

    name: str
    kind: Literal["speech", "sound"]
    sounds: list[str] = Field(
        default_factory=list,
        description="sounds this player knows by name (sound only); none listed: the robot folder's "
        "sounds/ files, followed as they are added and deleted",
    )
    description: str = ""


class EmbodimentConfig(_Model):
    """The schema of `embodiment.yaml`."""

    name: str
    urdf: str = "robot.urdf"
    description: str = ""
    stationary: list[StationaryDofConfig] = Field(default_factory=list)
    spatial: list[SpatialDofConfig] = Field(default_factory=list)
    display: list[DisplayDofConfig] = Field(default_factory=list)
    audible: list[AudibleDofConfig] = Field(default_factory=list)
    postures: dict[str, dict[str, Any]] = Field(
        default_factory=dict,
        description="named poses: either DoF name -> value (float, colour list or option name), or "
        "{description: one line, values: {DoF name -> value}} (the nutty-posture/1 shape)",
    )
    gaze: dict[str, Any] = Field(
        default_factory=dict, description="gaze chain description for look-at blocks"
    )

    @model_validator(mode="after")
    def _posture_shapes(self) -> EmbodimentConfig:
        for name, pose in self.postures.items():
            if "values" in pose and isinstance(pose["values"], dict):
                extra = set(pose) - {"values", "description"}
                if extra:
                    raise ValueError(
                        f"postures.{name}: a described posture has only 'description' and 'values', "
                        f"not {sorted(extra)}"
                    )
                if not isinstance(pose.get("description", ""), str):
                    raise ValueError(f"postures.{name}.description: a posture's description is text")
        return self

    def posture_values(self) -> dict[str, dict[str, Any]]:
        """Posture name -> {DoF name: value}, whichever of the two shapes each posture was written in."""
        return {
            name: dict(pose["values"]) if _described(pose) else dict(pose)
            for name, pose in self.postures.items()
        }

    def posture_descriptions(self) -> dict[str, str]:
        """Posture name -> its one-line description ('' when the file gives none)."""
        return {
            name: str(pose.get("description", "")) if _described(pose) else ""
            for name, pose in self.postures.items()
        }


def _described(pose: dict[str, Any]) -> bool:
    """Whether a posture of embodiment.yaml is written as {description?, values} (a value is never a mapping)."""
    return isinstance(pose.get("values"), dict)


def read_urdf_joints(urdf_path: Path) -> tuple[list[UrdfJoint], dict[str, Any]]:
    """Actuated joints (non-fixed, not mimic) of a URDF, with their limits; plus the mimic table."""
    try:
        table = urdf_table(urdf_path)
    except UrdfReadError as exc:
        raise EmbodimentError(str(exc)) from exc
    joints: list[UrdfJoint] = []
    mimics: dict[str, Any] = {}
    for j in table.joints:
        if j.type == "fixed" or j.type == "floating" or j.type == "planar":
            continue
        if j.mimic is not None:
            mimics[j.name] = {"joint": j.mimic[0], "multiplier": j.mimic[1], "offset": j.mimic[2]}
            continue
        lower, upper = j.lower, j.upper
        if j.type == "continuous" or lower is None or upper is None or not lower < upper:
            lower, upper = -2 * math.pi, 2 * math.pi
        velocity = j.velocity if j.velocity else DEFAULT_VELOCITY.get(j.type, 2.0)
        joints.append(UrdfJoint(j.name, j.type, float(lower), float(upper), float(velocity), j.child))
    return joints, mimics


def _limit(value: float | None, default: float) -> float:
    return float(default if value is None else value)


def _stationary_from_joint(j: UrdfJoint, cfg: StationaryDofConfig | None, start: int) -> Dof:
    cfg = cfg or StationaryDofConfig(name=j.name)
    vel = _limit(cfg.velocity, j.velocity)
    acc = _limit(cfg.acceleration, ACC_PER_VEL * vel)
    lo, hi = _limit(cfg.min, j.lower), _limit(cfg.max, j.upper)
    rest = _limit(cfg.rest, min(max(0.0, lo), hi))
    return Dof(
        name=cfg.name,
        dimension=Dimension.stationary,
        type=DofType.continuous,
        channels=slice(start, start + 1),
        min=lo,
        max=hi,
        velocity=vel,
        acceleration=acc,
        jerk=_limit(cfg.jerk, JERK_PER_ACC * acc),
        rest=rest,
        joint=j.name,
        group=cfg.group,
        description=cfg.description,
    )


class _DofList:
    """DoFs in declaration order, each on the next free channels; a name may be declared once."""

    def __init__(self) -> None:
        self.dofs: list[Dof] = []
        self.cursor = 0  # the next free channel
        self._seen: set[str] = set()

    def claim(self, name: str, where: str) -> None:
        if name in self._seen:
            raise EmbodimentError(f"{where}: DoF name '{name}' is declared twice")
        self._seen.add(name)

    def add(self, dof: Dof) -> None:
        self.dofs.append(dof)
        self.cursor = dof.channels.stop


def dofs_from_urdf(joints: list[UrdfJoint]) -> list[Dof]:
    """A bare URDF: every actuated joint a stationary DoF with the URDF's limits."""
    return [_stationary_from_joint(j, None, i) for i, j in enumerate(joints)]


def dofs_from_config(cfg: EmbodimentConfig, joints: list[UrdfJoint], mimics: dict[str, Any]) -> list[Dof]:
    """The DoFs `embodiment.yaml` declares (stationary, spatial, display, audible, in that order)
    on the URDF's actuated `joints`; `mimics` only improves the message about a mimic joint."""
    out = _DofList()
    joint_by_name = {j.name: j for j in joints}
    for i, s in enumerate(cfg.stationary):
        where = f"stationary[{i}] '{s.name}'"
        out.claim(s.name, where)
        if s.drives:
            out.add(_symbolic_dof(s, where, joint_by_name, mimics, out.cursor))
        else:
            out.add(_joint_dof(s, where, joint_by_name, mimics, out.cursor))
    axes_seen: set[str] = set()
    for i, s in enumerate(cfg.spatial):
        where = f"spatial[{i}] '{s.name}'"
        out.claim(s.name, where)
        if s.axis in axes_seen:
            raise EmbodimentError(f"{where}: axis '{s.axis}' is already declared")
        axes_seen.add(s.axis)
        out.add(_spatial_dof(s, where, out.cursor))
    if len(cfg.spatial) > 6:
        raise EmbodimentError("spatial: a base has at most 6 axes")
    for i, s in enumerate(cfg.display):
        where = f"display[{i}] '{s.name}'"
        out.claim(s.name, where)
        out.add(_display_dof(s, where, out.cursor))
    for i, s in enumerate(cfg.audible):
        out.claim(s.name, f"audible[{i}] '{s.name}'")
        out.add(_audible_dof(s, out.cursor))
    return out.dofs


def _symbolic_dof(
    s: StationaryDofConfig,
    where: str,
    joint_by_name: dict[str, UrdfJoint],
    mimics: dict[str, Any],
    start: int,
) -> Dof:
    """A DoF driving several joints (joint += coefficient * value): its range and speed are what
    its joints allow for its coefficients, unless the file says otherwise."""
    for joint in s.drives or {}:
        if joint not in joint_by_name:
            hint = " (it is a mimic joint; drive its leader)" if joint in mimics else ""
            raise EmbodimentError(f"{where}: drives unknown actuated joint '{joint}'{hint}")
    lo, hi = -math.inf, math.inf
    vel_bound = math.inf
    for joint, coef in (s.drives or {}).items():
        j = joint_by_name[joint]
        if coef == 0:
            continue
        a, b = sorted((j.lower / coef, j.upper / coef))
        lo, hi = max(lo, a), min(hi, b)
        vel_bound = min(vel_bound, j.velocity / abs(coef))
    lo = _limit(s.min, lo if math.isfinite(lo) else -1.0)
    hi = _limit(s.max, hi if math.isfinite(hi) else 1.0)
    if not lo < hi:
        raise EmbodimentError(f"{where}: min {lo} must be below max {hi}")
    vel = _limit(s.velocity, vel_bound if math.isfinite(vel_bound) else 2.0)
    return _continuous(
        s,
        Dimension.stationary,
        start,
        lo,
        hi,
        vel,
        rest=_limit(s.rest, min(max(0.0, lo), hi)),
        drives=dict(s.drives or {}),
        group=s.group,
    )


def _joint_dof(
    s: StationaryDofConfig,
    where: str,
    joint_by_name: dict[str, UrdfJoint],
    mimics: dict[str, Any],
    start: int,
) -> Dof:
    """A DoF that is one URDF joint (`joint`, default the DoF's name)."""
    joint = s.joint or s.name
    if joint not in joint_by_name:
        hint = " (it is a mimic joint; it follows its leader)" if joint in mimics else ""
        raise EmbodimentError(f"{where}: URDF has no actuated joint '{joint}'{hint}")
    d = _stationary_from_joint(joint_by_name[joint], s, start)
    if not d.min < d.max:
        raise EmbodimentError(f"{where}: min {d.min} must be below max {d.max}")
    rest = d.rest  # a joint DoF's rest is one number
    if isinstance(rest, tuple) or not d.min <= rest <= d.max:
        raise EmbodimentError(f"{where}: rest {d.rest} is outside [{d.min}, {d.max}]")
    return d


def _spatial_dof(s: SpatialDofConfig, where: str, start: int) -> Dof:
    """One base axis: by default +-1 m at 0.3 m/s (x, y, z) or +-pi rad at 1 rad/s (yaw, pitch, roll)."""
    linear = s.axis in ("x", "y", "z")
    vel = _limit(s.velocity, 0.3 if linear else 1.0)
    lo = _limit(s.min, -1.0 if linear else -math.pi)
    hi = _limit(s.max, 1.0 if linear else math.pi)
    if not lo < hi:
        raise EmbodimentError(f"{where}: min {lo} must be below max {hi}")
    return _continuous(
        s,
        Dimension.spatial,
        start,
        lo,
        hi,
        vel,
        rest=_limit(s.rest, min(max(0.0, lo), hi)),
        axis=s.axis,
        group=s.group,
    )


def _display_dof(s: DisplayDofConfig, where: str, start: int) -> Dof:
    """An LED colour (three channels), an expression (an enum index, switching at once) or a
    continuous face parameter (default [0, 1], full range in a quarter second)."""
    common = {
        "name": s.name,
        "dimension": Dimension.display,
        "links": tuple(s.links),
        "description": s.description,
    }
    if s.type == "colour":
        return Dof(
            type=DofType.colour,
            channels=slice(start, start + 3),
            min=0.0,
            max=1.0,
            velocity=_limit(s.velocity, COLOUR_VELOCITY),
            acceleration=_limit(s.acceleration, COLOUR_ACCELERATION),
            jerk=_limit(s.jerk, COLOUR_JERK),
            rest=tuple(s.rest_colour or (0.0, 0.0, 0.0)),
            **common,
        )
    if s.type == "enum":
        options = tuple(s.options or ())
        return Dof(
            type=DofType.enum,
            channels=slice(start, start + 1),
            min=0.0,
            max=float(len(options) - 1),
            velocity=math.inf,
            acceleration=math.inf,
            jerk=math.inf,
            rest=float(options.index(s.rest_option) if s.rest_option else 0),
            options=options,
            **common,
        )
    lo, hi = _limit(s.min, 0.0), _limit(s.max, 1.0)
    if not lo < hi:
        raise EmbodimentError(f"{where}: min {lo} must be below max {hi}")
    return _continuous(
        s,
        Dimension.display,
        start,
        lo,
        hi,
        _limit(s.velocity, 4.0 * (hi - lo)),
        rest=_limit(s.rest, lo),
        links=tuple(s.links),
    )


def _audible_dof(s: AudibleDofConfig, start: int) -> Dof:
    """Speech or a sound player: no channel, no limits (NaN); it carries events."""
    return Dof(
        name=s.name,
        dimension=Dimension.audible,
        type=DofType.event,
        channels=slice(start, start),
        min=math.nan,
        max=math.nan,
        velocity=math.nan,
        acceleration=math.nan,
        jerk=math.nan,
        rest=math.nan,
        kind=s.kind,
        sounds=tuple(s.sounds),
        description=s.description,
    )


def _continuous(
    s: StationaryDofConfig | SpatialDofConfig | DisplayDofConfig,
    dimension: Dimension,
    start: int,
    lo: float,
    hi: float,
    vel: float,
    *,
    rest: float,
    **extra: Any,
) -> Dof:
    """A one-channel continuous DoF; acceleration and jerk from the file or the documented defaults."""
    acc = _limit(s.acceleration, ACC_PER_VEL * vel)
    return Dof(
        name=s.name,
        dimension=dimension,
        type=DofType.continuous,
        channels=slice(start, start + 1),
        min=lo,
        max=hi,
        velocity=vel,
        acceleration=acc,
        jerk=_limit(s.jerk, JERK_PER_ACC * acc),
        rest=rest,
        description=s.description,
        **extra,
    )
