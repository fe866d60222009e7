"""BVH motion capture (.bvh) -> channels.

HIERARCHY: `ROOT`/`JOINT name { OFFSET x y z  CHANNELS n <ch>...  ...  End Site { OFFSET ... } }`
with channels `Xposition Yposition Zposition` and `Xrotation Yrotation Zrotation` in any order.
MOTION: `Frames: N`, `Frame Time: dt`, then N lines of channel values (rotations in degrees).

A joint's rotation is the product of its rotation channels in the order listed (R = R1 R2 R3, the
usual BVH convention); each joint gives one rotation channel (quaternions) and, if it has position
channels, one translation channel, both keyed linearly at every frame.

Rest pose: the frame the hierarchy's OFFSETs define (every rotation channel at 0, so each joint's
rest frame is aligned with the file's world axes), or with `rest_frame=N` the pose of frame N. A
rotation channel carries `pre` (the parent's rest world rotation) and `post` (the inverse of the
joint's own), so `pre * q * post` is its change from rest in world axes. Position channels are taken
relative to the first imported frame (or frame N).

Bad data stops the import with one short message naming the frame (index and time) and the channel:
a header number that is not finite (`OFFSET nan`, `Frames: nan`, `Frame Time: inf`), a value that is
not a number or not finite. With `fill="hold"|"linear"`, gaps of non-finite values of at most
`max_gap` frames are repaired instead (hold the last good value, or interpolate linearly).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from backend.importers.mapping import ClipImportError, SourceChannel
from backend.importers.rotations import IDENTITY, quat_axis_angle, quat_conj, quat_mul, quat_normalise
from backend.importers.sources import Importer, ReadOptions

_AXIS = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}
_CHANNELS = ("xposition", "yposition", "zposition", "xrotation", "yrotation", "zrotation")
FILL_MODES = ("hold", "linear")


@dataclass
class _Tokens:
    """The file's whitespace-separated words, read front to back."""

    words: list[str]
    where: str
    pos: int = 0

    def take(self) -> str:
        if self.pos >= len(self.words):
            raise ClipImportError(f"{self.where}: unexpected end of file")
        self.pos += 1
        return self.words[self.pos - 1]

    def expect(self, word: str) -> None:
        got = self.take()
        if got.upper() != word.upper():
            raise ClipImportError(f"{self.where}: expected '{word}', got '{got[:40]}'")


@dataclass
class _Hierarchy:
    """Joints in file order: names, parent index (-1: the root), channel names, OFFSETs."""

    names: list[str] = field(default_factory=list)
    parents: list[int] = field(default_factory=list)
    chans_of: list[list[str]] = field(default_factory=list)
    offsets: list[np.ndarray] = field(default_factory=list)

    def columns(self) -> list[str]:
        """The MOTION columns: `joint.Channel` in file order."""
        return [f"{self.names[j]}.{c}" for j in range(len(self.names)) for c in self.chans_of[j]]


def read_bvh(
    path: str | Path, *, rest_frame: int | None = None, fill: str | None = None, max_gap: int = 10
) -> tuple[list[SourceChannel], dict, list[str]]:
    """(channels, info, notes) of a BVH file; see the module's docstring."""
    path = Path(path)
    where = f"BVH '{path.name}'"
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ClipImportError(f"cannot read BVH file '{path}': {exc}") from exc
    tokens = _Tokens(text.split(), where)
    hier = _read_hierarchy(tokens)
    data, dt, notes = _read_motion(tokens, hier)
    n_frames = len(data)
    filled = _repair(data, hier.columns(), dt, where, fill, max_gap)
    if filled:
        per = ", ".join(f"{k} {v}" for k, v in filled.items())
        notes.append(f"--fill {fill}: filled {sum(filled.values())} sample(s) ({per})")
    if rest_frame is not None and not 0 <= rest_frame < n_frames:
        raise ClipImportError(
            f"{where}: --rest-frame {rest_frame} is not a frame of the file (0..{n_frames - 1})"
        )
    rest_note = "the OFFSET pose" if rest_frame is None else f"frame {rest_frame}"
    channels = _source_channels(hier, data, np.arange(n_frames) * dt, rest_frame, rest_note)
    info = {"frames": n_frames, "frame_time": dt, "joints": len(hier.names), "rest": rest_note}
    return channels, info, notes


class BvhImporter(Importer):
    """BVH motion capture: the OFFSET pose or `--rest-frame` is the rest pose, +Y up."""

    name = "bvh"
    label = "BVH"
    suffixes = (".bvh",)
    options = frozenset({"rest_frame"})

    @classmethod
    def read(cls, path: Path, options: ReadOptions) -> tuple[list[SourceChannel], dict[str, Any], list[str]]:
        return read_bvh(path, rest_frame=options.rest_frame, fill=options.fill, max_gap=options.max_gap)


def _read_hierarchy(tok: _Tokens) -> _Hierarchy:
    """HIERARCHY up to the root's closing brace."""
    where = tok.where
    tok.expect("HIERARCHY")
    hier = _Hierarchy()
    names = hier.names
    stack: list[int] = []  # joint indices; -1 for an End Site
    word = tok.take()
    if word.upper() != "ROOT":
        raise ClipImportError(f"{where}: expected 'ROOT', got '{word[:40]}'")
    while True:
        up = word.upper()
        if up in ("ROOT", "JOINT"):
            if up == "ROOT" and stack:
                raise ClipImportError(f"{where}: ROOT inside joint '{names[stack[-1]]}'")
            name = tok.take()
            tok.expect("{")
            hier.parents.append(next((i for i in reversed(stack) if i >= 0), -1))
            names.append(name)
            hier.chans_of.append([])
            hier.offsets.append(np.zeros(3))
            stack.append(len(names) - 1)
        elif up == "END":
            tok.expect("Site")
            tok.expect("{")
            stack.append(-1)
        elif up == "OFFSET":
            owner = stack[-1] if stack else -1
            label = f"joint '{names[owner]}'" if owner >= 0 else "an End Site"
            vals = [_number(tok.take(), f"{where}: {label}: OFFSET") for _ in range(3)]
            if owner >= 0:
                hier.offsets[owner] = np.array(vals)
        elif up == "CHANNELS":
            if not stack or stack[-1] < 0:
                raise ClipImportError(f"{where}: an End Site cannot have channels")
            hier.chans_of[stack[-1]].extend(_read_channel_names(tok, names[stack[-1]]))
        elif word == "}":
            if not stack:
                raise ClipImportError(f"{where}: unbalanced '}}'")
            stack.pop()
            if not stack:
                return hier
        else:
            raise ClipImportError(f"{where}: unexpected '{word[:40]}' in HIERARCHY")
        word = tok.take()


def _read_channel_names(tok: _Tokens, joint: str) -> list[str]:
    """`CHANNELS n <ch>...` after the keyword: the n channel names, each a known one."""
    n = _count(tok.take(), f"{tok.where}: joint '{joint}': CHANNELS")
    chans = [tok.take() for _ in range(n)]
    for c in chans:
        if c.lower() not in _CHANNELS:
            raise ClipImportError(f"{tok.where}: joint '{joint}': unknown channel '{c[:40]}'")
    return chans


def _read_motion(tok: _Tokens, hier: _Hierarchy) -> tuple[np.ndarray, float, list[str]]:
    """MOTION: (frames x columns values, frame time s, notes). Non-finite values are left to `_repair`."""
    where = tok.where
    tok.expect("MOTION")
    tok.expect("Frames:")
    n_frames = _count(tok.take(), f"{where}: Frames:")
    if n_frames < 1:
        raise ClipImportError(f"{where}: Frames: must be at least 1, got {n_frames}")
    tok.expect("Frame")
    tok.expect("Time:")
    dt = _number(tok.take(), f"{where}: Frame Time:")
    if dt <= 0:
        raise ClipImportError(f"{where}: Frame Time: must be > 0 s, got {dt:g}")
    columns = hier.columns()
    n_ch = len(columns)
    if n_ch == 0:
        raise ClipImportError(f"{where}: no joint has CHANNELS")
    values = tok.words[tok.pos : tok.pos + n_frames * n_ch]
    if len(values) < n_frames * n_ch:
        got = len(values) // n_ch
        raise ClipImportError(
            f"{where}: 'Frames: {n_frames}' but only {got} complete frame(s) of {n_ch} values "
            f"follow ({len(values)} values)"
        )
    data = _frames(values, n_frames, columns, dt, where)
    notes: list[str] = []
    extra = len(tok.words) - tok.pos - n_frames * n_ch
    if extra > 0:
        notes.append(f"{extra} value(s) after the {n_frames} frames announced by 'Frames:' were ignored")
    return data, dt, notes


def _frames(values: list[str], n_frames: int, columns: list[str], dt: float, where: str) -> np.ndarray:
    """The frame values as numbers; a word that is not one is an error naming its frame and column."""
    n_ch = len(columns)
    try:
        return np.array(values, dtype=float).reshape(n_frames, n_ch)
    except ValueError:
        for i, tok in enumerate(values):
            try:
                float(tok)
            except ValueError:
                f, c = divmod(i, n_ch)
                raise ClipImportError(
                    f"{where}: frame {f} (t = {f * dt:.4f} s): {columns[c]} is '{tok[:40]}', not a number"
                ) from None
        raise


def _joint_motion(hier: _Hierarchy, data: np.ndarray) -> tuple[list, list, list[str]]:
    """Per joint: local rotation quaternions per frame (None without rotation channels), positions
    per frame (None without position channels), and the rotation channels' order (e.g. "ZXY")."""
    n_frames = len(data)
    local: list[np.ndarray | None] = []
    positions: list[np.ndarray | None] = []
    orders: list[str] = []
    col = 0
    for chans in hier.chans_of:
        q = np.tile(IDENTITY, (n_frames, 1))
        p = np.zeros((n_frames, 3))
        has_rot = has_pos = False
        order = ""
        for c in chans:
            letter = c[0].lower()
            if c.lower().endswith("rotation"):
                q = quat_mul(q, quat_axis_angle(_AXIS[letter], np.radians(data[:, col])))
                has_rot = True
                order += letter.upper()
            else:
                p[:, "xyz".index(letter)] = data[:, col]
                has_pos = True
            col += 1
        local.append(quat_normalise(q) if has_rot else None)
        positions.append(p if has_pos else None)
        orders.append(order)
    return local, positions, orders


def _source_channels(
    hier: _Hierarchy, data: np.ndarray, times: np.ndarray, rest_frame: int | None, rest_note: str
) -> list[SourceChannel]:
    """A rotation channel per joint with rotation channels, a translation channel per joint with
    position channels, each carrying its rest pose (the OFFSET pose or frame `rest_frame`)."""
    names, parents = hier.names, hier.parents
    local, positions, orders = _joint_motion(hier, data)
    # rest: the OFFSET pose (identity rotations) or frame N
    rest_local = [IDENTITY if (rest_frame is None or q is None) else q[rest_frame] for q in local]
    rest_world: list[np.ndarray] = []
    for j in range(len(names)):
        base = rest_world[parents[j]] if parents[j] >= 0 else IDENTITY
        rest_world.append(quat_normalise(quat_mul(base, rest_local[j])))
    channels: list[SourceChannel] = []
    for j, name in enumerate(names):
        pre = rest_world[parents[j]] if parents[j] >= 0 else IDENTITY
        if local[j] is not None:
            channels.append(
                SourceChannel(
                    name,
                    "rotation",
                    times,
                    local[j],
                    "LINEAR",
                    path="rotation",
                    decimate=True,
                    detail=f"BVH channel order {orders[j]}",
                    pre=pre,
                    post=quat_conj(rest_world[j]),
                    unit="frame",
                    rest_note=rest_note,
                )
            )
        if positions[j] is not None:
            rest = None if rest_frame is None else positions[j][rest_frame]
            channels.append(
                SourceChannel(
                    name,
                    "translation",
                    times,
                    positions[j],
                    "LINEAR",
                    path="translation",
                    decimate=True,
                    pre=pre,
                    rest=rest,
                    unit="frame",
                    rest_note="first frame" if rest is None else rest_note,
                )
            )
    return channels


def _repair(
    data: np.ndarray, columns: list[str], dt: float, where: str, fill: str | None, max_gap: int
) -> dict[str, int]:
    """Check for non-finite values; with `fill`, repair gaps of at most `max_gap` frames in place.
    Returns the number of samples filled per column."""
    bad = ~np.isfinite(data)
    if not bad.any():
        return {}
    if fill is None:
        f, c = (int(x) for x in np.argwhere(bad)[0])
        n_bad_frames = int(bad.any(axis=1).sum())
        more = f" ({n_bad_frames} frames have such values)" if n_bad_frames > 1 else ""
        raise ClipImportError(
            f"{where}: frame {f} (t = {f * dt:.4f} s): {columns[c]} is {float(data[f, c])}, "
            f"not a finite number{more}\n"
            f"  --fill hold or --fill linear repairs gaps of up to {max_gap} frames"
        )
    filled: dict[str, int] = {}
    for c in np.flatnonzero(bad.any(axis=0)):
        col = data[:, c]
        good = np.flatnonzero(~bad[:, c])
        if good.size == 0:
            raise ClipImportError(
                f"{where}: {columns[c]} has no finite value in any frame; nothing to fill from"
            )
        runs = _runs(bad[:, c])
        for a, b in runs:  # frames a..b-1 are bad
            if b - a > max_gap:
                raise ClipImportError(
                    f"{where}: frames {a}-{b - 1} (t = {a * dt:.4f}-{(b - 1) * dt:.4f} s): "
                    f"{columns[c]} has a gap of {b - a} frames that are not finite numbers, "
                    f"longer than --max-gap {max_gap}"
                )
        if fill == "hold":
            for a, b in runs:
                col[a:b] = col[a - 1] if a > 0 else col[b]
        else:
            idx = np.arange(len(col))
            col[bad[:, c]] = np.interp(idx[bad[:, c]], good, col[good])
        filled[columns[c]] = int(bad[:, c].sum())
    return filled


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of each run of True."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def _number(tok: str, what: str) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise ClipImportError(f"{what} expected a number, got '{tok[:40]}'") from None
    if not math.isfinite(v):
        raise ClipImportError(f"{what} expected a finite number, got '{tok[:40]}'")
    return v


def _count(tok: str, what: str) -> int:
    try:
        v = int(tok)
    except ValueError:
        raise ClipImportError(f"{what} expected a whole number, got '{tok[:40]}'") from None
    if v < 0:
        raise ClipImportError(f"{what} expected a whole number >= 0, got {v}")
    return v
