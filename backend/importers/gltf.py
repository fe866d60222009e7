"""glTF 2.0 animations (.gltf with embedded data URIs or a .bin next to it, or binary .glb) -> channels.

Reads one animation: each channel targets a node's `rotation`, `translation`, `scale` or `weights`;
its sampler gives input times and output values through accessors (buffer views with or without a
byteStride, float or normalised integer components). CUBICSPLINE outputs are triplets
(in-tangent, value, out-tangent) per key.

Rest pose: every node's rest (bind) rotation in the file's world axes comes from the nodes' own
rest transforms (`rotation` or `matrix`, composed down the node tree) or, for a joint of a skin, from
the skin's inverse bind matrices (which hold the bind pose even when the nodes were exported in
another pose). A rotation channel carries `pre` (the parent's rest world rotation) and `post` (the
inverse of the node's rest world rotation), so its change from rest in world axes is
`pre * q(t) * post`.
"""

from __future__ import annotations

import base64
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import unquote

import numpy as np
from pygltflib import GLTF2

from backend.importers.clip_warnings import option_text
from backend.importers.gltf_animations import align_start, channels_named_elsewhere
from backend.importers.mapping import ClipImportError, SourceChannel
from backend.importers.rotations import IDENTITY, quat_conj, quat_from_matrix, quat_mul, quat_normalise
from backend.importers.sources import Importer, ReadOptions

_COMPONENT = {
    5120: np.int8,
    5121: np.uint8,
    5122: np.int16,
    5123: np.uint16,
    5125: np.uint32,
    5126: np.float32,
}
_NORMALISE = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0, 5125: 4294967295.0}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


class _Reader:
    def __init__(self, gltf: Any, folder: Path):
        self.gltf = gltf
        self.folder = folder
        self._buffers: dict[int, bytes] = {}

    def buffer(self, index: int) -> bytes:
        if index in self._buffers:
            return self._buffers[index]
        buf = _item(self.gltf.buffers, index, "buffer")
        uri = buf.uri
        if not uri:
            data = self.gltf.binary_blob()
            if data is None:
                raise ClipImportError(f"glTF: buffer {index} has no uri and the file has no binary chunk")
        elif uri.startswith("data:"):
            try:
                data = base64.b64decode(uri.split(",", 1)[1])
            except (IndexError, ValueError) as exc:
                raise ClipImportError(f"glTF: buffer {index}: bad data URI: {exc}") from exc
        else:
            path = self.folder / unquote(uri)
            try:
                data = path.read_bytes()
            except OSError as exc:
                raise ClipImportError(
                    f"glTF: buffer {index}: cannot read '{path}': {exc.strerror or exc}"
                ) from exc
        self._buffers[index] = bytes(data)
        return self._buffers[index]

    def accessor(self, index: int) -> np.ndarray:
        """The accessor's elements as a float array (count, width)."""
        acc = _item(self.gltf.accessors, index, "accessor")
        dtype = _COMPONENT.get(acc.componentType)
        width = _WIDTH.get(acc.type)
        if dtype is None or width is None:
            raise ClipImportError(
                f"glTF: accessor {index}: unsupported componentType {acc.componentType} or type {acc.type}"
            )
        dtype = np.dtype(dtype).newbyteorder("<")
        count = int(acc.count)
        if acc.bufferView is None:
            out = np.zeros((count, width))
        else:
            view = _item(self.gltf.bufferViews, acc.bufferView, f"accessor {index}: bufferView")
            data = self.buffer(view.buffer)
            start = int(view.byteOffset or 0) + int(acc.byteOffset or 0)
            elem = dtype.itemsize * width
            stride = int(view.byteStride or elem)
            need = start + (count - 1) * stride + elem if count else start
            end = int(view.byteOffset or 0) + int(view.byteLength)
            if need > min(end, len(data)):
                raise ClipImportError(f"glTF: accessor {index} reads past the end of its buffer view")
            arr = np.ndarray(
                (count, width), dtype=dtype, buffer=data, offset=start, strides=(stride, dtype.itemsize)
            )
            out = arr.astype(float)
            if acc.normalized and acc.componentType in _NORMALISE:
                out = out / _NORMALISE[acc.componentType]
                if acc.componentType in (5120, 5122):
                    out = np.maximum(out, -1.0)
        if getattr(acc, "sparse", None) is not None:
            out = self._apply_sparse(acc, out, width, index)
        return out

    def _apply_sparse(self, acc: Any, out: np.ndarray, width: int, index: int) -> np.ndarray:
        sp = acc.sparse
        out = out.copy()
        n = int(sp.count)
        idx_view = self.gltf.bufferViews[sp.indices.bufferView]
        idx_dtype = np.dtype(_COMPONENT[sp.indices.componentType]).newbyteorder("<")
        idx_data = self.buffer(idx_view.buffer)
        idx = np.frombuffer(
            idx_data,
            dtype=idx_dtype,
            count=n,
            offset=int(idx_view.byteOffset or 0) + int(sp.indices.byteOffset or 0),
        )
        val_view = self.gltf.bufferViews[sp.values.bufferView]
        val_dtype = np.dtype(_COMPONENT[acc.componentType]).newbyteorder("<")
        vals = np.frombuffer(
            self.buffer(val_view.buffer),
            dtype=val_dtype,
            count=n * width,
            offset=int(val_view.byteOffset or 0) + int(sp.values.byteOffset or 0),
        )
        vals = vals.reshape(n, width).astype(float)
        if acc.normalized and acc.componentType in _NORMALISE:
            vals = vals / _NORMALISE[acc.componentType]
        if np.any(idx >= len(out)):
            raise ClipImportError(f"glTF: accessor {index}: sparse index out of range")
        out[idx] = vals
        return out


def _load(path: Path) -> Any:

    try:
        return GLTF2().load(str(path))
    except Exception as exc:  # pygltflib raises many kinds for malformed files
        raise ClipImportError(f"cannot read glTF file '{path}': {exc}") from exc


@dataclass
class _Scene:
    """The node tree: unique node names, parent of each child node, and each node's rest pose (world
    rotation, local translation, where the rotation came from)."""

    names: list[str]
    parents: dict[int, int]
    rest_world: list[np.ndarray]
    rest_local: list[np.ndarray]
    rest_from: dict[int, str]


def read_gltf(
    path: str | Path, animation: str | int | None = None, wanted: frozenset[str] = frozenset()
) -> tuple[list[SourceChannel], dict[str, Any], list[str]]:
    """Channels of one animation of a glTF/GLB file, plus those the mapping file names (`wanted`) that
    only one other animation of the file animates; plus (source info, notes). The first key is t = 0."""
    path = Path(path)
    gltf = _load(path)
    anims = list(gltf.animations or [])
    if not anims:
        raise ClipImportError(f"'{path}' has no animations")
    names = [a.name or f"animation{i}" for i, a in enumerate(anims)]
    index = _animation_index(path, names, animation)
    notes: list[str] = []
    if len(anims) > 1:
        notes.append(
            f"file has {len(anims)} animations {names}; imported #{index} '{names[index]}' "
            f"(choose another with {_animation_hint(names, index)})"
        )
    anim = anims[index]
    reader = _Reader(gltf, path.parent)
    nodes = gltf.nodes or []
    node_names = _unique_names([n.name or f"node{i}" for i, n in enumerate(nodes)])
    rest_world, rest_local, rest_from = _rest_pose(gltf, reader, node_names)
    parents = {c: i for i, n in enumerate(nodes) for c in (n.children or []) if isinstance(c, int)}
    scene = _Scene(node_names, parents, rest_world, rest_local, rest_from)
    if any(v.startswith("skin") for v in rest_from.values()):
        notes.append(
            "rest pose: the skin's inverse bind matrices (joints), the nodes' rest transforms (others)"
        )
    channels = _animation_channels(gltf, reader, anim, scene, notes)
    if wanted and len(anims) > 1:
        others = {
            i: _animation_channels(gltf, reader, a, scene, []) for i, a in enumerate(anims) if i != index
        }
        channels += channels_named_elsewhere(wanted, channels, others, names, index, notes)
    info: dict[str, Any] = {"animation": names[index], "animation_index": index}
    shift = align_start(channels, notes)
    if shift:
        info["time_shift"] = shift
    return channels, info, notes


def _animation_channels(
    gltf: Any, reader: _Reader, anim: Any, scene: _Scene, notes: list[str]
) -> list[SourceChannel]:
    """The source channels of one animation."""
    channels: list[SourceChannel] = []
    for ci, ch in enumerate(anim.channels or []):
        channels.extend(_read_channel(gltf, reader, anim, ci, ch, scene, notes))
    return channels


class GltfImporter(Importer):
    """glTF 2.0 and GLB files: one animation (`--animation`), +Y up."""

    name = "gltf"
    label = "glTF"
    suffixes = (".gltf", ".glb")
    options = frozenset({"animation"})

    @classmethod
    def read(cls, path: Path, options: ReadOptions) -> tuple[list[SourceChannel], dict[str, Any], list[str]]:
        return read_gltf(path, options.animation, options.wanted)


def _animation_hint(names: list[str], index: int) -> str:
    """`--animation 1 or --animation walk` for an animation other than `index` (quoted for a shell)."""
    other = 1 if index == 0 else 0
    return f"{option_text('--animation', str(other))} or {option_text('--animation', names[other])}"


def _animation_index(path: Path, names: list[str], animation: str | int | None) -> int:
    """The animation chosen by name or index (default the first)."""
    if animation is None or animation == "":
        return 0
    if isinstance(animation, int) or (
        isinstance(animation, str) and animation.lstrip("-").isdigit() and animation not in names
    ):
        index = int(animation)
        if not 0 <= index < len(names):
            raise ClipImportError(
                f"'{path}' has {len(names)} animation(s); index {index} is out of range (animations: {names})"
            )
        return index
    if animation not in names:
        raise ClipImportError(f"'{path}' has no animation '{animation}' (animations: {names})")
    return names.index(animation)


def _read_channel(
    gltf: Any, reader: _Reader, anim: Any, ci: int, ch: Any, scene: _Scene, notes: list[str]
) -> list[SourceChannel]:
    """The source channels of animation channel `ci`: one, or one per morph target for `weights`;
    none (with a note) for a channel without target or with an unknown path."""
    target = ch.target
    if target is None or target.node is None:
        notes.append(f"channel {ci} has no target node; skipped")
        return []
    if not 0 <= target.node < len(scene.names):
        raise ClipImportError(f"glTF: channel {ci} targets node {target.node}, which does not exist")
    sampler = _item(anim.samplers, ch.sampler, f"channel {ci}: sampler")
    node = scene.names[target.node]
    times = _key_times(reader, sampler, f"{node}.{target.path}")
    out = reader.accessor(sampler.output)
    interp = (sampler.interpolation or "LINEAR").upper()
    if interp not in ("STEP", "LINEAR", "CUBICSPLINE"):
        raise ClipImportError(f"glTF: sampler {ch.sampler}: unknown interpolation '{interp}'")
    n = len(times)
    triplet = 3 if interp == "CUBICSPLINE" else 1
    if target.path in ("rotation", "translation", "scale"):
        if out.shape[0] != n * triplet:
            raise ClipImportError(
                f"glTF: channel {ci} ({node}.{target.path}): {n} times but {out.shape[0]} output values"
            )
        series = [(target.path, out)]
    elif target.path == "weights":
        if n == 0 or out.shape[0] % (n * triplet):
            raise ClipImportError(
                f"glTF: channel {ci} ({node}.weights): output count does not divide by the key count"
            )
        m = out.shape[0] // (n * triplet)
        flat = out[:, 0].reshape(n * triplet, m)
        tnames = _target_names(gltf, gltf.nodes[target.node], m)
        series = [(f"weights[{tnames[k]}]", flat[:, k : k + 1]) for k in range(m)]
    else:
        notes.append(f"channel {ci} ({node}) animates unknown path '{target.path}'; skipped")
        return []
    return [_source_channel(label, vals, times, interp, target.node, scene) for label, vals in series]


def _key_times(reader: _Reader, sampler: Any, label: str) -> np.ndarray:
    """A sampler's key times (s), which must be finite."""
    raw_t = reader.accessor(sampler.input)[:, 0]
    bad = np.flatnonzero(~np.isfinite(raw_t))
    if bad.size:
        k = int(bad[0])
        raise ClipImportError(
            f"glTF: {label}: key {k} has time {float(raw_t[k])}, not a finite "
            f"number (input accessor {sampler.input})"
        )
    # float32 times read back as the decimal they were written from (1.2, not 1.2000000476837158)
    return np.array([float(str(x)) for x in raw_t.astype(np.float32)])


def _source_channel(
    label: str, vals: np.ndarray, times: np.ndarray, interp: str, node_index: int, scene: _Scene
) -> SourceChannel:
    """One series of keys (CUBICSPLINE: in-tangent, value, out-tangent per key) with its rest pose."""
    n = len(times)
    kind = {"rotation": "rotation", "translation": "translation"}.get(label, "scalar")
    if label == "scale":
        kind = "scale"
    if interp == "CUBICSPLINE":
        v3 = vals.reshape(n, 3, vals.shape[1])
        in_t, value, out_t = v3[:, 0], v3[:, 1], v3[:, 2]
    else:
        in_t = out_t = None
        value = vals
    if kind == "scalar":
        value = value[:, 0]
        in_t = None if in_t is None else in_t[:, 0]
        out_t = None if out_t is None else out_t[:, 0]
    sc = SourceChannel(
        scene.names[node_index],
        kind,
        np.asarray(times, dtype=float),
        value,
        interp,
        in_t,
        out_t,
        path=label,
        unit="key",
    )
    p_idx = scene.parents.get(node_index)
    parent_world = scene.rest_world[p_idx] if p_idx is not None else IDENTITY
    if kind == "rotation":
        sc.pre = parent_world
        sc.post = quat_conj(scene.rest_world[node_index])
        sc.rest_note = scene.rest_from[node_index]
    elif kind == "translation":
        sc.pre = parent_world
        sc.rest = scene.rest_local[node_index]
        sc.rest_note = "node rest translation"
    return sc


def _item(items: Any, index: Any, what: str) -> Any:
    """items[index] for a glTF index that must exist (no negative indices, no None)."""
    if (
        isinstance(index, bool)
        or not isinstance(index, int)
        or not items
        or not 0 <= index < len(items)
        or items[index] is None
    ):
        raise ClipImportError(f"glTF: {what} {index!r} does not exist")
    return items[index]


def _node_rest(node: Any, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(rest rotation quaternion, rest translation) of a node, checked for NaN/inf."""
    if node.matrix is not None and len(node.matrix) == 16:
        m = np.asarray(node.matrix, dtype=float).reshape(4, 4).T  # column-major
        if not np.all(np.isfinite(m)):
            raise ClipImportError(
                f"glTF: node '{name}': its rest matrix has values that are not finite numbers"
            )
        if abs(np.linalg.det(m[:3, :3])) < 1e-12:
            return IDENTITY.copy(), m[:3, 3].copy()
        return quat_from_matrix(m[:3, :3]), m[:3, 3].copy()
    rot = np.asarray(node.rotation if node.rotation is not None else IDENTITY, dtype=float)
    tr = np.asarray(node.translation if node.translation is not None else [0.0, 0.0, 0.0], dtype=float)
    for what, arr, n in (("rotation", rot, 4), ("translation", tr, 3)):
        if arr.shape != (n,) or not np.all(np.isfinite(arr)):
            raise ClipImportError(
                f"glTF: node '{name}': its rest {what} {arr.tolist()} is not {n} finite numbers"
            )
    if np.linalg.norm(rot) < 1e-9:
        raise ClipImportError(f"glTF: node '{name}': its rest rotation has length 0")
    return quat_normalise(rot), tr


def _rest_pose(
    gltf: Any, reader: _Reader, names: list[str]
) -> tuple[list[np.ndarray], list[np.ndarray], dict[int, str]]:
    """Per node: rest rotation in world axes, rest local translation, and where the rest came from."""
    nodes = gltf.nodes or []
    local_q, local_t = zip(*[_node_rest(n, names[i]) for i, n in enumerate(nodes)]) if nodes else ((), ())
    parents = {c: i for i, n in enumerate(nodes) for c in (n.children or []) if isinstance(c, int)}
    world: dict[int, np.ndarray] = {}

    def w(i: int, depth: int = 0) -> np.ndarray:
        if i not in world:
            p = parents.get(i)
            base = w(p, depth + 1) if p is not None and depth < 1024 else IDENTITY
            world[i] = quat_normalise(quat_mul(base, local_q[i]))
        return world[i]

    out = [w(i) for i in range(len(nodes))]
    source = {i: "node rest rotations" for i in range(len(nodes))}
    for s_i, skin in enumerate(gltf.skins or []):
        joints = [j for j in (skin.joints or []) if isinstance(j, int) and 0 <= j < len(nodes)]
        if skin.inverseBindMatrices is None or not joints:
            continue
        ibm = reader.accessor(skin.inverseBindMatrices)
        if ibm.shape[1] != 16 or len(ibm) < len(skin.joints):
            raise ClipImportError(
                f"glTF: skin {s_i}: inverseBindMatrices has {len(ibm)} matrices for {len(skin.joints)} joints"
            )
        for k, j in enumerate(skin.joints):
            if not (isinstance(j, int) and 0 <= j < len(nodes)) or source.get(j) == "skin":
                continue
            m = ibm[k].reshape(4, 4).T
            if not np.all(np.isfinite(m)):
                raise ClipImportError(
                    f"glTF: skin {s_i}: the inverse bind matrix of joint '{names[j]}' has "
                    "values that are not finite numbers"
                )
            try:
                bind = np.linalg.inv(m)
            except np.linalg.LinAlgError:
                raise ClipImportError(
                    f"glTF: skin {s_i}: the inverse bind matrix of joint '{names[j]}' cannot be inverted"
                ) from None
            out[j] = quat_from_matrix(bind[:3, :3])
            source[j] = "skin"
    source = {i: ("skin inverse bind matrices" if v == "skin" else v) for i, v in source.items()}
    return out, list(local_t), source


def _unique_names(names: list[str]) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for n in names:
        if n in seen:
            seen[n] += 1
            out.append(f"{n}#{seen[n]}")
        else:
            seen[n] = 0
            out.append(n)
    return out


def _target_names(gltf: Any, node: Any, m: int) -> list[str]:
    names: list[str] = []
    if node.mesh is not None and gltf.meshes and 0 <= node.mesh < len(gltf.meshes):
        extras = gltf.meshes[node.mesh].extras or {}
        if isinstance(extras, dict) and isinstance(extras.get("targetNames"), list):
            names = [str(x) for x in extras["targetNames"]]
    if len(names) != m:
        names = [str(k) for k in range(m)]
    return names
