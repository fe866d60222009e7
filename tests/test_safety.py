"""The engine's safety net (backend/engine/safety.py), checked on the finite differences of its output.

Whatever the program sends (steps, noise, chirps, values far beyond the limits, NaN), every governed
DoF stays within its position, velocity, acceleration and jerk limits at 30, 100 and 1000 Hz; a
program that respects the limits passes through bit for bit; after a correction the net returns to
exact pass-through (re-locks) within a bounded time. Each frame says what the net was handed and, where
it corrected, the joints that request composes to and which limit each correction enforced (what the
editor's curve panel, top bar and safety node show), also in the telemetry message.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from joint_truth import joint_truth

from backend.api_types import TelemetryFrame
from backend.engine.frames import LIMIT_POSITION
from backend.engine.safety import SafetyNet, plan_gains, plan_horizons
from backend.engine.trajectory import analyze
from backend.routes.telemetry import frame_json
from backend.session import EngineSession

RATES = (30.0, 100.0, 1000.0)
# Finite differences of float positions at 1000 Hz amplify rounding by 1/dt^3 = 1e9: this is that
# rounding, not a tolerance on the limits.
ROUNDING = 1e-6


def run(net: SafetyNet, program: np.ndarray) -> np.ndarray:
    """Feed (T, C) program frames through the net; returns the (T, C) output."""
    return np.array([net.step(row) for row in program])


def channel_stage(net: SafetyNet) -> np.ndarray:
    """Positions in `net.idx` of the channels whose own limits the frames keep: every governed channel
    except the own channel of a joint the joint stage steps (that channel carries its joint's
    correction, and the joint is judged against the joint's limits: `assert_within_limits`)."""
    carried = net.joints.own[net.joints.governed]
    return np.flatnonzero(~np.isin(net.idx, carried))


def limit_ratios(net: SafetyNet, out: np.ndarray, start: np.ndarray) -> dict[str, float]:
    """Worst |v|/V, |a|/A, |j|/J and position excess of the channel stage's channels, from finite
    differences of the output preceded by the state the net started from (at rest: three equal samples)."""
    k = channel_stage(net)
    p = np.vstack([start[None, net.idx[k]]] * 3 + [out[:, net.idx[k]]])
    rate = 1.0 / net.h
    v = np.diff(p, axis=0) * rate
    a = np.diff(v, axis=0) * rate
    j = np.diff(a, axis=0) * rate
    return {
        "v": float((np.abs(v) / net.V[k]).max()),
        "a": float((np.abs(a) / net.A[k]).max()),
        "j": float((np.abs(j) / net.J[k]).max()),
        "below": float((net.lo[k] - p).max()),
        "above": float((p - net.hi[k]).max()),
    }


def assert_within_limits(net: SafetyNet, out: np.ndarray, start: np.ndarray) -> None:
    """The channel stage's channels within their limits, and every joint the frames compose to within the
    joint's (computed from the robot's files by tests/joint_truth.py)."""
    r = limit_ratios(net, out, start)
    assert r["v"] <= 1 + ROUNDING and r["a"] <= 1 + ROUNDING and r["j"] <= 1 + ROUNDING, r
    assert r["below"] <= 1e-12 and r["above"] <= 1e-12, r
    truth = joint_truth(net.emb.name)
    # A robot stands within its joints' ranges: a start whose channels compose past one starts at the limit.
    start_q = np.clip(
        truth.compose(net.emb, np.clip(start, net.emb.min, net.emb.max)), truth.lower, truth.upper
    )
    truth.assert_within(np.vstack([start_q] * 3 + [truth.compose(net.emb, out)]), 1.0 / net.h, "joints")


def hostile_program(desk, kind: str, rate: float, seconds: float, seed: int) -> np.ndarray:
    """Frames of a program that breaks every limit in its own way."""
    rng = np.random.default_rng(seed)
    n = int(seconds * rate)
    t = np.arange(n) / rate
    frames = np.tile(desk.rest, (n, 1))
    cont = np.flatnonzero(desk.continuous_mask)
    lo, hi = desk.min[cont], desk.max[cont]
    span, mid = hi - lo, (hi + lo) / 2
    if kind == "steps":
        hold = max(1, int(rate * rng.uniform(0.05, 0.6)))
        levels = rng.uniform(lo - 0.3 * span, hi + 0.3 * span, size=(n // hold + 1, len(cont)))
        x = np.repeat(levels, hold, axis=0)[:n]
    elif kind == "noise":
        x = rng.uniform(lo - 0.2 * span, hi + 0.2 * span, size=(n, len(cont)))
    elif kind == "chirp":
        f = rng.uniform(0.1, 0.5) + rng.uniform(1, 6) * t / seconds
        x = mid + rng.uniform(0.3, 0.8) * span * np.sin(2 * np.pi * np.cumsum(f) / rate)[:, None]
    elif kind == "beyond":
        x = np.where(rng.random(len(cont)) < 0.5, hi + 10.0, lo - 10.0) * np.ones((n, 1))
    else:  # "spikes": a smooth program with single-sample spikes and NaN holes
        x = mid + 0.2 * span * np.sin(2 * np.pi * 0.4 * t)[:, None]
        spikes = rng.random(x.shape) < 0.02
        x = np.where(spikes, x + rng.normal(0, 1.0, x.shape), x)
        x[rng.random(x.shape) < 0.01] = np.nan
    frames[:, cont] = x
    return frames


@pytest.mark.parametrize("rate", RATES)
@pytest.mark.parametrize("kind", ["steps", "noise", "chirp", "beyond", "spikes"])
def test_every_limit_holds_on_the_finite_differences(desk, rate, kind):
    net = SafetyNet(desk, rate)
    out = run(net, hostile_program(desk, kind, rate, 6.0, seed=hash((kind, rate)) % 2**32))
    assert np.all(np.isfinite(out))
    assert_within_limits(net, out, desk.rest)
    assert net.corrections[net.idx].sum() > 0  # it had work to do


@settings(max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(
    kind=st.sampled_from(["steps", "noise", "chirp", "beyond", "spikes"]),
    rate=st.sampled_from(RATES),
    seed=st.integers(0, 2**31 - 1),
    start=st.floats(-1.0, 1.0),
)
def test_limits_hold_from_any_start_property(desk, kind, rate, seed, start):
    """Random programs from a random starting pose (within the limits)."""
    pose = np.clip(desk.rest + start * (desk.max - desk.min) / 2, desk.min, desk.max)
    pose = np.where(desk.continuous_mask & np.isfinite(pose), pose, desk.rest)
    net = SafetyNet(desk, rate, start=pose)
    out = run(net, hostile_program(desk, kind, rate, 2.0, seed))
    assert_within_limits(net, out, pose)


def gentle(t: np.ndarray, f: float = 0.3) -> np.ndarray:
    """0..1..0 at f Hz, starting at rest: position, velocity, acceleration and jerk all 0 at t = 0."""
    return (1 - np.cos(2 * np.pi * f * t)) ** 2 / 4


def smooth_feasible(desk, rate: float, seconds: float) -> np.ndarray:
    """Slow waves that start at rest, well inside every limit."""
    n = int(seconds * rate)
    t = np.arange(n) / rate
    frames = np.tile(desk.rest, (n, 1))
    cont = np.flatnonzero(desk.continuous_mask)
    span = desk.max[cont] - desk.min[cont]
    amp = 0.1 * np.minimum(span, 0.6 * desk.vel_limit[cont])
    frames[:, cont] = desk.rest[cont] + amp * gentle(t)[:, None]
    return frames


@pytest.mark.parametrize("rate", RATES)
def test_a_program_within_the_limits_passes_bit_for_bit(desk, rate):
    net = SafetyNet(desk, rate)
    program = smooth_feasible(desk, rate, 5.0)
    out = run(net, program)
    assert np.array_equal(out, program)  # no lag, no change of character
    assert net.corrected_ticks == 0 and not net.corrections.any()


def test_reaching_and_holding_a_position_limit_passes_through(desk):
    net = SafetyNet(desk, 100.0)
    i = desk.channel_index["neck_pitch"]
    u = np.clip(np.arange(400) / 200.0, 0.0, 1.0)  # 2 s smootherstep from rest to the limit, then hold
    frames = np.tile(desk.rest, (400, 1))
    frames[:, i] = desk.max[i] * u**3 * (u * (6 * u - 15) + 10)
    out = run(net, frames)
    assert np.array_equal(out, frames)
    assert out[-1, i] == desk.max[i]
    assert (
        out[-1, desk.channel_index["mouth_open"]] == desk.min[desk.channel_index["mouth_open"]]
    )  # rest at a limit


@pytest.mark.parametrize("rate", [100.0, 1000.0])
def test_relocks_after_a_step_on_a_smooth_program(desk, rate):
    """A 0.5 rad step riding on a slow sine on the neck: corrected, then exact again within 2 s."""
    net = SafetyNet(desk, rate)
    i = desk.channel_index["neck_pitch"]
    n = int(6 * rate)
    t = np.arange(n) / rate
    program = np.tile(desk.rest, (n, 1))
    program[:, i] = 0.1 * gentle(t) + np.where(t >= 1.0, 0.3, 0.0) - 0.15 * (t >= 3.5)
    out = run(net, program)
    assert_within_limits(net, out, desk.rest)
    exact = out[:, i] == program[:, i]
    assert exact[: int(rate)].all()  # before the step: pass-through
    assert not exact[int(rate)]  # the step is corrected
    relock = int(rate) + int(np.argmax(exact[int(rate) :]))
    assert exact[relock : int(3.5 * rate)].all()  # once re-locked it stays locked
    assert (relock - rate) / rate < 2.0, (relock - rate) / rate
    relock2 = int(3.5 * rate) + int(np.argmax(exact[int(3.5 * rate) :]))
    assert exact[relock2:].all() and (relock2 - 3.5 * rate) / rate < 2.0


def test_corrections_are_counted_per_dof(desk):
    net = SafetyNet(desk, 100.0)
    program = smooth_feasible(desk, 100.0, 3.0)
    i, k = desk.channel_index["head_yaw"], desk.channel_index["ear_left"]
    program[150:, i] += 0.4  # one DoF steps
    out = run(net, program)
    differs = (out != program).sum(axis=0)
    # The net counts exactly the ticks where it changed a channel's sample (or had to decide to keep it).
    assert net.corrections[i] >= differs[i] > 0
    assert net.corrections[k] == differs[k] == 0
    stats = net.stats()
    assert stats["corrections"] == {"head_yaw": int(net.corrections[i])}
    assert stats["corrected_ticks"] == net.corrected_ticks >= differs[i]


def test_non_finite_samples_hold_the_last_output(desk):
    net = SafetyNet(desk, 100.0)
    frames = smooth_feasible(desk, 100.0, 1.0)
    frames[50, desk.channel_index["head_yaw"]] = np.nan
    frames[51, desk.channel_index["head_yaw"]] = np.inf
    out = run(net, frames)
    assert np.all(np.isfinite(out))
    assert_within_limits(net, out, desk.rest)


def test_colour_and_enum_channels_pass_untouched(desk):
    net = SafetyNet(desk, 100.0)
    frames = np.tile(desk.rest, (20, 1))
    led = desk.dof("eye_leds").channels
    frames[10:, led] = [1.0, 0.0, 0.0]
    frames[10:, desk.channel_index["mouth"]] = 3
    out = run(net, frames)
    assert np.array_equal(out[:, led], frames[:, led])
    assert np.array_equal(out[:, desk.channel_index["mouth"]], frames[:, desk.channel_index["mouth"]])


def test_disabled_net_passes_everything(desk):
    net = SafetyNet(desk, 100.0, enabled=False)
    program = hostile_program(desk, "noise", 100.0, 1.0, seed=3)
    assert np.array_equal(run(net, program), program)


def test_plan_gains_bring_a_triple_integrator_to_rest():
    """The receding-horizon plans (scaled units, h = 1) are exact: each zeroes the state in n ticks."""
    assert plan_horizons(100.0)[:4] == [3, 4, 5, 6] and plan_horizons(1000.0)[-1] <= 400
    gains, starts = plan_gains([3, 4, 7, 12, 40])
    rng = np.random.default_rng(0)
    for k in range(len(starts) - 1):
        n = starts[k + 1] - starts[k]
        s = rng.normal(size=3)
        e, f, g = s
        for u in gains[starts[k] : starts[k + 1]] @ s:
            g = g + u
            f = f + g
            e = e + f
        assert abs(e) + abs(f) + abs(g) < 1e-9 * (1 + n**3), n


def test_the_trajectory_helper_agrees(desk):
    """backend/engine/trajectory.py (the editor's colouring) finds no violation in the net's output."""
    net = SafetyNet(desk, 100.0)
    out = run(net, hostile_program(desk, "steps", 100.0, 4.0, seed=11))
    idx = net.idx[channel_stage(net)]  # (the joints' own channels are judged as joints)
    pos = np.vstack([np.tile(desk.rest[idx], (3, 1)), out[:, idx]])
    res = analyze(
        pos,
        100.0,
        desk.vel_limit[idx] * (1 + ROUNDING),
        desk.acc_limit[idx] * (1 + ROUNDING),
        desk.jerk_limit[idx] * (1 + ROUNDING),
        desk.min[idx],
        desk.max[idx],
    )
    assert res.ok, res.summary


# --- What the frames say the net did (the editor's curve panel, top bar and safety node read it) ------


def _breathing_frames(desk, amplitude: float, ticks: int = 700):
    """Frames of the bundled idle program with its breathe amplitude at `amplitude`, at 100 Hz."""
    program = json.loads((Path(__file__).parents[1] / "robots/nutty_desk/programs/idle.json").read_text())
    for node in program["nodes"]:
        if node["type"] == "breathe":
            node["params"]["amplitude"] = amplitude
    engine = EngineSession.create(desk, rate=100.0, program=program).engine
    return engine, engine.run_ticks(ticks)


def _own_class(x: np.ndarray, V: float, A: float, J: float, h: float) -> int:
    """The trajectory-helper's class of the last sample of `x` (4 samples, oldest first), computed here."""
    v, a, j = np.diff(x) / h, np.diff(x, 2) / h**2, np.diff(x, 3) / h**3
    k = 1 + 1e-9
    return 3 if abs(j[-1]) > J * k else 2 if abs(a[-1]) > A * k else 1 if abs(v[-1]) > V * k else 0


def test_frames_carry_what_was_asked_and_which_limit_each_correction_enforced(desk):
    engine, frames = _breathing_frames(desk, 0.38)
    cont, h = desk.continuous_mask, 1.0 / 100.0
    requested = np.array([f.requested for f in frames])
    corrected = [k for k, f in enumerate(frames) if f.net is not None]
    assert len(corrected) == engine.safety.corrected_ticks > 50
    neck, seen = desk.channel_names.index("neck_pitch"), set()
    for k, f in enumerate(frames):
        changed = cont & (f.requested != f.position)
        if f.net is None:  # passed through: the request is what the robot got, channels and joints
            assert not changed.any() and f.corrected is None
            continue
        assert np.array_equal(np.flatnonzero(f.net.channel_limits), np.flatnonzero(changed))
        np.testing.assert_allclose(f.net.requested_joints, desk.joint_positions(f.requested), atol=1e-12)
        assert np.array_equal(f.net.joint_limits != 0, f.net.requested_joints != f.joints)
        code = int(f.net.channel_limits[neck])
        if code and k >= 3:
            x = requested[k - 3 : k + 1, neck]
            own = _own_class(x, desk.vel_limit[neck], desk.acc_limit[neck], desk.jerk_limit[neck], h)
            if not desk.min[neck] <= x[-1] <= desk.max[neck]:
                assert code == LIMIT_POSITION
            elif own:  # the program's own motion breaks that limit (most severe wins)
                assert code == own, (k, code, own)
            seen.add(code)
    assert seen  # neck_pitch was corrected after the start too
    # telemetry: the request per corrected channel and joint, the limit by name, |requested - delivered|
    f = frames[corrected[-1]]
    msg = TelemetryFrame.model_validate(frame_json(desk, f, engine.safety))
    assert msg.net is not None and set(msg.net.channels) == {
        desk.channel_names[i] for i in np.flatnonzero(f.net.channel_limits)
    }
    for name, c in msg.net.channels.items():
        i = desk.channel_names.index(name)
        assert c.requested == pytest.approx(f.requested[i], abs=1e-6)
        assert c.amount == pytest.approx(abs(f.requested[i] - f.position[i]), abs=1e-6)
    assert msg.joints == pytest.approx(dict(zip(desk.joint_names, f.joints)), abs=1e-5)
    assert msg.net_totals is not None and msg.net_totals.ticks == engine.safety.corrected_ticks
    assert msg.net_totals.channels["neck_pitch"] == int(engine.safety.corrections[neck])
    quiet = next(g for g in frames if g.net is None)
    assert TelemetryFrame.model_validate(frame_json(desk, quiet)).net is None


def test_a_posture_beyond_a_joints_range_is_a_position_correction(desk):
    # neck_pitch 0.5 + 0.6 * gaze_pitch 0.45: the neck joint asked for 0.77 rad, its limit 0.5
    pose = {
        "format": "nutty-program/1",
        "name": "too far",
        "nodes": [
            {"id": "far", "type": "pose", "params": {"values": {"neck_pitch": 0.5, "gaze_pitch": 0.45}}},
            {"id": "output", "type": "output", "params": {}},
        ],
        "edges": [{"from": {"node": "far", "port": "out"}, "to": {"node": "output", "port": "in"}}],
    }
    frames = EngineSession.create(desk, rate=100.0, program=pose).engine.run_ticks(300)
    neck = desk.channel_names.index("neck_pitch")
    joint = list(desk.joint_names).index("neck_pitch")
    last = frames[-1]  # held at the joint's limit, still asking for more
    assert last.net is not None and last.joints[joint] == pytest.approx(0.5)
    assert last.net.requested_joints[joint] == pytest.approx(0.77)
    assert last.net.joint_limits[joint] == LIMIT_POSITION
    assert last.net.channel_limits[neck] == LIMIT_POSITION  # the joint's correction, on its own channel
