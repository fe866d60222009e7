"""A robot's embodiment: its URDF plus its *kinematronics*.

The paper describes a robot's expressive channels in four dimensions:

- **stationary**: joints used for expression (a real URDF joint, or a *symbolic* DoF that drives
  several joints with fixed coefficients, e.g. `gaze_pitch -> neck_pitch: 0.6, head_pitch: 0.4`);
- **spatial**: motion of the base, 0-6 axes (x, y, z, yaw, pitch, roll), optionally coupled in groups
  whose limits apply to the vector norm (e.g. base x/y linear speed);
- **display**: LEDs (RGB colour), aggregated LED groups, face/screen expressions (enumerations) or
  continuous face parameters;
- **audible**: speech and sound players, which carry events rather than curves.

At run time the engine works on *channels*: a flat float vector over all DoFs (one channel per
continuous or enum DoF, three per colour DoF, none per event DoF). Every per-channel property
(limits, rest value, kind) is a numpy array, so the hot path is vectorised over DoFs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

# Documented defaults used when a URDF (or embodiment.yaml) gives no acceleration/jerk limit:
#   acceleration = ACC_PER_VEL * velocity limit   [1/s]
#   jerk         = JERK_PER_ACC * acceleration limit [1/s]
ACC_PER_VEL = 4.0
JERK_PER_ACC = 10.0
# Velocity used when a URDF joint declares none (rad/s for revolute, m/s for prismatic).
DEFAULT_VELOCITY = {"revolute": 2.0, "continuous": 2.0, "prismatic": 0.5}
# Limits of display channels: colours live in [0, 1]; changes are allowed to be fast but finite.
COLOUR_VELOCITY, COLOUR_ACCELERATION, COLOUR_JERK = 20.0, 400.0, 20000.0


class Dimension(str, Enum):
    stationary = "stationary"
    spatial = "spatial"
    display = "display"
    audible = "audible"


class DofType(str, Enum):
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


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class DofLimits(_Model):
    """Optional limit overrides. Units: rad (or m) for positions, per s, per s², per s³."""

    min: float | None = None
    max: float | None = None
    velocity: float | None = Field(None, gt=0)
    acceleration: float | None = Field(None, gt=0)
    jerk: float | None = Field(None, gt=0)
    rest: float | None = None


class StationaryDofConfig(DofLimits):
    """A stationary DoF: a URDF joint (`joint`, default: the DoF's name) or a symbolic DoF (`drives`)."""

    name: str
    joint: str | None = None
    drives: dict[str, float] | None = Field(
        None, description="symbolic DoF: URDF joint name -> coefficient (joint += coefficient * value)"
    )
    group: str | None = None
    description: str = ""


class SpatialDofConfig(DofLimits):
    """One axis of the base: x, y, z in m; yaw, pitch, roll in rad."""

    name: str
    axis: Literal["x", "y", "z", "yaw", "pitch", "roll"]
    group: str | None = Field(None, description="DoFs sharing a group are limited by their vector norm")
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
    def _check(self) -> "DisplayDofConfig":
        if self.type == "enum" and not self.options:
            raise ValueError(f"display DoF '{self.name}' of type enum needs a non-empty 'options' list")
        if self.rest_option is not None and (not self.options or self.rest_option not in self.options):
            raise ValueError(f"display DoF '{self.name}': rest_option '{self.rest_option}' is not one of its options")
        if self.rest_colour is not None and not all(0.0 <= c <= 1.0 for c in self.rest_colour):
            raise ValueError(f"display DoF '{self.name}': rest_colour components must be in [0, 1]")
        return self


class AudibleDofConfig(_Model):
    """A speech (TTS) channel or a sound player: carries events, not curves."""

    name: str
    kind: Literal["speech", "sound"]
    sounds: list[str] = Field(default_factory=list, description="sound clips this player knows (sound only)")
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
        default_factory=dict, description="named poses: DoF name -> value (float, colour list or option name)"
    )
    gaze: dict[str, Any] = Field(default_factory=dict, description="gaze chain description for look-at blocks")


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


@dataclass(eq=False)  # identity semantics: embodiments are shared, hashed by identity
class Embodiment:
    """A robot's kinematronics resolved to channel arrays. Build with `load_embodiment`."""

    name: str
    dofs: list[Dof]
    urdf_path: Path | None = None
    joints: list[UrdfJoint] = field(default_factory=list)
    postures: dict[str, dict[str, Any]] = field(default_factory=dict)
    gaze: dict[str, Any] = field(default_factory=dict)
    description: str = ""

    def __post_init__(self) -> None:
        self._by_name = {d.name: d for d in self.dofs}
        n = sum(d.channels.stop - d.channels.start for d in self.dofs)
        self.n_channels = n
        names: list[str] = []
        kind = np.zeros(n, dtype=np.int8)
        lo, hi = np.empty(n), np.empty(n)
        vel, acc, jerk, rest = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
        dof_of_channel = np.empty(n, dtype=np.int32)
        for i, d in enumerate(self.dofs):
            sl = d.channels
            width = sl.stop - sl.start
            if width == 0:
                continue
            if d.type is DofType.colour:
                names += [f"{d.name}.{c}" for c in "rgb"]
                kind[sl] = ChannelKind.colour
                rest[sl] = d.rest
            else:
                names.append(d.name)
                kind[sl] = ChannelKind.enum if d.type is DofType.enum else ChannelKind.continuous
                rest[sl] = d.rest
            lo[sl], hi[sl] = d.min, d.max
            vel[sl], acc[sl], jerk[sl] = d.velocity, d.acceleration, d.jerk
            dof_of_channel[sl] = i
        self.channel_names = names
        self.channel_index = {c: i for i, c in enumerate(names)}
        self.channel_kind = kind
        self.min, self.max = lo, hi
        self.vel_limit, self.acc_limit, self.jerk_limit = vel, acc, jerk
        self.rest = rest
        self.dof_of_channel = dof_of_channel
        self.continuous_mask = kind == ChannelKind.continuous
        self.enum_mask = kind == ChannelKind.enum
        self.colour_mask = kind == ChannelKind.colour
        # Coupled groups: channel index arrays whose limits apply to the vector norm.
        groups: dict[str, list[int]] = {}
        for d in self.dofs:
            if d.group and d.channels.stop > d.channels.start:
                groups.setdefault(d.group, []).extend(range(d.channels.start, d.channels.stop))
        self.groups = {g: np.array(ix, dtype=np.intp) for g, ix in groups.items()}
        for a in (lo, hi, vel, acc, jerk, rest, kind):
            a.setflags(write=False)
        self._build_joint_map()

    # --- look-ups -----------------------------------------------------------------------------
    def dof(self, name: str) -> Dof:
        try:
            return self._by_name[name]
        except KeyError:
            raise KeyError(f"robot '{self.name}' has no DoF '{name}'") from None

    def has_dof(self, name: str) -> bool:
        return name in self._by_name

    @property
    def dof_names(self) -> list[str]:
        return [d.name for d in self.dofs]

    def dofs_in(self, dimension: Dimension | str) -> list[Dof]:
        dim = Dimension(dimension)
        return [d for d in self.dofs if d.dimension is dim]

    @property
    def event_dofs(self) -> list[Dof]:
        return [d for d in self.dofs if d.type is DofType.event]

    @property
    def continuous_names(self) -> list[str]:
        """Names of the continuous DoFs (the columns of `nutty run --out x.csv`)."""
        return [d.name for d in self.dofs if d.type is DofType.continuous]

    def dimension_counts(self) -> dict[str, int]:
        counts = {dim.value: 0 for dim in Dimension}
        for d in self.dofs:
            counts[d.dimension.value] += 1
        return counts

    def clamp(self, values: np.ndarray) -> np.ndarray:
        """Clip channel values to the position limits (out-of-place)."""
        return np.clip(values, self.min, self.max)

    # --- joints -------------------------------------------------------------------------------
    def _build_joint_map(self) -> None:
        """Linear map from channels to actuated URDF joint positions: q = joint_matrix @ values.

        A real DoF contributes its value with coefficient 1; a symbolic DoF adds
        `coefficient * value` to each joint it drives (Nutty Tracks' symbolic DoFs).
        """
        names = [j.name for j in self.joints]
        index = {n: i for i, n in enumerate(names)}
        m = np.zeros((len(names), self.n_channels))
        for d in self.dofs:
            if d.dimension is not Dimension.stationary or d.type is not DofType.continuous:
                continue
            c = d.channels.start
            if d.drives:
                for joint, coef in d.drives.items():
                    if joint in index:
                        m[index[joint], c] += coef
            elif d.joint in index:
                m[index[d.joint], c] += 1.0
        self.joint_names = names
        self.joint_matrix = m
        self._joint_lower = np.array([j.lower for j in self.joints])
        self._joint_upper = np.array([j.upper for j in self.joints])
        # Symbolic DoFs add to the joints' rest-centred value, so a symbolic DoF at rest moves nothing.
        self.joint_offset = -(m @ np.where(self.continuous_mask, self.rest, 0.0)) + self._joint_rest(m)

    def _joint_rest(self, m: np.ndarray) -> np.ndarray:
        # Joints no DoF drives sit at 0, or at the limit nearest to it.
        rest = np.array([min(max(0.0, j.lower), j.upper) for j in self.joints])
        for d in self.dofs:
            if d.joint and not d.drives and d.joint in self.joint_names:
                rest[self.joint_names.index(d.joint)] = float(d.rest)  # type: ignore[arg-type]
        return rest

    def joint_positions(self, values: np.ndarray) -> np.ndarray:
        """Actuated URDF joint positions (rad or m) for a full channel vector, within joint limits."""
        q = self.joint_matrix @ values + self.joint_offset
        return np.clip(q, self._joint_lower, self._joint_upper)

    def base_pose(self, values: np.ndarray) -> dict[str, float]:
        """The base's spatial axes (x, y, z in m; yaw, pitch, roll in rad); absent axes are 0."""
        pose = dict.fromkeys(SPATIAL_AXES, 0.0)
        for d in self.dofs_in(Dimension.spatial):
            pose[d.axis] = float(values[d.channels.start])  # type: ignore[index]
        return pose

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "description": self.description,
            "dimensions": self.dimension_counts(),
            "dofs": [d.to_dict() for d in self.dofs],
            "channels": list(self.channel_names),
            "joints": [j.name for j in self.joints],
            "groups": {g: [self.channel_names[i] for i in ix] for g, ix in self.groups.items()},
            "postures": sorted(self.postures),
        }


# ------------------------------------------------------------------------------------------------
# Loading
# ------------------------------------------------------------------------------------------------


def _read_urdf_joints(urdf_path: Path) -> tuple[list[UrdfJoint], dict[str, Any]]:
    """Actuated joints (non-fixed, not mimic) of a URDF, with their limits; plus the mimic table."""
    import yourdfpy  # local import: loading yourdfpy is only needed when a robot is loaded

    try:
        urdf = yourdfpy.URDF.load(
            str(urdf_path), build_scene_graph=False, load_meshes=False, build_collision_scene_graph=False
        )
    except Exception as exc:  # yourdfpy raises many types for malformed files
        raise EmbodimentError(f"cannot read URDF '{urdf_path}': {exc}") from exc
    joints: list[UrdfJoint] = []
    mimics: dict[str, Any] = {}
    for j in urdf.robot.joints:
        if j.type == "fixed" or j.type == "floating" or j.type == "planar":
            continue
        if j.mimic is not None:
            mimics[j.name] = {"joint": j.mimic.joint, "multiplier": j.mimic.multiplier, "offset": j.mimic.offset}
            continue
        lim = j.limit
        lower = lim.lower if lim is not None and lim.lower is not None else None
        upper = lim.upper if lim is not None and lim.upper is not None else None
        if j.type == "continuous" or lower is None or upper is None or not lower < upper:
            lower, upper = -2 * math.pi, 2 * math.pi
        velocity = lim.velocity if lim is not None and lim.velocity else DEFAULT_VELOCITY.get(j.type, 2.0)
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


def load_embodiment(source: str | Path) -> Embodiment:
    """Load a robot from a folder (`robot.urdf` + `embodiment.yaml`) or from a bare URDF file.

    `source` may also be the name of a bundled robot (a folder under `robots/`).
    A bare URDF makes every actuated joint (non-fixed, not a mimic) a stationary DoF with the URDF's
    position and velocity limits; acceleration = ACC_PER_VEL x velocity, jerk = JERK_PER_ACC x acceleration.
    """
    path = resolve_robot_path(source)
    if path.is_dir():
        yaml_path = path / "embodiment.yaml"
        if not yaml_path.exists():
            urdf = path / "robot.urdf"
            if urdf.exists():
                return _from_urdf(urdf)
            raise EmbodimentError(f"robot folder '{path}' has neither embodiment.yaml nor robot.urdf")
        try:
            raw = yaml.safe_load(yaml_path.read_text()) or {}
        except yaml.YAMLError as exc:
            raise EmbodimentError(f"{yaml_path}: invalid YAML: {exc}") from exc
        try:
            cfg = EmbodimentConfig.model_validate(raw)
        except ValidationError as exc:
            raise EmbodimentError(f"{yaml_path}: {_format_validation(exc)}") from exc
        return _from_config(cfg, path)
    if path.suffix.lower() in (".urdf", ".xml"):
        return _from_urdf(path)
    raise EmbodimentError(f"'{source}' is neither a robot folder nor a URDF file")


def _format_validation(exc: ValidationError) -> str:
    parts = []
    for err in exc.errors():
        loc = ".".join(str(p) for p in err["loc"])
        parts.append(f"{loc}: {err['msg']}")
    return "; ".join(parts)


def resolve_robot_path(source: str | Path) -> Path:
    """A robot folder or URDF path; a bare name is looked up among the bundled robots."""
    path = Path(source)
    if path.exists():
        return path
    bundled = robots_dir() / str(source)
    if bundled.exists():
        return bundled
    raise EmbodimentError(f"no robot at '{source}' (not a path, nor a bundled robot in {robots_dir()})")


def robots_dir() -> Path:
    return Path(__file__).resolve().parents[2] / "robots"


DEFAULT_ROBOT = "nutty_desk"


def default_robot_path() -> Path:
    return robots_dir() / DEFAULT_ROBOT


def _from_urdf(urdf_path: Path) -> Embodiment:
    joints, _ = _read_urdf_joints(urdf_path)
    dofs = [_stationary_from_joint(j, None, i) for i, j in enumerate(joints)]
    return Embodiment(name=urdf_path.stem, dofs=dofs, urdf_path=urdf_path, joints=joints)


def _from_config(cfg: EmbodimentConfig, folder: Path) -> Embodiment:
    urdf_path = folder / cfg.urdf
    if not urdf_path.exists():
        raise EmbodimentError(f"{folder / 'embodiment.yaml'}: urdf '{cfg.urdf}' not found")
    joints, mimics = _read_urdf_joints(urdf_path)
    joint_by_name = {j.name: j for j in joints}
    dofs: list[Dof] = []
    seen: set[str] = set()
    cursor = 0

    def claim(name: str, where: str) -> None:
        if name in seen:
            raise EmbodimentError(f"{where}: DoF name '{name}' is declared twice")
        seen.add(name)

    for i, s in enumerate(cfg.stationary):
        where = f"stationary[{i}] '{s.name}'"
        claim(s.name, where)
        if s.drives:
            for joint in s.drives:
                if joint not in joint_by_name:
                    hint = " (it is a mimic joint; drive its leader)" if joint in mimics else ""
                    raise EmbodimentError(f"{where}: drives unknown actuated joint '{joint}'{hint}")
            # A symbolic DoF's range is what its joints allow for its coefficients.
            lo, hi = -math.inf, math.inf
            vel_bound = math.inf
            for joint, coef in s.drives.items():
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
            acc = _limit(s.acceleration, ACC_PER_VEL * vel)
            dofs.append(
                Dof(
                    name=s.name,
                    dimension=Dimension.stationary,
                    type=DofType.continuous,
                    channels=slice(cursor, cursor + 1),
                    min=lo,
                    max=hi,
                    velocity=vel,
                    acceleration=acc,
                    jerk=_limit(s.jerk, JERK_PER_ACC * acc),
                    rest=_limit(s.rest, min(max(0.0, lo), hi)),
                    drives=dict(s.drives),
                    group=s.group,
                    description=s.description,
                )
            )
        else:
            joint = s.joint or s.name
            if joint not in joint_by_name:
                hint = " (it is a mimic joint; it follows its leader)" if joint in mimics else ""
                raise EmbodimentError(f"{where}: URDF has no actuated joint '{joint}'{hint}")
            d = _stationary_from_joint(joint_by_name[joint], s, cursor)
            if not d.min < d.max:
                raise EmbodimentError(f"{where}: min {d.min} must be below max {d.max}")
            if not d.min <= d.rest <= d.max:  # type: ignore[operator]
                raise EmbodimentError(f"{where}: rest {d.rest} is outside [{d.min}, {d.max}]")
            dofs.append(d)
        cursor += 1

    axes_seen: set[str] = set()
    for i, s in enumerate(cfg.spatial):
        where = f"spatial[{i}] '{s.name}'"
        claim(s.name, where)
        if s.axis in axes_seen:
            raise EmbodimentError(f"{where}: axis '{s.axis}' is already declared")
        axes_seen.add(s.axis)
        linear = s.axis in ("x", "y", "z")
        vel = _limit(s.velocity, 0.3 if linear else 1.0)
        acc = _limit(s.acceleration, ACC_PER_VEL * vel)
        lo = _limit(s.min, -1.0 if linear else -math.pi)
        hi = _limit(s.max, 1.0 if linear else math.pi)
        if not lo < hi:
            raise EmbodimentError(f"{where}: min {lo} must be below max {hi}")
        dofs.append(
            Dof(
                name=s.name,
                dimension=Dimension.spatial,
                type=DofType.continuous,
                channels=slice(cursor, cursor + 1),
                min=lo,
                max=hi,
                velocity=vel,
                acceleration=acc,
                jerk=_limit(s.jerk, JERK_PER_ACC * acc),
                rest=_limit(s.rest, min(max(0.0, lo), hi)),
                axis=s.axis,
                group=s.group,
                description=s.description,
            )
        )
        cursor += 1
    if len(cfg.spatial) > 6:
        raise EmbodimentError("spatial: a base has at most 6 axes")

    for i, s in enumerate(cfg.display):
        where = f"display[{i}] '{s.name}'"
        claim(s.name, where)
        if s.type == "colour":
            rest: float | tuple[float, ...] = tuple(s.rest_colour or (0.0, 0.0, 0.0))
            d = Dof(
                name=s.name,
                dimension=Dimension.display,
                type=DofType.colour,
                channels=slice(cursor, cursor + 3),
                min=0.0,
                max=1.0,
                velocity=_limit(s.velocity, COLOUR_VELOCITY),
                acceleration=_limit(s.acceleration, COLOUR_ACCELERATION),
                jerk=_limit(s.jerk, COLOUR_JERK),
                rest=rest,
                links=tuple(s.links),
                description=s.description,
            )
            cursor += 3
        elif s.type == "enum":
            options = tuple(s.options or ())
            d = Dof(
                name=s.name,
                dimension=Dimension.display,
                type=DofType.enum,
                channels=slice(cursor, cursor + 1),
                min=0.0,
                max=float(len(options) - 1),
                velocity=math.inf,
                acceleration=math.inf,
                jerk=math.inf,
                rest=float(options.index(s.rest_option) if s.rest_option else 0),
                options=options,
                links=tuple(s.links),
                description=s.description,
            )
            cursor += 1
        else:
            lo, hi = _limit(s.min, 0.0), _limit(s.max, 1.0)
            if not lo < hi:
                raise EmbodimentError(f"{where}: min {lo} must be below max {hi}")
            vel = _limit(s.velocity, 4.0 * (hi - lo))
            acc = _limit(s.acceleration, ACC_PER_VEL * vel)
            d = Dof(
                name=s.name,
                dimension=Dimension.display,
                type=DofType.continuous,
                channels=slice(cursor, cursor + 1),
                min=lo,
                max=hi,
                velocity=vel,
                acceleration=acc,
                jerk=_limit(s.jerk, JERK_PER_ACC * acc),
                rest=_limit(s.rest, lo),
                links=tuple(s.links),
                description=s.description,
            )
            cursor += 1
        dofs.append(d)

    for i, s in enumerate(cfg.audible):
        claim(s.name, f"audible[{i}] '{s.name}'")
        dofs.append(
            Dof(
                name=s.name,
                dimension=Dimension.audible,
                type=DofType.event,
                channels=slice(cursor, cursor),
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
        )

    emb = Embodiment(
        name=cfg.name,
        dofs=dofs,
        urdf_path=urdf_path,
        joints=joints,
        postures=cfg.postures,
        gaze=cfg.gaze,
        description=cfg.description,
    )
    for pname, pose in cfg.postures.items():
        for dof_name in pose:
            if not emb.has_dof(dof_name):
                raise EmbodimentError(f"postures.{pname}: unknown DoF '{dof_name}'")
    return emb
