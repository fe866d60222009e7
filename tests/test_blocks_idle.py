"""Procedural idle blocks (breathe, noise, weight_shift) and the blink scheduler."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from backend.engine.blocks import BLOCKS, BlockContext
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession


def make(desk, type_name: str, node_id: str | None = None, rate: float = 100.0, seed: int = 0, **params):
    cls = BLOCKS[type_name]
    ctx = BlockContext(embodiment=desk, rate=rate, seed=seed)
    return cls(cls.Params(**params), ctx, node_id or type_name)


def run(block, n: int, dt: float = 0.01, inputs: dict | None = None, port: str = "out") -> np.ndarray:
    """Values of `port` over n ticks: (n, channels) for frames, (n,) for signals."""
    rows = []
    for _ in range(n):
        out = block.tick(dt, inputs or {})[port]
        rows.append(out.values.copy() if port == "out" else out)
    return np.array(rows)


def ch(desk, name: str) -> int:
    return desk.channel_index[name]


# --------------------------------------------------------------------------------------------------
# breathe
# --------------------------------------------------------------------------------------------------


def test_breathe_period_matches_frequency_and_stays_around_rest(desk):
    b = make(desk, "breathe", dofs=["head_pitch"], amplitude=0.05, frequency=0.5)
    i = ch(desk, "head_pitch")
    x = run(b, 2000)[:, i] - desk.rest[i]  # 20 s
    ups = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    assert len(ups) >= 8
    assert np.mean(np.diff(ups)) * 0.01 == pytest.approx(2.0, abs=0.02)
    assert x.max() == pytest.approx(0.05, abs=1e-3) and x.min() == pytest.approx(-0.05, abs=1e-3)
    assert abs(x[:2000].mean()) < 0.003  # the asymmetric cycle is still centred on rest


def test_breathe_inhales_faster_than_it_exhales(desk):
    b = make(desk, "breathe", dofs=["head_pitch"], amplitude=0.05, frequency=0.25, inhale_ratio=0.35)
    x = run(b, 4000)[:, ch(desk, "head_pitch")]  # 10 cycles
    d = np.diff(x)
    rising, falling = np.sum(d > 0), np.sum(d < 0)
    assert rising / (rising + falling) == pytest.approx(0.35, abs=0.02)
    assert d.max() > 1.5 * -d.min()  # the inhale is also the faster motion


def test_breathe_live_frequency_change_never_jumps(desk):
    b = make(desk, "breathe", dofs=["head_pitch"], amplitude=0.05, frequency=0.25, inhale_ratio=0.4)
    i = ch(desk, "head_pitch")
    before = run(b, 333)[:, i]
    after = run(b, 1500, inputs={"frequency": 1.0})[:, i]
    x = np.concatenate([before, after])
    # Fastest motion of the new rhythm: amp * pi * f / inhale_ratio per second.
    assert np.max(np.abs(np.diff(x))) <= 0.05 * math.pi * 1.0 / 0.4 * 0.01 * 1.05
    x_after = after - desk.rest[i]
    ups = np.flatnonzero((x_after[:-1] < 0) & (x_after[1:] >= 0))
    assert np.mean(np.diff(ups)) * 0.01 == pytest.approx(1.0, abs=0.02)


def test_breathe_per_dof_amplitudes_phases_and_amplitude_signal(desk):
    b = make(
        desk,
        "breathe",
        dofs=["head_pitch", "neck_pitch"],
        amplitude=0.02,
        frequency=0.5,
        amplitudes={"neck_pitch": 0.06},
        phase_spread=0.0,
        phases={"neck_pitch": math.pi},
    )
    hp, npi = ch(desk, "head_pitch"), ch(desk, "neck_pitch")
    v = run(b, 400)
    assert np.ptp(v[:, hp]) == pytest.approx(0.04, abs=1e-3)
    assert np.ptp(v[:, npi]) == pytest.approx(0.12, abs=2e-3)
    assert np.corrcoef(v[:, hp], v[:, npi])[0, 1] < -0.5  # half a cycle apart
    out = b.tick(0.01, {})["out"]
    assert set(np.flatnonzero(out.mask)) == {hp, npi}
    doubled = run(b, 400, inputs={"amplitude": 0.04})
    assert np.ptp(doubled[:, hp]) == pytest.approx(0.08, abs=2e-3)
    assert np.ptp(doubled[:, npi]) == pytest.approx(0.24, abs=4e-3)  # overrides scale in proportion


def test_breathe_unknown_dof_in_amplitudes_is_a_clear_error(desk):
    with pytest.raises(ValueError, match="no DoF 'tail'"):
        make(desk, "breathe", amplitudes={"tail": 0.1})


# --------------------------------------------------------------------------------------------------
# noise
# --------------------------------------------------------------------------------------------------


def _noise_series(desk, rate: float, seconds: float, **params) -> np.ndarray:
    b = make(desk, "noise", rate=rate, **params)
    mask = b.tick(1.0 / rate, {})["out"].mask
    return (run(b, int(seconds * rate), dt=1.0 / rate) - desk.rest)[:, mask]


@pytest.mark.parametrize("rate", [50.0, 500.0])
def test_noise_std_matches_amplitude_at_any_rate(desk, rate):
    x = _noise_series(desk, rate, 50.0, amplitude=0.02, tau=0.3, smoothing=0.1, seed=3)
    assert x.shape[1] >= 5
    assert np.std(x[int(rate * 2) :]) == pytest.approx(0.02, rel=0.15)
    assert abs(np.mean(x)) < 0.004


def test_noise_smoothing_makes_velocity_continuous(desk):
    def step_ratio(smoothing: float) -> float:
        fine = np.std(
            np.diff(_noise_series(desk, 500.0, 20.0, amplitude=0.02, tau=0.5, smoothing=smoothing), axis=0)
        )
        coarse = np.std(
            np.diff(_noise_series(desk, 50.0, 20.0, amplitude=0.02, tau=0.5, smoothing=smoothing), axis=0)
        )
        return fine / coarse

    assert step_ratio(0.2) < 0.18  # steps shrink like dt: a differentiable path
    assert step_ratio(0.0) > 0.25  # plain OU: steps shrink like sqrt(dt)


def test_noise_is_reproducible_and_differs_between_nodes_and_seeds(desk):
    a = run(make(desk, "noise", "n1", seed=1), 300)
    assert np.array_equal(a, run(make(desk, "noise", "n1", seed=1), 300))
    assert not np.allclose(a, run(make(desk, "noise", "n2", seed=1), 300))
    assert not np.allclose(a, run(make(desk, "noise", "n1", seed=2), 300))
    b = make(desk, "noise", "n1", seed=1)
    b.ctx.seed = 99
    b.reset()
    assert not np.allclose(a, run(b, 300))  # the engine seed counts too


def test_noise_stays_within_limits_and_amplitude_signal_scales(desk):
    b = make(desk, "noise", amplitude=1.0, tau=0.2, smoothing=0.05)
    v = run(b, 3000)
    assert np.all(v >= desk.min - 1e-12) and np.all(v <= desk.max + 1e-12)
    quiet = make(desk, "noise", "q", amplitude=0.5)
    assert np.allclose(run(quiet, 200, inputs={"amplitude": 0.0}), desk.rest)


# --------------------------------------------------------------------------------------------------
# weight_shift
# --------------------------------------------------------------------------------------------------


def test_weight_shift_stays_within_amplitude_and_moves_smoothly(desk):
    amp, dur = 0.1, 2.0
    b = make(desk, "weight_shift", amplitude=amp, min_interval=3.0, max_interval=6.0, shift_duration=dur)
    out = b.tick(0.01, {})["out"]
    sel = np.flatnonzero(out.mask)
    assert {ch(desk, "body_yaw"), ch(desk, "head_roll")} <= set(sel)
    off = (run(b, 12000) - desk.rest)[:, sel]  # 120 s
    assert np.all(np.abs(off) <= amp + 1e-9)
    assert np.all(np.ptp(off, axis=0) > 0.3 * amp)  # it really shifts
    # Sine in/out over `dur` between two offsets at most 2*amp apart.
    assert np.max(np.abs(np.diff(off, axis=0))) <= 2 * amp * math.pi / (2 * dur) * 0.01 * 1.01
    assert abs(np.corrcoef(off[:, 0], off[:, 1])[0, 1]) < 0.95  # DoFs shift by different fractions


def test_weight_shift_rejects_min_interval_above_max(desk):
    with pytest.raises(ValidationError, match="min_interval.*max_interval"):
        BLOCKS["weight_shift"].Params(min_interval=10.0, max_interval=5.0)


# --------------------------------------------------------------------------------------------------
# blink
# --------------------------------------------------------------------------------------------------


def _onsets(blinking: np.ndarray) -> np.ndarray:
    b = blinking.astype(int)
    return np.flatnonzero(np.diff(np.concatenate([[0], b])) == 1)


def test_blink_mean_interval_over_a_long_run(desk):
    b = make(
        desk, "blink", min_interval=1.5, mean_interval=4.0, max_interval=10.0, double_blink_probability=0.0
    )
    blinking = run(b, 60000, port="blinking")  # 600 s
    gaps = np.diff(_onsets(blinking)) * 0.01
    assert len(gaps) > 100
    assert np.mean(gaps) == pytest.approx(4.0, abs=0.6)
    assert gaps.min() >= 1.5 - 0.011 and gaps.max() <= 10.0 + 0.011
    assert np.std(gaps) > 0.5  # random, not a metronome


def test_blink_shape_closes_faster_than_it_opens(desk):
    b = make(
        desk,
        "blink",
        close_time=0.08,
        hold_time=0.03,
        open_time=0.18,
        min_interval=20,
        mean_interval=30,
        max_interval=40,
        double_blink_probability=0.0,
        rate=1000.0,
    )
    i = ch(desk, "blink")
    run(b, 100, dt=0.001)
    b.handle("blink", {})
    x = run(b, 500, dt=0.001)[:, i]
    assert x.max() == pytest.approx(desk.max[i])  # "max": fully closed at the DoF's limit
    closed = np.flatnonzero(x >= x.max() - 1e-9)
    moving = np.flatnonzero(x > 1e-9)
    close_dur = (closed[0] - moving[0]) * 0.001
    open_dur = (moving[-1] - closed[-1]) * 0.001
    assert close_dur == pytest.approx(0.08, abs=0.003)
    assert open_dur == pytest.approx(0.18, abs=0.003)
    assert close_dur < open_dur
    assert x[-1] == desk.rest[i] == 0.0  # open again, at rest


def test_blink_never_starts_during_hold_and_catches_up_after(desk):
    b = make(desk, "blink", min_interval=0.5, mean_interval=1.0, max_interval=2.0)
    i = ch(desk, "blink")
    held = b.tick(0.01, {"hold": True})
    assert held["blinking"] is False
    values = run(b, 1000, inputs={"hold": True})[:, i]  # 10 s, many blinks due
    assert np.all(values == desk.rest[i])
    b.tick(0.01, {"hold": True, "gaze": [1.0, 0.0, 0.0]})
    assert b.tick(0.01, {"hold": True, "gaze": [0.0, 1.0, 0.0]})["blinking"] is False  # gaze shifts wait too
    assert b.tick(0.01, {"hold": False})["blinking"] is True  # overdue: blinks when the hold ends


def test_gaze_shift_triggers_a_blink_unless_one_just_happened(desk):
    b = make(
        desk,
        "blink",
        min_interval=2.0,
        mean_interval=20.0,
        max_interval=30.0,
        gaze_shift_threshold=0.2,
        double_blink_probability=0.0,
    )
    look = {"gaze": [1.0, 0.0, 0.3]}
    assert not run(b, 150, inputs=look, port="blinking").any()  # 1.5 s, nothing scheduled yet
    small = {"gaze": [1.0, 0.1, 0.3]}
    assert not run(b, 20, inputs=small, port="blinking").any()  # below the threshold
    shift = {"gaze": [1.0, 0.6, 0.3]}
    assert run(b, 2, inputs=shift, port="blinking").any()  # blinks with the gaze shift
    run(b, 50, inputs=shift)
    back = {"gaze": [1.0, 0.0, 0.3]}
    assert not run(b, 20, inputs=back, port="blinking").any()  # 0.7 s after the last: too soon
    run(b, 40, inputs=back)
    assert run(b, 2, inputs={"gaze": [1.0, 0.6, 0.3]}, port="blinking").any()  # 1.3 s after: blinks again


def test_gaze_shift_is_an_angle_for_target_points(desk):
    b = make(
        desk,
        "blink",
        min_interval=2.0,
        mean_interval=20.0,
        max_interval=30.0,
        gaze_shift_threshold=0.2,
        double_blink_probability=0.0,
    )
    run(b, 150, inputs={"gaze": [1.0, 0.0, 0.3]})
    assert not run(b, 20, inputs={"gaze": [3.0, 0.0, 0.9]}, port="blinking").any()  # same direction, farther
    assert run(b, 2, inputs={"gaze": [3.0, 1.0, 0.9]}, port="blinking").any()  # turned by ~0.3 rad


def test_gaze_may_be_a_float(desk):
    b = make(
        desk, "blink", min_interval=2.0, mean_interval=20.0, max_interval=30.0, double_blink_probability=0.0
    )
    run(b, 150, inputs={"gaze": 0.0})
    assert run(b, 2, inputs={"gaze": 0.5}, port="blinking").any()


def test_double_blinks(desk):
    b = make(
        desk,
        "blink",
        min_interval=5.0,
        mean_interval=10.0,
        max_interval=20.0,
        double_blink_probability=1.0,
        double_blink_gap=0.1,
    )
    b.handle("blink", {})
    blinking = run(b, 100, port="blinking")  # 1 s
    onsets = _onsets(blinking)
    assert len(onsets) == 2
    assert (onsets[1] - onsets[0]) * 0.01 == pytest.approx(0.08 + 0.03 + 0.18 + 0.1, abs=0.025)


def test_blink_closed_value_and_mask(desk):
    b = make(desk, "blink", dofs=["eyelid_left", "eyelid_right"], closed=1.0, double_blink_probability=0.0)
    b.handle("blink", {})
    frames = [b.tick(0.01, {})["out"] for _ in range(40)]
    lid = ch(desk, "eyelid_left")
    assert set(np.flatnonzero(frames[0].mask)) == {lid, ch(desk, "eyelid_right")}
    x = np.array([f.values[lid] for f in frames])
    assert x.max() == pytest.approx(1.0) and x[-1] == pytest.approx(desk.rest[lid])
    assert x.min() >= desk.rest[lid] - 1e-12


def test_blink_validator_names_the_fields(desk):
    with pytest.raises(ValidationError, match="min_interval <= mean_interval") as err:
        BLOCKS["blink"].Params(min_interval=5.0, mean_interval=3.0, max_interval=10.0)
    assert "min_interval=5.0" in str(err.value) and "mean_interval=3.0" in str(err.value)
    with pytest.raises(ValidationError, match="max_interval=2.0"):
        BLOCKS["blink"].Params(min_interval=1.0, mean_interval=3.0, max_interval=2.0)


def test_blink_is_reproducible(desk):
    a = run(
        make(desk, "blink", "eyes", min_interval=0.5, mean_interval=1.0, max_interval=3.0),
        1000,
        port="blinking",
    )
    b = run(
        make(desk, "blink", "eyes", min_interval=0.5, mean_interval=1.0, max_interval=3.0),
        1000,
        port="blinking",
    )
    c = run(
        make(desk, "blink", "other", min_interval=0.5, mean_interval=1.0, max_interval=3.0),
        1000,
        port="blinking",
    )
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_idle_blocks_describe_themselves():
    for name in ("breathe", "noise", "weight_shift", "blink"):
        d = BLOCKS[name].describe()
        assert d["category"] == "sources" and d["role"] == "source" and "out" in d["outputs"]
        assert d["summary"] and d["summary"] != d["doc"]
    assert BLOCKS["blink"].describe()["outputs"]["blinking"]["type"] == "bool"


# --------------------------------------------------------------------------------------------------
# a whole program
# --------------------------------------------------------------------------------------------------


def test_idle_program_with_breathing_noise_shifts_and_blinks_respects_limits(desk):
    b = ProgramBuilder("idle", robot=desk.name)
    gaze = b.expose("gaze", type="vec3", default=[1.0, 0.0, 0.3])
    rest = b.node("rest_pose", "rest")
    breathe = b.node("breathe", "breathe", amplitude=0.05, frequency=0.3)
    noise = b.node("noise", "noise", amplitude=0.03)
    shift = b.node("weight_shift", "shift", amplitude=0.1, min_interval=2.0, max_interval=4.0)
    blink = b.node("blink", "blink", min_interval=20.0, mean_interval=25.0, max_interval=30.0)
    mix = b.node(
        "layer_mixer",
        "mix",
        layers=[
            {"name": "base"},
            {"name": "breath", "mode": "additive"},
            {"name": "noise", "mode": "additive"},
            {"name": "shift", "mode": "additive"},
            {"name": "eyes", "mode": "override", "mask": ["blink"]},
        ],
    )
    b.connect(rest, mix, "out", "base").connect(breathe, mix, "out", "breath").connect(
        noise, mix, "out", "noise"
    )
    b.connect(shift, mix, "out", "shift").connect(blink, mix, "out", "eyes").chain(mix, b.output())
    b.connect(gaze, blink, "value", "gaze")
    session = EngineSession.create(desk, rate=100, program=b.to_dict())
    timeline = [(3.0, {"type": "set_input", "name": "gaze", "value": [1.0, 0.8, 0.3]})]
    frames = list(session.run_headless(600, timeline))
    pos = np.array([f.position for f in frames])
    cont = desk.continuous_mask
    assert np.all(pos[:, cont] >= desk.min[cont] - 1e-9) and np.all(pos[:, cont] <= desk.max[cont] + 1e-9)
    lids = pos[:, ch(desk, "blink")]
    assert lids[:290].max() == 0.0  # no scheduled blink before 20 s ...
    assert lids[300:330].max() > 1.0  # ... but one with the gaze shift at 3 s
    assert np.ptp(pos[:, ch(desk, "head_pitch")]) > 0.05  # breathing + noise move the head
    assert np.ptp(pos[:, ch(desk, "head_roll")]) > 0.02  # weight shifts
