"""The blend algebra of the Level 2 APU (hypothesis properties) and layer fades."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from backend.engine.blend import BlendMode, advance_fades, blend_layers

C = 7
vals = arrays(np.float64, (C,), elements=st.floats(-3, 3))
masks = arrays(np.bool_, (C,))
weight = st.floats(0.0, 1.0)


def blend(layers, base=None, rest=None):
    v = np.stack([x[0] for x in layers])
    m = np.stack([x[1] for x in layers])
    w = np.array([x[2] for x in layers])
    modes = [x[3] for x in layers]
    base = np.zeros(C) if base is None else base
    rest = base if rest is None else rest
    return blend_layers(v, m, w, modes, base, rest)


@settings(max_examples=150, deadline=None)
@given(
    lower=st.lists(st.tuples(vals, masks, weight, st.sampled_from(list(BlendMode))), max_size=3),
    top=vals,
    base=vals,
)
def test_full_override_returns_top_layer(lower, top, base):
    out, mask = blend([*lower, (top, np.ones(C, bool), 1.0, BlendMode.override)], base=base)
    np.testing.assert_allclose(out, top, atol=1e-12)
    assert mask.all()


@settings(max_examples=150, deadline=None)
@given(
    lower=st.lists(
        st.tuples(vals, masks, weight, st.sampled_from([BlendMode.override, BlendMode.average])),
        min_size=1,
        max_size=3,
    ),
    rest=vals,
    m=masks,
    w=weight,
)
def test_additive_zero_is_identity(lower, rest, m, w):
    without, _mask_a = blend(lower, base=rest)
    with_zero, _mask_b = blend([*lower, (rest.copy(), m, w, BlendMode.additive)], base=rest)
    np.testing.assert_allclose(with_zero, without, atol=1e-12)


@settings(max_examples=150, deadline=None)
@given(a=vals, b=vals, w=weight)
def test_override_weight_interpolates(a, b, w):
    out, _ = blend(
        [(a, np.ones(C, bool), 1.0, BlendMode.override), (b, np.ones(C, bool), w, BlendMode.override)]
    )
    np.testing.assert_allclose(out, a + w * (b - a), atol=1e-12)


@settings(max_examples=150, deadline=None)
@given(a=vals, b=vals, wa=st.floats(0.05, 1.0), wb=st.floats(0.05, 1.0))
def test_average_is_normalised_weighted_mean(a, b, wa, wb):
    full = np.ones(C, bool)
    out, _ = blend([(a, full, wa, BlendMode.average), (b, full, wb, BlendMode.average)], base=np.zeros(C))
    mean = (wa * a + wb * b) / (wa + wb)
    np.testing.assert_allclose(out, min(wa + wb, 1.0) * mean, atol=1e-9)


@settings(max_examples=150, deadline=None)
@given(
    layers=st.lists(st.tuples(vals, masks, weight, st.sampled_from(list(BlendMode))), min_size=1, max_size=4),
    base=vals,
)
def test_masks_confine_each_layer(layers, base):
    out, mask = blend(layers, base=base)
    union = np.zeros(C, bool)
    for _, m, w, _ in layers:
        if w > 0:
            union |= m
    np.testing.assert_array_equal(mask, union)
    np.testing.assert_allclose(out[~union], base[~union])


@settings(max_examples=100, deadline=None)
@given(a=vals, off=vals, w=weight, rest=vals)
def test_additive_adds_weighted_offset_from_rest(a, off, w, rest):
    full = np.ones(C, bool)
    out, _ = blend(
        [(a, full, 1.0, BlendMode.override), (rest + off, full, w, BlendMode.additive)], base=rest, rest=rest
    )
    np.testing.assert_allclose(out, a + w * off, atol=1e-9)


def test_zero_weight_layer_has_no_effect():
    a, b = np.full(C, 1.0), np.full(C, 5.0)
    full = np.ones(C, bool)
    out, _ = blend([(a, full, 1.0, BlendMode.override), (b, full, 0.0, BlendMode.override)])
    np.testing.assert_allclose(out, a)


def test_enum_channels_switch_half_way():
    full = np.ones(2, bool)
    v = np.array([[0.0, 0.0], [3.0, 3.0]])
    enum = np.array([True, False])
    for w, expect in ((0.4, 0.0), (0.6, 3.0)):
        out, _ = blend_layers(
            v,
            np.stack([full, full]),
            np.array([1.0, w]),
            [BlendMode.override, BlendMode.override],
            np.zeros(2),
            np.zeros(2),
            enum,
        )
        assert out[0] == expect
        assert out[1] == np.float64(3.0 * w)


def test_fades_move_at_one_over_fade_time():
    level = np.array([0.0, 1.0, 0.0])
    target = np.array([1.0, 0.0, 1.0])
    fade = np.array([0.5, 0.25, 0.0])
    level = advance_fades(level, target, fade, 0.1)
    np.testing.assert_allclose(level, [0.2, 0.6, 1.0])
    for _ in range(10):
        level = advance_fades(level, target, fade, 0.1)
    np.testing.assert_allclose(level, target)
