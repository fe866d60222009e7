"""BVH motion capture (.bvh) -> channels.

HIERARCHY: `ROOT`/`JOINT name { OFFSET x y z  CHANNELS n <ch>...  ...  End Site { OFFSET ... } }`
with channels `Xposition Yposition Zposition` and `Xrotation Yrotation Zrotation` in any order.
MOTION: `Frames: N`, `Frame Time: dt`, then N lines of channel values (rotations in degrees).

A joint's rotation is the product of its rotation channels in the order listed (R = R1 R2 R3, the
usual BVH convention); each joint gives one rotation channel (quaternions) and, if it has position
channels, one translation channel, both keyed linearly at every frame.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from backend.importers.mapping import ClipImportError, SourceChannel, quat_axis_angle, quat_mul

_AXIS = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}


def read_bvh(path: str | Path) -> tuple[list[SourceChannel], dict, list[str]]:
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ClipImportError(f"cannot read BVH file '{path}': {exc}") from exc
    tokens = text.split()
    pos = 0

    def take() -> str:
        nonlocal pos
        if pos >= len(tokens):
            raise ClipImportError(f"BVH '{path.name}': unexpected end of file")
        pos += 1
        return tokens[pos - 1]

    def expect(word: str) -> None:
        got = take()
        if got.upper() != word.upper():
            raise ClipImportError(f"BVH '{path.name}': expected '{word}', got '{got}'")

    expect("HIERARCHY")
    joints: list[tuple[str, list[str]]] = []  # (name, channel names) in file order
    stack: list[str] = []
    word = take()
    if word.upper() != "ROOT":
        raise ClipImportError(f"BVH '{path.name}': expected 'ROOT', got '{word}'")
    while True:
        if word.upper() in ("ROOT", "JOINT"):
            name = take()
            expect("{")
            stack.append(name)
            joints.append((name, []))
            current = len(joints) - 1
        elif word.upper() == "END":
            expect("Site")
            expect("{")
            stack.append("")
            current = -1
        elif word.upper() == "OFFSET":
            for _ in range(3):
                _number(take(), path)
        elif word.upper() == "CHANNELS":
            if current < 0:
                raise ClipImportError(f"BVH '{path.name}': an End Site cannot have channels")
            n = int(_number(take(), path))
            chans = [take() for _ in range(n)]
            for c in chans:
                if c.lower() not in ("xposition", "yposition", "zposition", "xrotation", "yrotation", "zrotation"):
                    raise ClipImportError(f"BVH '{path.name}': joint '{joints[current][0]}': unknown channel '{c}'")
            joints[current][1].extend(chans)
        elif word == "}":
            if not stack:
                raise ClipImportError(f"BVH '{path.name}': unbalanced '}}'")
            stack.pop()
            if not stack:
                break
            # back in the parent joint (End Sites have no channels anyway)
            current = next((i for i in range(len(joints) - 1, -1, -1) if joints[i][0] == stack[-1]), -1)
        else:
            raise ClipImportError(f"BVH '{path.name}': unexpected '{word}' in HIERARCHY")
        word = take()
    expect("MOTION")
    expect("Frames:")
    n_frames = int(_number(take(), path))
    expect("Frame")
    expect("Time:")
    dt = _number(take(), path)
    if dt <= 0:
        raise ClipImportError(f"BVH '{path.name}': Frame Time must be > 0, got {dt}")
    n_ch = sum(len(c) for _, c in joints)
    values = tokens[pos:pos + n_frames * n_ch]
    if len(values) < n_frames * n_ch or n_frames < 1:
        raise ClipImportError(f"BVH '{path.name}': expected {n_frames} frames of {n_ch} values, "
                              f"got {len(values)} values")
    try:
        data = np.array(values, dtype=float).reshape(n_frames, n_ch)
    except ValueError as exc:
        raise ClipImportError(f"BVH '{path.name}': bad number in MOTION: {exc}") from exc
    times = np.arange(n_frames) * dt
    channels: list[SourceChannel] = []
    col = 0
    for name, chans in joints:
        q = np.tile([0.0, 0.0, 0.0, 1.0], (n_frames, 1))
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
        if has_rot:
            channels.append(SourceChannel(name, "rotation", times, q, "LINEAR", path="rotation",
                                          decimate=True, detail=f"BVH channel order {order}"))
        if has_pos:
            channels.append(SourceChannel(name, "translation", times, p, "LINEAR", path="translation",
                                          decimate=True))
    return channels, {"frames": n_frames, "frame_time": dt}, []


def _number(tok: str, path: Path) -> float:
    try:
        return float(tok)
    except ValueError:
        raise ClipImportError(f"BVH '{path.name}': expected a number, got '{tok}'") from None
