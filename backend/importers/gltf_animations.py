"""What a glTF file's times and animations mean for a clip: where t = 0 is, and which animation holds a
channel the mapping file names.

Time zero. glTF times have no start frame. Blender's exporter writes a key at frame f as `f / fps`
(frame 1 of a scene starting at frame 1 is t = 1/24 s at 24 fps), whatever the scene's start frame;
only "Set All glTF Animation Starting at 0" (`export_anim_slide_to_zero`), and animations starting on
negative frames under the default "Negative Frames: Slide", write `(f - first frame) / fps`. The clip's
t = 0 is the animation's first frame, as the Nutty add-on exports it (`(f - scene.frame_start) / fps`),
so the importer makes the first key t = 0 and says by how much it moved the times; a scene starting
before its first key is what a file cannot tell.

Animations. Blender exports each action as its own glTF animation: an armature's action and a mesh's
shape-key action are two. A channel the mapping file names explicitly (`Face.weights[smile]`) that the
imported animation does not animate is taken from the one other animation that does, with a note.
"""

from __future__ import annotations

import numpy as np

from backend.importers.clip_warnings import option_text
from backend.importers.mapping import ClipImportError, SourceChannel


def align_start(channels: list[SourceChannel], notes: list[str]) -> float:
    """Shift every channel's key times so the first key of them all is t = 0; the shift (s) added."""
    keyed = [ch for ch in channels if len(ch.times)]
    t0 = min((float(ch.times[0]) for ch in keyed), default=0.0)
    if t0 == 0.0:
        return 0.0
    for ch in channels:
        ch.times = np.round(np.asarray(ch.times, dtype=float) - t0, 9)
    notes.append(
        f"the animation's first key is at {t0:.6g} s{_as_frame(channels, t0)} in the file; shifted by "
        f"{-t0:+.6g} s so it is the clip's t = 0"
    )
    return round(-t0, 9)


def _as_frame(channels: list[SourceChannel], t0: float) -> str:
    """` (frame 1 at 24 fps)` when the keys are samples at a whole frame rate and t0 is a whole frame
    of it, else ''."""
    steps = [float(np.median(np.diff(ch.times))) for ch in channels if len(ch.times) >= 4]
    if not steps or min(steps) <= 0:
        return ""
    fps = 1.0 / min(steps)
    if abs(fps - round(fps)) > 1e-3 * fps:
        return ""
    frame = t0 * round(fps)
    if abs(frame - round(frame)) > 1e-3:
        return ""
    return f" (frame {round(frame)} at {round(fps)} fps)"


def _names(key: str, ch: SourceChannel) -> bool:
    """Mapping key `key` names channel `ch`: by its label (`Face.weights[smile]`, `Head.rotation`) or,
    for a bare name, its rotation or scalar."""
    if ch.label == key:
        return True
    return ch.name == key and (
        ch.kind == "rotation" or (ch.kind == "scalar" and not ch.path.startswith("weights"))
    )


def channels_named_elsewhere(
    wanted: frozenset[str],
    channels: list[SourceChannel],
    others: dict[int, list[SourceChannel]],
    names: list[str],
    index: int,
    notes: list[str],
) -> list[SourceChannel]:
    """The channels of other animations (`others`: index -> channels) that a mapping key in `wanted`
    names and animation `index` (`channels`) does not animate: from the one animation that has them.
    A key that several other animations animate is a ClipImportError saying how to choose."""
    extra: list[SourceChannel] = []
    for key in sorted(wanted):
        if any(_names(key, ch) for ch in channels):
            continue
        found = {i: [ch for ch in chs if _names(key, ch)] for i, chs in others.items()}
        found = {i: chs for i, chs in found.items() if chs}
        if len(found) > 1:
            hints = " or ".join(option_text("--animation", names[i]) for i in found)
            raise ClipImportError(
                f"the mapping file names '{key}', which animation #{index} '{names[index]}' does not "
                f"animate but {len(found)} others do ({', '.join(repr(names[i]) for i in found)}): "
                f"import the one you mean, e.g. {hints}"
            )
        for i, chs in found.items():
            extra.extend(chs)
            notes.append(
                f"'{key}' is not in animation #{index} '{names[index]}'; taken from #{i} '{names[i]}' "
                "(Blender exports each action, e.g. a mesh's shape keys, as an animation of its own)"
            )
    return extra
