"""Layer blending: pure functions over arrays (layers x channels), the heart of the Level 2 APU.

Modes (per layer):
- `average`: all average layers form one normalised weighted average over the base pose; where their
  summed weight s < 1 the result is `base + s * (avg - base)`, so a single layer fading in moves
  smoothly from the base to its pose.
- `override`: applied after the averages, bottom to top (later layers have priority):
  `acc = acc + w * (v - acc)` on the layer's mask; a full-weight override on a full mask returns it.
- `additive`: `acc = acc + w * (v - rest)`, an offset from the rest pose; `v == rest` is identity.
Enum channels (face expressions) are never interpolated (index 1.5 means nothing): an override
switches to the layer's option once its weight reaches 0.5, average layers contribute the option of
the heaviest layer, and an additive layer switches to its option only where that differs from the rest
option (an option has no offset; the rest option means "no change", so a zero additive layer stays the
identity).
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np


class BlendMode(StrEnum):
    override = "override"
    additive = "additive"
    average = "average"


def blend_layers(
    values: np.ndarray,
    masks: np.ndarray,
    weights: np.ndarray,
    modes: list[BlendMode],
    base: np.ndarray,
    rest: np.ndarray,
    enum_channels: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Blend L layers into one PAF.

    values (L, C), masks (L, C) bool, weights (L,) in [0, 1] (layer weight x fade), modes (L,),
    base (C,) the pose under every layer (usually the rest pose), rest (C,) the additive reference.
    Returns (values (C,), mask (C,)): mask marks channels any layer with weight > 0 touched.
    """
    n_layers = values.shape[0]
    out = base.astype(float, copy=True)
    out_mask = np.zeros(base.shape[0], dtype=bool)
    if n_layers == 0:
        return out, out_mask
    enum = np.zeros(base.shape[0], dtype=bool) if enum_channels is None else enum_channels
    w = np.clip(weights, 0.0, 1.0)
    active = masks & (w > 0.0)[:, None]

    avg_rows = np.array([m is BlendMode.average for m in modes], dtype=bool)
    if avg_rows.any():
        wm = np.where(active[avg_rows], w[avg_rows, None], 0.0)
        total = wm.sum(axis=0)
        touched = total > 0.0
        safe = np.where(touched, total, 1.0)
        avg = (wm * values[avg_rows]).sum(axis=0) / safe
        blended = base + np.minimum(total, 1.0) * (avg - base)
        if enum.any():
            heaviest = values[avg_rows][np.argmax(wm, axis=0), np.arange(base.shape[0])]
            blended = np.where(enum, np.where(total >= 0.5, heaviest, base), blended)
        out = np.where(touched, blended, out)
        out_mask |= touched

    for i, mode in enumerate(modes):
        if mode is BlendMode.average:
            continue
        m = active[i]
        if not m.any():
            continue
        if mode is BlendMode.override:
            mixed = out + w[i] * (values[i] - out)
            if enum.any():
                mixed = np.where(enum, values[i] if w[i] >= 0.5 else out, mixed)
            out = np.where(m, mixed, out)
        else:
            out = np.where(m & ~enum, out + w[i] * (values[i] - rest), out)
            if enum.any() and w[i] >= 0.5:
                out = np.where(m & enum & (values[i] != rest), values[i], out)
        out_mask |= m
    return out, out_mask


def advance_fades(level: np.ndarray, target: np.ndarray, fade_time: np.ndarray, dt: float) -> np.ndarray:
    """Move each layer's fade level (0..1) toward its target at 1/fade_time per second (0 s = instant)."""
    step = np.where(fade_time > 0.0, dt / np.maximum(fade_time, 1e-9), np.inf)
    return np.clip(level + np.clip(target - level, -step, step), 0.0, 1.0)
