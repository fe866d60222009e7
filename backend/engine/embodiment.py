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

The DoF types live in `backend.engine.dofs`, the `embodiment.yaml` schema and the rules that turn
it into DoFs in `backend.engine.kinematronics`; their public names are importable from here too.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydantic import ValidationError

from backend.engine.dofs import (  # noqa: F401 (re-exported: the names were importable from here before the split)
    ACC_PER_VEL,
    COLOUR_ACCELERATION,
    COLOUR_JERK,
    COLOUR_VELOCITY,
    DEFAULT_VELOCITY,
    JERK_PER_ACC,
    SPATIAL_AXES,
    ChannelKind,
    Dimension,
    Dof,
    DofType,
    EmbodimentError,
    UrdfJoint,
)
from backend.engine.joint_frames import joint_frames, root_links
from backend.engine.kinematronics import (  # noqa: F401 (re-exported: the names were importable from here before the split)
    AudibleDofConfig,
    DisplayDofConfig,
    DofLimits,
    EmbodimentConfig,
    SpatialDofConfig,
    StationaryDofConfig,
    dofs_from_config,
    dofs_from_urdf,
    read_urdf_joints,
)
from backend.engine.sounds import SoundLibrary


@dataclass(eq=False)  # identity semantics: embodiments are shared, hashed by identity
class Embodiment:
    """A robot's kinematronics resolved to channel arrays. Build with `load_embodiment`."""

    name: str
    dofs: list[Dof]
    urdf_path: Path | None = None
    joints: list[UrdfJoint] = field(default_factory=list)
    postures: dict[str, dict[str, Any]] = field(default_factory=dict)  # name -> {DoF name: value}
    gaze: dict[str, Any] = field(default_factory=dict)
    description: str = ""
    posture_descriptions: dict[str, str] = field(default_factory=dict)  # name -> one line (may be missing)
    # sound DoFs whose list is the robot folder's sounds/ files (they declare none of their own)
    folder_sound_dofs: tuple[str, ...] = ()

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

    def follow_sound_folder(self, names: list[str]) -> None:
        """Give the sound DoFs that follow the robot folder's sounds/ this list of sound names (after a
        sound is stored or deleted). Only the DoF's `sounds` changes: no channel does."""
        for i, d in enumerate(self.dofs):
            if d.name in self.folder_sound_dofs:
                self.dofs[i] = self._by_name[d.name] = replace(d, sounds=tuple(names))

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
            if d.joint and not d.drives and d.joint in self.joint_names and not isinstance(d.rest, tuple):
                rest[self.joint_names.index(d.joint)] = float(d.rest)  # a joint DoF's rest is one number
        return rest

    def joint_positions(self, values: np.ndarray) -> np.ndarray:
        """Actuated URDF joint positions (rad or m) that a full channel vector composes to: each joint's
        own DoF plus its symbolic DoFs, not clipped. A frame from the engine composes to joints within
        their limits (the safety net's joint stage); a program's raw values may not."""
        return self.joint_matrix @ values + self.joint_offset

    def joint_positions_in_range(self, values: np.ndarray) -> np.ndarray:
        """`joint_positions` clipped to the URDF ranges: a kinematic model's view of a raw program pose
        (IK, the ghost), never what a motor is sent."""
        return np.clip(self.joint_positions(values), self._joint_lower, self._joint_upper)

    @property
    def joint_lower(self) -> np.ndarray:
        return self._joint_lower

    @property
    def joint_upper(self) -> np.ndarray:
        return self._joint_upper

    def base_pose(self, values: np.ndarray) -> dict[str, float]:
        """The base's spatial axes (x, y, z in m; yaw, pitch, roll in rad); absent axes are 0."""
        pose: dict[str, float] = dict.fromkeys(SPATIAL_AXES, 0.0)
        for d in self.dofs_in(Dimension.spatial):
            if d.axis is not None:  # every spatial DoF names its axis
                pose[d.axis] = float(values[d.channels.start])
        return pose

    def to_dict(self) -> dict[str, Any]:

        frames = joint_frames(self)  # a rig's bones: each moving joint's frame and axis at zero
        return {
            "name": self.name,
            "description": self.description,
            "dimensions": self.dimension_counts(),
            "dofs": [
                {**d.to_dict(), **({"joint_frame": frames[d.joint]} if d.joint in frames else {})}
                for d in self.dofs
            ],
            "channels": list(self.channel_names),
            "joints": [j.name for j in self.joints],
            "groups": {g: [self.channel_names[i] for i in ix] for g, ix in self.groups.items()},
            "postures": sorted(self.postures),
            "joint_frames": frames,
            "root_links": root_links(self),
        }


# ------------------------------------------------------------------------------------------------
# Loading
# ------------------------------------------------------------------------------------------------


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
    joints, _ = read_urdf_joints(urdf_path)
    return Embodiment(name=urdf_path.stem, dofs=dofs_from_urdf(joints), urdf_path=urdf_path, joints=joints)


def _from_config(cfg: EmbodimentConfig, folder: Path) -> Embodiment:
    urdf_path = folder / cfg.urdf
    if not urdf_path.exists():
        raise EmbodimentError(f"{folder / 'embodiment.yaml'}: urdf '{cfg.urdf}' not found")
    joints, mimics = read_urdf_joints(urdf_path)
    emb = Embodiment(
        name=cfg.name,
        dofs=dofs_from_config(cfg, joints, mimics),
        urdf_path=urdf_path,
        joints=joints,
        postures=cfg.posture_values(),
        gaze=cfg.gaze,
        description=cfg.description,
        posture_descriptions=cfg.posture_descriptions(),
    )
    for pname, pose in emb.postures.items():
        for dof_name in pose:
            if not emb.has_dof(dof_name):
                raise EmbodimentError(f"postures.{pname}: unknown DoF '{dof_name}'")
    emb.folder_sound_dofs = tuple(s.name for s in cfg.audible if s.kind == "sound" and not s.sounds)
    if emb.folder_sound_dofs:
        emb.follow_sound_folder(SoundLibrary(folder / "sounds").list())
    return emb
