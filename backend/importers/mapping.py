"""Source channels, the robot's joint frames and the source-name -> robot-DoF mapping of the importers.

Every importer turns its file into `SourceChannel`s (a named, timed series of rotations,
translations or scalars) that carry their rest pose (`pre`, `post`, `rest`). `resolve_channel` then
decides which robot DoF(s) each channel drives:

1. an entry of the mapping file (`--map`), looked up as `"<name>.<path>"` (e.g. `Neck.rotation`,
   `Hips.translation`) and then as `"<name>"` (rotation and scalar channels only);
2. a DoF of exactly the same name;
3. a joint of exactly that name, or a joint whose child link has exactly that name (Blender bones are
   often named after the link they move), driven by a DoF of its own;
4. a DoF or joint name ignoring case and separators (`Head-Yaw` -> `head_yaw`); link names only
   match exactly (a mocap `Head` is not the link `head`).

Translation channels are only mapped by an explicit `"<name>.translation"` entry.

Mapping file (JSON or YAML)::

    {"joints": {"Neck": {"dof": "neck_pitch", "axis": [0, 1, 0], "scale": 1.0, "offset": 0.0},
                "HeadTurn": "head_yaw",
                "Head": [{"dof": "head_yaw"}, {"dof": "head_pitch"}],   # yaw, then pitch
                "Tail": null}}            # null: ignore this source channel

Every name must exist: a source name the file does not have, a DoF the robot does not have, two
entries for one source (`Head` and `Head.rotation`) or for one DoF are errors naming the closest
names. `axis` is in the robot's frame at rest (+X forward, +Z up), like the DoF's own axis.
"""

from __future__ import annotations

import difflib
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from backend.engine.embodiment import Dimension, DofType, Embodiment

# Source channels and the robot's joint frames live in their own modules; re-exported here, where the
# importers import them.
from backend.importers.channels import ChannelMap, ClipImportError, DofTarget, MappingSpec, SourceChannel
from backend.importers.robot_frames import dof_axis, dof_joint, robot_joint_frames, urdf_joint_axes
from backend.importers.rotations import (
    RotationError,
    check_axes,
    quat_axis_angle,
    quat_mul,
    swing_twist,
    twist_angle,
    unit,
)

__all__ = [
    "ChannelMap",
    "ClipImportError",
    "DofTarget",
    "MappingSpec",
    "SourceChannel",
    "check_mapping",
    "dof_axis",
    "dof_joint",
    "load_mapping",
    "normalise_name",
    "parse_mapping",
    "quat_axis_angle",
    "quat_mul",
    "resolve_channel",
    "robot_joint_frames",
    "swing_twist",
    "twist_angle",
    "urdf_joint_axes",
]


# --------------------------------------------------------------------------------------------------
# Mapping file
# --------------------------------------------------------------------------------------------------


def normalise_name(name: str) -> str:
    """Lower case without separators: `Head-Yaw`, `head_yaw` and `HeadYaw` all give `headyaw`."""
    return re.sub(r"[^0-9a-z]", "", name.lower())


def closest(name: str, candidates: list[str], n: int = 4) -> str:
    """`closest: a, b` (or the first few candidates) for an error message."""
    cands = sorted(set(candidates))
    by_norm = [c for c in cands if normalise_name(c) == normalise_name(name)]
    near = by_norm + [c for c in difflib.get_close_matches(name, cands, n=n, cutoff=0.5) if c not in by_norm]
    if not near:
        low = {c.lower(): c for c in cands}
        near = [low[c] for c in difflib.get_close_matches(name.lower(), list(low), n=n, cutoff=0.4)]
    if near:
        return "closest: " + ", ".join(near[:n])
    return "known: " + ", ".join(cands[:8]) + (", ..." if len(cands) > 8 else "") if cands else "none known"


def load_mapping(path: str | Path) -> MappingSpec:
    """Read a mapping file (.json, .yaml or .yml)."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise ClipImportError(f"cannot read mapping file '{path}': {exc.strerror or exc}") from exc
    try:
        if p.suffix.lower() in (".yaml", ".yml"):
            raw = yaml.safe_load(text)
        else:
            raw = json.loads(text)
    except Exception as exc:  # json/yaml errors
        raise ClipImportError(f"mapping file '{path}': cannot parse: {str(exc)[:200]}") from exc
    return parse_mapping(raw, str(path))


_ENTRY_KEYS = ("dof", "axis", "scale", "offset")


def _parse_entry(entry: Any, here: str) -> dict[str, Any]:
    if isinstance(entry, str):
        entry = {"dof": entry}
    if not isinstance(entry, dict) or not isinstance(entry.get("dof"), str) or not entry["dof"]:
        raise ClipImportError(f"{here}: expected a DoF name, an object with 'dof', or a list of them")
    bad = set(entry) - set(_ENTRY_KEYS)
    if bad:
        raise ClipImportError(f"{here}: unknown keys {sorted(bad)} (dof, axis, scale, offset)")
    out: dict[str, Any] = {"dof": entry["dof"]}
    if entry.get("axis") is not None:
        ax = entry["axis"]
        if not (
            isinstance(ax, (list, tuple))
            and len(ax) == 3
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in ax)
        ):
            raise ClipImportError(f"{here}: axis must be [x, y, z]")
        try:
            out["axis"] = unit(ax)
        except RotationError as exc:
            raise ClipImportError(f"{here}: {exc}") from None
    for k, default in (("scale", 1.0), ("offset", 0.0)):
        v = entry.get(k, default)
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            raise ClipImportError(f"{here}: {k} must be a finite number")
        out[k] = float(v)
    return out


def parse_mapping(raw: Any, where: str = "mapping") -> MappingSpec:
    """Check a mapping document `{"joints": {source: dof | {dof, axis, scale, offset} | [..] | null}}`."""
    if isinstance(raw, MappingSpec):
        return raw
    if not isinstance(raw, dict) or not isinstance(raw.get("joints"), dict):
        raise ClipImportError(
            f"{where}: expected an object with a 'joints' object "
            "(source name -> DoF name, {dof, axis, scale, offset}, a list of them, or null)"
        )
    extra = set(raw) - {"joints"}
    if extra:
        raise ClipImportError(f"{where}: unknown keys {sorted(extra)} (only 'joints')")
    joints: dict[str, list[dict[str, Any]] | None] = {}
    for src, entry in raw["joints"].items():
        here = f"{where}: joints.{src}"
        if entry is None:
            joints[str(src)] = None
            continue
        if isinstance(entry, list):
            if not entry:
                raise ClipImportError(f"{here}: an empty list (use null to ignore a source)")
            if len(entry) > 3:
                raise ClipImportError(f"{here}: one rotation can drive at most 3 DoFs, got {len(entry)}")
            items = [_parse_entry(e, f"{here}[{i}]") for i, e in enumerate(entry)]
        else:
            items = [_parse_entry(entry, here)]
        dofs = [e["dof"] for e in items]
        dup = sorted({d for d in dofs if dofs.count(d) > 1})
        if dup:
            raise ClipImportError(f"{here}: DoF {dup[0]!r} is listed twice")
        joints[str(src)] = items
    # one source named twice (Head and Head.rotation), one DoF driven from two entries
    by_base: dict[str, list[str]] = {}
    for k in joints:
        base = k.split(".", 1)[0]
        by_base.setdefault(base, []).append(k)
    for base, keys in by_base.items():
        if base in keys and any(k.startswith(base + ".rotation") for k in keys if k != base):
            other = next(k for k in keys if k != base and k.startswith(base + ".rotation"))
            raise ClipImportError(f"{where}: '{base}' and '{other}' both map the same rotation; keep one")
    owner: dict[str, str] = {}
    for k, items in joints.items():
        for e in items or []:
            if e["dof"] in owner:
                raise ClipImportError(
                    f"{where}: DoF '{e['dof']}' is driven by both '{owner[e['dof']]}' "
                    f"and '{k}'; a DoF takes one source"
                )
            owner[e["dof"]] = k
    return MappingSpec(joints, where)


def check_mapping(spec: MappingSpec, channels: list[SourceChannel], emb: Embodiment, file_name: str) -> None:
    """Every entry must name a source of the file and DoFs of the robot (errors list the closest)."""
    names = sorted({ch.name for ch in channels})
    labels = sorted({ch.label for ch in channels})
    for key, items in spec.joints.items():
        if key not in labels and key not in names:
            raise ClipImportError(
                f"{spec.path}: joints.{key}: '{file_name}' has no animated source '{key}' "
                f"({closest(key, labels + names)})"
            )
        if key in names and key not in labels:
            kinds = {ch.kind for ch in channels if ch.name == key}
            if items is not None and kinds <= {"translation", "scale"}:
                raise ClipImportError(
                    f"{spec.path}: joints.{key}: '{key}' has only "
                    f"{'/'.join(sorted(kinds))} channels; name it '{key}.translation'"
                )
        for e in items or []:
            if not emb.has_dof(e["dof"]):
                raise ClipImportError(
                    f"{spec.path}: joints.{key}: robot '{emb.name}' has no DoF '{e['dof']}' "
                    f"({closest(e['dof'], emb.dof_names)})"
                )
        if items and len(items) > 1:
            _check_split(spec, key, channels)


def _by_bare_name(ch: SourceChannel) -> bool:
    """A bare source name (`Head`) maps the source's rotation, or a scalar column; never its
    translation, scale or morph weights (those are named `Head.translation`, ...)."""
    return ch.kind == "rotation" or (ch.kind == "scalar" and not ch.path.startswith("weights"))


def _check_split(spec: MappingSpec, key: str, channels: list[SourceChannel]) -> None:
    """Entry `key` lists several DoFs: it must name a rotation (which is split between their axes)."""
    chs = [ch for ch in channels if ch.label == key or (ch.name == key and _by_bare_name(ch))]
    other = [ch for ch in chs if ch.kind != "rotation"]
    if other or not chs:
        what = f"'{other[0].label}' is a {other[0].kind} channel" if other else f"'{key}' has no rotation"
        raise ClipImportError(
            f"{spec.path}: joints.{key}: {what}; only a rotation can drive several DoFs "
            "(it is split between their axes)"
        )


# --------------------------------------------------------------------------------------------------
# Resolution
# --------------------------------------------------------------------------------------------------


def _joint_dofs(emb: Embodiment) -> dict[str, str]:
    """URDF joint name -> the (non-symbolic, stationary) DoF that drives it 1:1."""
    return {d.joint: d.name for d in emb.dofs if d.joint and not d.drives}


def resolve_channel(
    ch: SourceChannel, emb: Embodiment, spec: MappingSpec | None
) -> tuple[ChannelMap | None, str]:
    """The DoF(s) a channel drives and how, or (None, reason)."""
    spec = spec or MappingSpec()
    items: list[dict[str, Any]] | None = None
    key = None
    if ch.kind == "scale":
        return None, "scale channel (no DoF takes a node's scale)"
    by_name = ch.kind == "rotation" or (ch.kind == "scalar" and not ch.path.startswith("weights"))
    for k in (f"{ch.name}.{ch.path}" if ch.path else None, ch.name if by_name else None):
        if k is not None and k in spec.joints:
            key = k
            items = spec.joints[k]
            break
    if key is not None and items is None:
        return None, f"ignored by the mapping file ('{key}': null)"
    if items is not None:
        for e in items:
            if not emb.has_dof(e["dof"]):
                return None, f"mapping file names DoF '{e['dof']}', which robot '{emb.name}' does not have"
        how = f"mapping file ('{key}')"
        if len(items) > 1:
            how += ", split in order " + " then ".join(e["dof"] for e in items)
        return _finish(ch, emb, [(e["dof"], e.get("axis"), e["scale"], e["offset"]) for e in items], how, key)
    if ch.kind == "translation":
        return None, (
            f"translation channel (map '{ch.name}.translation' to a linear DoF in a --map FILE to use it)"
        )
    name = ch.name
    if ch.path.startswith("weights"):  # a morph target matches by its own name (mesh extras.targetNames)
        name = ch.path[len("weights[") : -1]
        if name.isdigit():
            return None, "morph-target weight with no target name (map it in a --map FILE)"
    if emb.has_dof(name):
        return _finish(ch, emb, [(name, None, 1.0, 0.0)], "exact name")
    joint_dofs = _joint_dofs(emb)
    links = {j.child: j.name for j in emb.joints if j.child}
    if ch.kind == "rotation":
        if name in joint_dofs:
            return _finish(ch, emb, [(joint_dofs[name], None, 1.0, 0.0)], f"joint '{name}'")
        if name in links and links[name] in joint_dofs:
            return _finish(
                ch, emb, [(joint_dofs[links[name]], None, 1.0, 0.0)], f"child link of joint '{links[name]}'"
            )
    norm = normalise_name(name)
    matches = sorted({d.name for d in emb.dofs if normalise_name(d.name) == norm and norm})
    if (
        not matches and ch.kind == "rotation" and norm
    ):  # link names only match exactly (Head is no link 'head')
        matches = sorted({dof for j, dof in joint_dofs.items() if normalise_name(j) == norm})
    if len(matches) == 1:
        return _finish(ch, emb, [(matches[0], None, 1.0, 0.0)], "name ignoring case and separators")
    if len(matches) > 1:
        return None, f"ambiguous name: matches DoFs {matches} (choose one in a --map FILE)"
    return None, f"no DoF of that name on robot '{emb.name}' (map it in a --map FILE)"


def _finish(
    ch: SourceChannel,
    emb: Embodiment,
    items: list[tuple[str, Any, float, float]],
    how: str,
    key: str | None = None,
) -> tuple[ChannelMap | None, str]:
    targets: list[DofTarget] = []
    for dof_name, axis, scale, offset in items:
        d = emb.dof(dof_name)
        given = axis is not None
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
        targets.append(
            DofTarget(dof_name, None if axis is None else np.asarray(axis, dtype=float), scale, offset, given)
        )
    if len(targets) > 1:
        try:
            check_axes([t.axis for t in targets if t.axis is not None])  # a rotation's: every one has one
        except RotationError as exc:
            raise ClipImportError(f"{key}: {' then '.join(t.dof for t in targets)}: {exc}") from None
    return ChannelMap(targets, how, key), ""
