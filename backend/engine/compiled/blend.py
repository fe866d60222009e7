"""The layer mixer's whole tick, compiled: fades, effective weights and the blend of every layer.

The numpy reference is `LayerMixer.tick` with `backend.engine.blend.blend_layers` and `advance_fades`
(the blend modes are documented there); this kernel performs the same operations channel by channel
in one call. Layers arrive concatenated (L*C values and masks) so the call's cost does not grow with
the number of layers.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from backend.engine.blend import BlendMode
from backend.engine.compiled import b1_1, b1_2, f8, f8_1, i8_1

#: Blend modes as the kernel's integer codes.
MODE_CODES = {BlendMode.override: 0, BlendMode.additive: 1, BlendMode.average: 2}


@njit(cache=True)
def mixer_tick(
    vals,
    masks,
    layer_masks,
    weights,
    fade_level,
    fade_target,
    fade_time,
    signal_weights,
    dt,
    modes,
    base,
    rest,
    enum,
    out,
    out_mask,
    w,
):
    """Advance the fades (in place), write each layer's effective weight to `w` (L,) and the blend of
    layers (values `vals` and masks `masks`, both (L*C,), layer-major) over `base` to `out`/`out_mask`."""
    n_layers, n = weights.shape[0], base.shape[0]
    for i in range(n_layers):  # advance_fades: toward the target at 1/fade_time per second
        step = dt / max(fade_time[i], 1e-9) if fade_time[i] > 0.0 else np.inf
        d = min(max(fade_target[i] - fade_level[i], -step), step)
        fade_level[i] = min(max(fade_level[i] + d, 0.0), 1.0)
        w[i] = weights[i] * fade_level[i] * signal_weights[i]
    any_enum = False
    for c in range(n):
        out[c] = base[c]
        out_mask[c] = False
        any_enum = any_enum or enum[c]
    # Average layers: one normalised weighted average over the base.
    has_avg = False
    for i in range(n_layers):
        has_avg = has_avg or modes[i] == 2
    if has_avg:
        for c in range(n):
            total = 0.0
            acc = 0.0
            best, heaviest = -1.0, 0.0
            for i in range(n_layers):
                if modes[i] != 2:
                    continue
                wi = min(max(w[i], 0.0), 1.0)
                wm = wi if (masks[i * n + c] and layer_masks[i, c] and wi > 0.0) else 0.0
                total += wm
                acc += wm * vals[i * n + c]
                if wm > best:  # argmax: the first of equal weights
                    best, heaviest = wm, vals[i * n + c]
            if total > 0.0:
                if any_enum and enum[c]:
                    out[c] = heaviest if total >= 0.5 else base[c]
                else:
                    out[c] = base[c] + min(total, 1.0) * (acc / total - base[c])
                out_mask[c] = True
    # Overrides and additive layers, bottom to top.
    for i in range(n_layers):
        mode = modes[i]
        if mode == 2:
            continue
        wi = min(max(w[i], 0.0), 1.0)
        if not wi > 0.0:
            continue
        for c in range(n):
            if not (masks[i * n + c] and layer_masks[i, c]):
                continue
            v = vals[i * n + c]
            if mode == 0:
                if any_enum and enum[c]:
                    if wi >= 0.5:
                        out[c] = v
                else:
                    out[c] = out[c] + wi * (v - out[c])
            else:
                if not (any_enum and enum[c]):
                    out[c] = out[c] + wi * (v - rest[c])
                elif wi >= 0.5 and v != rest[c]:
                    out[c] = v
            out_mask[c] = True


MIXER_SIG = (f8_1, b1_1, b1_2, f8_1, f8_1, f8_1, f8_1, f8_1, f8, i8_1, f8_1, f8_1, b1_1, f8_1, b1_1, f8_1)
