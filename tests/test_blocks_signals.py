"""Signal blocks: math, LFO and the emotion mapper."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from backend.engine.blocks import BLOCKS, BlockContext
from backend.engine.blocks.signals import SETTLE


def make(desk, type_name, **kw):
    cls = BLOCKS[type_name]
    return cls(cls.Params(**kw), BlockContext(embodiment=desk, rate=100.0), "n")


@pytest.mark.parametrize(
    "op,a,b,expected",
    [
        ("add", 2.0, 3.0, 5.0),
        ("subtract", 2.0, 3.0, -1.0),
        ("multiply", 2.0, 3.0, 6.0),
        ("divide", 3.0, 2.0, 1.5),
        ("min", 2.0, 3.0, 2.0),
        ("max", 2.0, 3.0, 3.0),
        ("abs", -2.5, 0.0, 2.5),
    ],
)
def test_math_binary_ops(desk, op, a, b, expected):
    blk = make(desk, "math", op=op)
    assert blk.tick(0.01, {"a": a, "b": b})["value"] == pytest.approx(expected)


def test_math_params_are_defaults_for_unconnected_inputs(desk):
    blk = make(desk, "math", op="multiply", a=2.0, b=4.0)
    assert blk.tick(0.01, {})["value"] == 8.0
    assert blk.tick(0.01, {"b": 0.5})["value"] == 1.0


def test_math_map_range_clamp_and_smoothstep(desk):
    m = make(desk, "math", op="map_range", in_min=-1.0, in_max=1.0, out_min=0.6, out_max=1.6)
    assert m.tick(0.01, {"a": 0.0})["value"] == pytest.approx(1.1)
    assert m.tick(0.01, {"a": 3.0})["value"] == pytest.approx(1.6)  # clamped
    free = make(
        desk, "math", op="map_range", in_min=0.0, in_max=1.0, out_min=0.0, out_max=10.0, clamped=False
    )
    assert free.tick(0.01, {"a": 2.0})["value"] == pytest.approx(20.0)
    c = make(desk, "math", op="clamp", min=-0.5, max=0.5)
    assert [c.tick(0.01, {"a": x})["value"] for x in (-2.0, 0.1, 2.0)] == [-0.5, 0.1, 0.5]
    s = make(desk, "math", op="smoothstep", in_min=0.0, in_max=2.0)
    assert [s.tick(0.01, {"a": x})["value"] for x in (-1.0, 1.0, 3.0)] == [0.0, 0.5, 1.0]
    assert s.tick(0.01, {"a": 0.5})["value"] == pytest.approx(0.15625)


def test_math_holds_last_finite_value(desk):
    blk = make(desk, "math", op="divide")
    assert blk.tick(0.01, {"a": 1.0, "b": 4.0})["value"] == 0.25
    assert blk.tick(0.01, {"a": 1.0, "b": 0.0})["value"] == 0.25  # division by zero
    big = make(desk, "math", op="multiply")
    big.tick(0.01, {"a": 2.0, "b": 3.0})
    assert big.tick(0.01, {"a": 1e308, "b": 1e308})["value"] == 6.0  # overflow to inf


def test_math_validation_messages():
    with pytest.raises(ValidationError, match="in_min and in_max must differ"):
        BLOCKS["math"].Params(op="map_range", in_min=1.0, in_max=1.0)
    with pytest.raises(ValidationError, match="min .* must not exceed max"):
        BLOCKS["math"].Params(op="clamp", min=1.0, max=0.0)


def _run(blk, n, dt=0.01, **inputs):
    return np.array([blk.tick(dt, inputs)["value"] for _ in range(n)])


def test_lfo_sine_period_amplitude_offset(desk):
    v = _run(make(desk, "lfo", frequency=2.0, amplitude=0.5, offset=1.0), 200)
    assert v.max() == pytest.approx(1.5, abs=1e-3) and v.min() == pytest.approx(0.5, abs=1e-3)
    up = np.flatnonzero((v[:-1] < 1.0) & (v[1:] >= 1.0))  # upward crossings of the offset
    assert np.allclose(np.diff(up), 50)  # 0.5 s at 100 Hz


@pytest.mark.parametrize("shape", ["triangle", "square", "saw", "random_smooth"])
def test_lfo_waveforms_stay_in_range_and_repeat(desk, shape):
    v = _run(make(desk, "lfo", waveform=shape, frequency=1.0, amplitude=2.0), 400)
    assert np.all(np.abs(v) <= 2.0 + 1e-9)
    if shape != "random_smooth":
        assert np.allclose(v[:100], v[100:200])
    else:
        assert np.max(np.abs(np.diff(v))) < 0.2  # smooth: no jumps
        assert np.ptp(v) > 0.1


def test_lfo_frequency_change_never_jumps(desk):
    blk = make(desk, "lfo", frequency=1.0)
    v1 = _run(blk, 37)
    v2 = _run(blk, 50, frequency=3.0)
    assert abs(v2[0] - v1[-1]) < 2 * math.pi * 1.0 * 0.01 + 1e-9


def test_lfo_phase_param(desk):
    assert make(desk, "lfo", phase=0.25).tick(0.01, {})["value"] == pytest.approx(1.0)


def _emotion(desk, v, a):
    return make(desk, "emotion", valence=v, arousal=a).tick(0.01, {})


def test_emotion_monotonic_mappings(desk):
    grid = np.linspace(-1, 1, 9)
    speed = [_emotion(desk, 0.0, a)["speed"] for a in grid]
    assert np.all(np.diff(speed) > 0) and speed[0] == pytest.approx(0.6) and speed[-1] == pytest.approx(1.6)
    assert _emotion(desk, 0.0, 0.0)["speed"] == pytest.approx(1.0)
    amp_a = [_emotion(desk, 0.3, a)["amplitude"] for a in grid]
    assert np.all(np.diff(amp_a) > 0)
    amp_v = [_emotion(desk, v, 0.0)["amplitude"] for v in np.linspace(0, 1, 5)]
    assert np.all(np.diff(amp_v) > 0)
    assert _emotion(desk, -0.8, 0.0)["amplitude"] == pytest.approx(_emotion(desk, 0.8, 0.0)["amplitude"])
    droop = [_emotion(desk, v, 0.0)["posture_offset"] for v in grid]
    assert np.all(np.diff(droop) < 0) and droop[0] > 0 > droop[-1]  # sad droops (+ pitch), happy lifts


@pytest.mark.parametrize(
    "v,a,name",
    [
        (0.8, 0.5, "happy"),
        (-0.8, -0.4, "sad"),
        (0.0, 1.0, "surprised"),
        (0.1, -0.9, "sleepy"),
        (0.0, 0.05, "neutral"),
    ],
)
def test_emotion_nearest_posture(desk, v, a, name):
    assert _emotion(desk, v, a)["posture"] == name


def test_a_settled_emotion_hands_out_the_same_outputs_until_it_moves(desk):
    blk = make(desk, "emotion", smoothing=0.0)  # no smoothing: settled from the first tick
    first = blk.tick(0.01, {"valence": 0.0, "arousal": 0.0})
    assert blk.tick(0.01, {"valence": 0.0, "arousal": 0.0}) is first  # the same objects downstream
    moved = blk.tick(0.01, {"valence": 1e-12, "arousal": 0.0})
    assert moved is not first and moved["valence"] == 1e-12
    happy = blk.tick(0.01, {"valence": 0.8, "arousal": 0.5})
    assert happy["posture"] == "happy" and happy["posture_offset"] < 0.0
    blk.reset()  # a fresh state works its outputs out again
    again = blk.tick(0.01, {"valence": 0.8, "arousal": 0.5})
    assert again is not happy and again == happy
    blk.update_params(blk.Params(smoothing=0.0, droop=0.5))  # new parameters too
    assert blk.tick(0.01, {"valence": 0.8, "arousal": 0.5})["posture_offset"] != happy["posture_offset"]


def test_a_smoothed_emotion_lands_on_its_target_and_goes_quiet(desk):
    """The smoothing lands on its target once within SETTLE: until then it is the exponential it always
    was, then the outputs are the target's, and the block says it is quiet (the core skips it)."""
    blk = make(desk, "emotion", smoothing=0.5)
    blk.tick(0.01, {"valence": 0.0, "arousal": 0.0})
    k = 1.0 - math.exp(-0.01 / 0.5)
    v = 0.0
    ticks = 0
    while blk.state.v != 0.8:
        out = blk.tick(0.01, {"valence": 0.8, "arousal": -0.4})
        v += k * (0.8 - v)
        ticks += 1
        assert out["valence"] == pytest.approx(v, abs=SETTLE) and ticks < 2000
    assert 0.8 - v <= SETTLE and 5.0 < ticks * 0.01 < 8.0  # ~7 s, not the ~19 s of vanishing steps
    assert blk.state.a == -0.4
    settled = blk.tick(0.01, {"valence": 0.8, "arousal": -0.4})
    assert blk.quiet and blk.tick(0.01, {"valence": 0.8, "arousal": -0.4}) is settled
    assert settled == blk.outputs_for(0.8, -0.4) | {"posture": settled["posture"]}


def test_emotion_outputs_never_jump(desk):
    blk = make(desk, "emotion", smoothing=0.5)
    outs = [blk.tick(0.01, {"valence": 0.0, "arousal": 0.0}) for _ in range(10)]
    outs += [blk.tick(0.01, {"valence": -1.0, "arousal": 1.0}) for _ in range(400)]
    for key in ("speed", "amplitude", "posture_offset"):
        series = np.array([o[key] for o in outs])
        assert np.max(np.abs(np.diff(series))) < 0.03, key
    final = outs[-1]
    assert final["speed"] == pytest.approx(1.6, abs=0.01) and final["posture_offset"] > 0.1
    postures = [o["posture"] for o in outs]
    assert postures[0] == "neutral" and postures[-1] != "neutral"
    switches = sum(1 for p, q in zip(postures, postures[1:]) if p != q)
    assert switches <= 2  # hysteresis: no flicker on the way
