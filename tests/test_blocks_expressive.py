"""Expressive operators: mirror, asymmetry, exaggerate, arc, follow-through and delay."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from backend.engine.blocks import BLOCKS, BlockContext
from backend.engine.blocks.expressive import find_pairs
from backend.engine.blocks.overlap import spring_step_matrix
from backend.engine.frames import FrameEvent, PartialFrame


def make(desk, type_name, rate=100.0, **kw):
    cls = BLOCKS[type_name]
    return cls(cls.Params(**kw), BlockContext(embodiment=desk, rate=rate), "n")


def frame(desk, events=None, **values):
    v = desk.rest.copy()
    for name, x in values.items():
        v[desk.channel_index[name]] = x
    return PartialFrame(v, np.ones(desk.n_channels, dtype=bool), list(events or []))


def ch(desk, name):
    return desk.channel_index[name]


# --- mirror ---------------------------------------------------------------------------------------


def test_pairs_found_by_name(desk):
    names = {(a.name, b.name) for a, b in find_pairs(desk)}
    assert {("ear_left", "ear_right"), ("eyelid_left", "eyelid_right")} <= names
    assert all(a.endswith("_left") and b == a[:-5] + "_right" for a, b in names)


def test_mirror_swaps_pairs_and_negates_yaw_about_rest(desk):
    blk = make(desk, "mirror")
    ev = FrameEvent("speech", "say", {"text": "hi"})
    out = blk.tick(
        0.01,
        {
            "in": frame(
                desk, [ev], ear_left=0.5, ear_right=-0.2, head_yaw=0.3, head_pitch=0.2, eyelid_left=0.9
            )
        },
    )["out"]
    assert out.values[ch(desk, "ear_left")] == pytest.approx(-0.2)
    assert out.values[ch(desk, "ear_right")] == pytest.approx(0.5)
    assert out.values[ch(desk, "head_yaw")] == pytest.approx(-0.3)
    assert out.values[ch(desk, "head_pitch")] == pytest.approx(0.2)  # not negated, not paired
    assert out.values[ch(desk, "eyelid_right")] == pytest.approx(0.9)
    assert out.values[ch(desk, "eyelid_left")] == pytest.approx(0.15)  # the rest of its partner
    assert out.events == [ev]


def test_mirror_mix_blends_and_explicit_pairs(desk):
    half = make(desk, "mirror", mix=0.5).tick(0.01, {"in": frame(desk, head_yaw=0.4, ear_left=0.6)})["out"]
    assert half.values[ch(desk, "head_yaw")] == pytest.approx(0.0)
    assert half.values[ch(desk, "ear_left")] == pytest.approx(0.3)
    assert half.values[ch(desk, "ear_right")] == pytest.approx(0.3)
    blk = make(desk, "mirror", pairs=[["body_yaw", "head_yaw"]], auto_pair=False, negate=[])
    out = blk.tick(0.01, {"in": frame(desk, body_yaw=0.1, head_yaw=0.4)})["out"]
    assert out.values[ch(desk, "body_yaw")] == pytest.approx(0.4)
    assert out.values[ch(desk, "head_yaw")] == pytest.approx(0.1)
    with pytest.raises(ValueError, match="no DoF 'tail'"):
        make(desk, "mirror", pairs=[["tail", "head_yaw"]])
    with pytest.raises(ValidationError, match="two different"):
        BLOCKS["mirror"].Params(pairs=[["a"]])


def test_mirror_follows_the_partner_mask(desk):
    f = PartialFrame.empty(desk.n_channels)
    f.values[ch(desk, "ear_left")] = 0.4
    f.mask[ch(desk, "ear_left")] = True
    out = make(desk, "mirror").tick(0.01, {"in": f})["out"]
    assert out.mask[ch(desk, "ear_right")] and not out.mask[ch(desk, "ear_left")]
    assert out.values[ch(desk, "ear_right")] == pytest.approx(0.4)


# --- asymmetry ------------------------------------------------------------------------------------


def test_asymmetry_delays_the_right_side_by_whole_ticks(desk):
    blk = make(desk, "asymmetry", delay=0.05)  # 5 ticks at 100 Hz
    left, right = [], []
    for k in range(20):
        x = 0.5 if k >= 3 else 0.0
        out = blk.tick(0.01, {"in": frame(desk, ear_left=x, ear_right=x)})["out"]
        left.append(out.values[ch(desk, "ear_left")])
        right.append(out.values[ch(desk, "ear_right")])
    assert np.argmax(np.array(left) > 0.25) == 3
    assert np.argmax(np.array(right) > 0.25) == 8


def test_asymmetry_offsets_and_gains_clamped(desk):
    blk = make(
        desk, "asymmetry", delay=0.0, offsets={"ear_left": 0.1}, gains={"ear_right": 0.5, "head_yaw": 3.0}
    )
    out = blk.tick(0.01, {"in": frame(desk, ear_left=0.2, ear_right=0.4, head_yaw=2.5)})["out"]
    assert out.values[ch(desk, "ear_left")] == pytest.approx(0.3)
    assert out.values[ch(desk, "ear_right")] == pytest.approx(0.2)
    assert out.values[ch(desk, "head_yaw")] == pytest.approx(desk.max[ch(desk, "head_yaw")])
    with pytest.raises(ValueError, match="no DoF 'tail'"):
        make(desk, "asymmetry", offsets={"tail": 0.1})


# --- exaggerate -----------------------------------------------------------------------------------


def test_exaggerate_doubles_deviation_from_rest_and_clamps(desk):
    blk = make(desk, "exaggerate", gain=2.0)
    out = blk.tick(0.01, {"in": frame(desk, head_yaw=0.2, eyelid_left=0.35, mouth=3.0)})["out"]
    assert out.values[ch(desk, "head_yaw")] == pytest.approx(0.4)
    assert out.values[ch(desk, "eyelid_left")] == pytest.approx(0.55)  # rest 0.15 + 2 * 0.2
    assert out.values[ch(desk, "mouth")] == 3.0  # display channels untouched
    hi = desk.max[ch(desk, "head_yaw")]
    out = blk.tick(0.01, {"in": frame(desk, head_yaw=0.9 * hi), "gain": 3.0})["out"]
    assert out.values[ch(desk, "head_yaw")] == pytest.approx(hi)


def test_exaggerate_moving_average_amplifies_changes_only(desk):
    blk = make(desk, "exaggerate", gain=2.0, reference="moving_average", time_constant=0.2)
    for _ in range(300):  # a held pose stays put
        out = blk.tick(0.01, {"in": frame(desk, head_pitch=0.1)})["out"]
    assert out.values[ch(desk, "head_pitch")] == pytest.approx(0.1, abs=1e-6)
    out = blk.tick(0.01, {"in": frame(desk, head_pitch=0.2)})["out"]
    assert 0.28 < out.values[ch(desk, "head_pitch")] < 0.3  # the step is nearly doubled


# --- arc ------------------------------------------------------------------------------------------


def test_arc_dips_secondary_only_while_primary_moves(desk):
    blk = make(desk, "arc", primary="head_yaw", secondary="head_pitch", gain=0.1, smoothing=0.02)
    pitch = []
    yaw = 0.0
    for k in range(150):
        if 20 <= k < 70:
            yaw += 0.01 if k < 45 else -0.01  # 1 rad/s right, then back: abs mode dips both ways
        out = blk.tick(0.01, {"in": frame(desk, head_yaw=yaw, head_pitch=0.05)})["out"]
        pitch.append(out.values[ch(desk, "head_pitch")])
    pitch = np.array(pitch)
    assert np.allclose(pitch[:20], 0.05)
    assert pitch[40] == pytest.approx(0.15, abs=0.01)  # 0.05 + 0.1 * 1 rad/s
    assert pitch[65] == pytest.approx(0.15, abs=0.01)
    assert np.allclose(pitch[-20:], 0.05, atol=1e-4)


def test_arc_signed_and_validation(desk):
    blk = make(desk, "arc", gain=0.1, mode="signed", smoothing=0.0)
    blk.tick(0.01, {"in": frame(desk, head_yaw=0.0)})
    out = blk.tick(0.01, {"in": frame(desk, head_yaw=-0.01)})
    assert out["offset"] == pytest.approx(-0.1)
    with pytest.raises(ValidationError, match="different DoFs"):
        BLOCKS["arc"].Params(primary="head_yaw", secondary="head_yaw")
    with pytest.raises(ValueError, match="continuous"):
        make(desk, "arc", secondary="mouth")


# --- follow-through -------------------------------------------------------------------------------


def _step_response(desk, rate, seconds=2.0, **kw):
    blk = make(desk, "follow_through", rate=rate, dofs=["head_yaw"], **kw)
    dt = 1.0 / rate
    out = []
    for k in range(int(seconds * rate)):
        x = 0.3 if k >= 1 else 0.0
        out.append(blk.tick(dt, {"in": frame(desk, head_yaw=x, head_pitch=0.1)})["out"])
    return out


def test_follow_through_disabled_is_identity(desk):
    blk = make(desk, "follow_through")
    rng = np.random.default_rng(1)
    for _ in range(20):
        f = frame(desk, head_yaw=float(rng.uniform(-1, 1)), ear_left=float(rng.uniform(-1, 1)))
        out = blk.tick(0.01, {"in": f})["out"]
        assert np.array_equal(out.values, f.values) and np.array_equal(out.mask, f.mask)


def test_follow_through_overshoots_then_settles(desk):
    out = _step_response(desk, 100, enabled=True, frequency=2.0, damping=0.2, max_overshoot=0.5)
    yaw = np.array([f.values[ch(desk, "head_yaw")] for f in out])
    assert yaw.max() > 0.3 + 0.05  # overshoot
    assert yaw[-1] == pytest.approx(0.3, abs=0.005)  # settled
    assert all(f.values[ch(desk, "head_pitch")] == pytest.approx(0.1) for f in out)  # unselected: untouched


def test_follow_through_same_shape_at_100_and_1000_hz(desk):
    kw = dict(enabled=True, frequency=1.5, damping=0.3, max_overshoot=0.5)
    a = np.array([f.values[ch(desk, "head_yaw")] for f in _step_response(desk, 100, **kw)])
    b = np.array([f.values[ch(desk, "head_yaw")] for f in _step_response(desk, 1000, **kw)])
    # the step arrives at tick 1 in both: tick k shows the response k ticks after it (time k * dt)
    assert np.allclose(a[1:200], b[10:2000:10], atol=1e-9)


def test_follow_through_never_exceeds_max_overshoot(desk):
    out = _step_response(desk, 100, enabled=True, frequency=3.0, damping=0.05, max_overshoot=0.04)
    yaw = np.array([f.values[ch(desk, "head_yaw")] for f in out])
    assert yaw.max() <= 0.3 + 0.04 + 1e-12
    assert yaw.max() > 0.3 + 0.03  # the clamp is reached, not avoided


def test_spring_matrix_is_exact_composition(desk):
    m1 = spring_step_matrix(2.0, 0.3, 0.01)
    m10 = spring_step_matrix(2.0, 0.3, 0.001)
    assert np.allclose(np.linalg.matrix_power(m10, 10), m1, atol=1e-12)
    c1 = spring_step_matrix(2.0, 1.0, 0.01)
    assert np.allclose(np.linalg.matrix_power(spring_step_matrix(2.0, 1.0, 0.005), 2), c1, atol=1e-12)


# --- delay ----------------------------------------------------------------------------------------


def test_delay_delays_selected_dofs_by_n_ticks(desk):
    blk = make(desk, "delay", dofs=["ear_*"], delay=0.07, delays={"head_pitch": 0.02})
    ev = FrameEvent("sound", "sound", {"clip": "beep"})
    rows = []
    for k in range(15):
        x = 0.4 if k >= 2 else 0.0
        out = blk.tick(
            0.01, {"in": frame(desk, [ev] if k == 2 else [], ear_left=x, head_yaw=x, head_pitch=x)}
        )["out"]
        rows.append(
            (
                out.values[ch(desk, "ear_left")],
                out.values[ch(desk, "head_yaw")],
                out.values[ch(desk, "head_pitch")],
                out.events,
            )
        )
    first = [next(k for k, r in enumerate(rows) if r[i] > 0.2) for i in range(3)]
    assert first == [9, 2, 4]
    assert rows[2][3] == [ev]  # events pass at once


def test_delay_keeps_state_when_params_change(desk):
    cls = BLOCKS["delay"]
    blk = make(desk, "delay", dofs=["head_yaw"], delay=0.05)
    for k in range(10):
        blk.tick(0.01, {"in": frame(desk, head_yaw=0.01 * k)})
    blk.update_params(cls.Params(dofs=["head_yaw"], delay=0.03))
    out = blk.tick(0.01, {"in": frame(desk, head_yaw=0.1)})["out"]
    assert out.values[ch(desk, "head_yaw")] == pytest.approx(0.07)
