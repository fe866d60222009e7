"""Source channels, quaternion helpers and the source-name -> robot-DoF mapping used by the importers.

Every importer turns its file into a list of `SourceChannel`s (a named, timed series of rotations,
translations or scalars). `resolve_mapping` then decides which robot DoF each channel drives:

1. an entry of the mapping file (`--map`), looked up as `"<name>.<path>"` (e.g. `Neck.rotation`,
   `Hips.translation`) and then as `"<name>"` (rotation and scalar channels only);
2. a DoF of exactly the same name;
3. a DoF whose name matches ignoring case and separators (`Head-Yaw` -> `head_yaw`).

Translation channels are only mapped by an explicit `"<name>.translation"` entry.

Mapping file (JSON or YAML)::

    {"joints": {"Neck": {"dof": "neck_pitch", "axis": [0, 1, 0], "scale": 1.0, "offset": 0.0},
                "HeadTurn": "head_yaw",
                "Tail": null}}            # null: ignore this source channel

A rotation becomes the angle of its *twist* about the axis (swing-twist decomposition), so rotation
about other axes is dropped cleanly; the axis defaults to the URDF axis of the DoF's joint (for a
symbolic DoF, of the joint it drives most). A translation is projected onto the axis.
"""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from backend.engine.embodiment import Dimension, DofType, Embodiment


class ClipImportError(ValueError):
    """A file that cannot be imported (missing, unknown format, malformed, nothing to map)."""


@dataclass
class SourceChannel:
    """One animated channel of a source file.

    kind: "rotation" (values (N, 4) quaternions x, y, z, w), "translation" (values (N, 3)) or
    "scalar" (values (N,) numbers, or option names for CSV enum columns).
    interp: "STEP", "LINEAR" or "CUBICSPLINE"; for CUBICSPLINE `in_tangents`/`out_tangents` have the
    shape of `values` (derivatives per second, as glTF stores them).
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

    @property
    def label(self) -> str:
        return f"{self.name}.{self.path}" if self.path else self.name


@dataclass
class ChannelMap:
    """How one source channel drives one DoF."""

    dof: str
    axis: np.ndarray | None
    scale: float = 1.0
    offset: float = 0.0
    how: str = "exact name"


@dataclass
class MappingSpec:
    """A parsed mapping file: source name -> entry (None means: ignore the channel)."""

    joints: dict[str, dict[str, Any] | None] = field(default_factory=dict)
    path: str = ""


# --------------------------------------------------------------------------------------------------
# Quaternions (x, y, z, w), vectorised over a leading axis
# --------------------------------------------------------------------------------------------------


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b of quaternions (..., 4) in x, y, z, w order."""
    ax, ay, az, aw = np.moveaxis(np.asarray(a, dtype=float), -1, 0)
    bx, by, bz, bw = np.moveaxis(np.asarray(b, dtype=float), -1, 0)
    return np.stack([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ], axis=-1)


def quat_axis_angle(axis: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """Quaternions (x, y, z, w) for rotations by `angle` (rad, scalar or (N,)) about `axis`."""
    axis = _unit(axis)
    half = 0.5 * np.asarray(angle, dtype=float)
    s = np.sin(half)[..., None]
    return np.concatenate([s * axis, np.cos(half)[..., None]], axis=-1)


def swing_twist(q: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split rotations `q` (..., 4) into (swing, twist) with q = swing * twist, twist about `axis`.

    The twist is the projection of the quaternion's vector part onto the axis, renormalised; a
    rotation of exactly 180 degrees about an axis perpendicular to `axis` has no defined twist and
    gets the identity."""
    q = np.asarray(q, dtype=float)
    axis = _unit(axis)
    proj = np.sum(q[..., :3] * axis, axis=-1)
    twist = np.concatenate([proj[..., None] * axis, q[..., 3:4]], axis=-1)
    norm = np.linalg.norm(twist, axis=-1, keepdims=True)
    degenerate = norm[..., 0] < 1e-12
    twist = np.where(degenerate[..., None], np.array([0.0, 0.0, 0.0, 1.0]), twist / np.where(norm == 0, 1, norm))
    conj = twist * np.array([-1.0, -1.0, -1.0, 1.0])
    swing = quat_mul(q, conj)
    return swing, twist


def twist_angle(q: np.ndarray, axis: np.ndarray, unwrap: bool = True) -> np.ndarray:
    """Angle (rad) of the twist of each rotation `q` (N, 4) about `axis`, in (-pi, pi].

    With `unwrap`, a sequence is made continuous (no 2*pi jumps between successive samples)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    axis = _unit(axis)
    s = q[:, :3] @ axis
    w = q[:, 3]
    ang = 2.0 * np.arctan2(s, w)
    ang = (ang + math.pi) % (2 * math.pi) - math.pi
    ang = np.where(np.isclose(ang, -math.pi), math.pi, ang)
    if unwrap and len(ang) > 1:
        ang = np.unwrap(ang)
    return ang


def _unit(v: Any) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(3)
    n = float(np.linalg.norm(v))
    if not math.isfinite(n) or n < 1e-12:
        raise ClipImportError(f"axis {v.tolist()} has no direction")
    return v / n


# --------------------------------------------------------------------------------------------------
# Robot axes
# --------------------------------------------------------------------------------------------------

_AXES_CACHE: dict[str, dict[str, np.ndarray]] = {}
_SPATIAL_AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1), "roll": (1, 0, 0), "pitch": (0, 1, 0),
                 "yaw": (0, 0, 1)}


def urdf_joint_axes(urdf_path: str | Path) -> dict[str, np.ndarray]:
    """Joint name -> unit axis (the URDF `<axis xyz>`, default 1 0 0) of every joint of a URDF."""
    key = str(urdf_path)
    if key not in _AXES_CACHE:
        axes: dict[str, np.ndarray] = {}
        try:
            root = ET.parse(key).getroot()
        except (OSError, ET.ParseError) as exc:
            raise ClipImportError(f"cannot read joint axes from '{urdf_path}': {exc}") from exc
        for j in root.iter("joint"):
            el = j.find("axis")
            xyz = el.get("xyz", "1 0 0") if el is not None else "1 0 0"
            try:
                axes[j.get("name", "")] = _unit([float(x) for x in xyz.split()])
            except (ValueError, ClipImportError):
                axes[j.get("name", "")] = np.array([1.0, 0.0, 0.0])
        _AXES_CACHE[key] = axes
    return _AXES_CACHE[key]


def dof_axis(emb: Embodiment, dof_name: str) -> np.ndarray | None:
    """The default axis of a DoF: its URDF joint's axis, the most-driven joint's for a symbolic DoF,
    the base axis for a spatial DoF; None if unknown."""
    d = emb.dof(dof_name)
    if d.axis in _SPATIAL_AXES:
        return np.array(_SPATIAL_AXES[d.axis], dtype=float)
    joint = d.joint
    if d.drives:
        joint = max(d.drives.items(), key=lambda kv: abs(kv[1]))[0]
    if joint is None or emb.urdf_path is None:
        return None
    return urdf_joint_axes(emb.urdf_path).get(joint)


# --------------------------------------------------------------------------------------------------
# Mapping
# --------------------------------------------------------------------------------------------------


def normalise_name(name: str) -> str:
    """Lower case without separators: `Head-Yaw`, `head_yaw` and `HeadYaw` all give `headyaw`."""
    return re.sub(r"[^0-9a-z]", "", name.lower())


def load_mapping(path: str | Path) -> MappingSpec:
    """Read a mapping file (.json, .yaml or .yml)."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise ClipImportError(f"cannot read mapping file '{path}': {exc.strerror or exc}") from exc
    try:
        if p.suffix.lower() in (".yaml", ".yml"):
            import yaml

            raw = yaml.safe_load(text)
        else:
            raw = json.loads(text)
    except Exception as exc:  # json/yaml errors
        raise ClipImportError(f"mapping file '{path}': cannot parse: {exc}") from exc
    return parse_mapping(raw, str(path))


def parse_mapping(raw: Any, where: str = "mapping") -> MappingSpec:
    """Check a mapping document `{"joints": {source: dof | {dof, axis, scale, offset} | null}}`."""
    if isinstance(raw, MappingSpec):
        return raw
    if not isinstance(raw, dict) or not isinstance(raw.get("joints"), dict):
        raise ClipImportError(f"{where}: expected an object with a 'joints' object "
                              "(source name -> DoF name or {dof, axis, scale, offset})")
    extra = set(raw) - {"joints"}
    if extra:
        raise ClipImportError(f"{where}: unknown keys {sorted(extra)} (only 'joints')")
    joints: dict[str, dict[str, Any] | None] = {}
    for src, entry in raw["joints"].items():
        here = f"{where}: joints.{src}"
        if entry is None:
            joints[str(src)] = None
            continue
        if isinstance(entry, str):
            entry = {"dof": entry}
        if not isinstance(entry, dict) or not isinstance(entry.get("dof"), str) or not entry["dof"]:
            raise ClipImportError(f"{here}: expected a DoF name or an object with 'dof'")
        bad = set(entry) - {"dof", "axis", "scale", "offset"}
        if bad:
            raise ClipImportError(f"{here}: unknown keys {sorted(bad)} (dof, axis, scale, offset)")
        out: dict[str, Any] = {"dof": entry["dof"]}
        if entry.get("axis") is not None:
            ax = entry["axis"]
            if not (isinstance(ax, (list, tuple)) and len(ax) == 3 and all(isinstance(x, (int, float)) for x in ax)):
                raise ClipImportError(f"{here}: axis must be [x, y, z]")
            try:
                out["axis"] = _unit(ax)
            except ClipImportError as exc:
                raise ClipImportError(f"{here}: {exc}") from None
        for k, default in (("scale", 1.0), ("offset", 0.0)):
            v = entry.get(k, default)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise ClipImportError(f"{here}: {k} must be a finite number")
            out[k] = float(v)
        joints[str(src)] = out
    return MappingSpec(joints, where)


def resolve_channel(ch: SourceChannel, emb: Embodiment, spec: MappingSpec | None) -> tuple[ChannelMap | None, str]:
    """The DoF a channel drives and how, or (None, reason)."""
    spec = spec or MappingSpec()
    entry: dict[str, Any] | None = None
    key = None
    if ch.kind == "scale":
        return None, "scale channel (no DoF takes a node's scale)"
    by_name = ch.kind == "rotation" or (ch.kind == "scalar" and not ch.path.startswith("weights"))
    for k in (f"{ch.name}.{ch.path}" if ch.path else None, ch.name if by_name else None):
        if k is not None and k in spec.joints:
            key = k
            entry = spec.joints[k]
            break
    if key is not None and entry is None:
        return None, f"ignored by the mapping file ('{key}': null)"
    if entry is not None:
        dof = entry["dof"]
        if not emb.has_dof(dof):
            return None, f"mapping file names DoF '{dof}', which robot '{emb.name}' does not have"
        how = f"mapping file ('{key}')"
        return _finish(ch, emb, dof, entry.get("axis"), entry["scale"], entry["offset"], how)
    if ch.kind == "translation":
        return None, (f"translation channel (map '{ch.name}.translation' to a linear DoF with --map to use it)")
    name = ch.name
    if ch.path.startswith("weights"):  # a morph target matches by its own name (mesh extras.targetNames)
        name = ch.path[len("weights["):-1]
        if name.isdigit():
            return None, "morph-target weight with no target name (map it with --map)"
    if emb.has_dof(name):
        return _finish(ch, emb, name, None, 1.0, 0.0, "exact name")
    norm = normalise_name(name)
    matches = [d.name for d in emb.dofs if normalise_name(d.name) == norm and norm]
    if len(matches) == 1:
        return _finish(ch, emb, matches[0], None, 1.0, 0.0, "name ignoring case and separators")
    if len(matches) > 1:
        return None, f"ambiguous name: matches DoFs {matches} (use --map)"
    return None, f"no DoF of that name on robot '{emb.name}' (use --map)"


def _finish(ch: SourceChannel, emb: Embodiment, dof_name: str, axis: np.ndarray | None, scale: float,
            offset: float, how: str) -> tuple[ChannelMap | None, str]:
    d = emb.dof(dof_name)
    if d.type is DofType.event:
        return None, f"DoF '{dof_name}' is an event DoF (takes events, not keys)"
    if ch.kind in ("rotation", "translation"):
        if d.type is not DofType.continuous:
            return None, f"DoF '{dof_name}' is {d.type.value}, not continuous"
        if axis is None:
            axis = dof_axis(emb, dof_name)
        if axis is None:
            return None, f"DoF '{dof_name}' has no joint axis (give 'axis' in the mapping file)"
        if ch.kind == "rotation" and d.dimension is Dimension.spatial and d.axis in ("x", "y", "z"):
            return None, f"DoF '{dof_name}' is a linear base axis; a rotation cannot drive it"
    elif d.type is DofType.colour:
        return None, f"DoF '{dof_name}' is a colour DoF (a single column cannot set it)"
    return ChannelMap(dof_name, None if axis is None else np.asarray(axis, dtype=float), scale, offset, how), ""
