"""The compiled fast path agrees with its numpy references (backend/engine/compiled): kernel by kernel on
random inputs, block by block over many ticks, and over ten seconds of the interactive program under a
scripted AI. Timing is benchmarks/bench_engine.py's business, not these tests'."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scripted_ai

from backend.engine.blend import BlendMode, advance_fades, blend_layers
from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import BlockContext
from backend.engine.clips import compile_clip
from backend.engine.compiled import REFERENCE_ENV, entry_point
from backend.engine.compiled.blend import MIXER_SIG, MODE_CODES, mixer_tick
from backend.engine.compiled.chain import _kinematics, chain_args
from backend.engine.curves import INTERPS, CurveSet, Key
from backend.engine.embodiment import load_embodiment
from backend.engine.frames import PartialFrame
from backend.engine.kinematics import Chain, chain_for
from backend.session import EngineSession

ROBOT = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk"
PROGRAMS = ROBOT / "programs"

# A chain with a prismatic joint and a mimic joint, which the desk robot does not have.
ODD_URDF = """<?xml version="1.0"?>
<robot name="odd">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="tip"/>
  <joint name="turn" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0 0 0.1" rpy="0.1 0 0.2"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" velocity="1" effort="1"/></joint>
  <joint name="slide" type="prismatic"><parent link="a"/><child link="b"/><origin xyz="0.2 0 0"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.3" velocity="1" effort="1"/></joint>
  <joint name="follow" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0 0.1 0" rpy="0 0.3 0"/>
    <axis xyz="0 1 0"/><mimic joint="turn" multiplier="-0.5" offset="0.1"/>
    <limit lower="-2" upper="2" velocity="1" effort="1"/></joint>
  <joint name="wrist" type="revolute"><parent link="c"/><child link="tip"/><origin xyz="0.05 0 0.02"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
</robot>
"""


def program(name: str) -> dict:
    return json.loads((PROGRAMS / f"{name}.json").read_text())


def run_program(name: str, monkeypatch, reference: bool, seconds: float = 10.0) -> tuple[list, EngineSession]:
    """Frames of `seconds` of a bundled program under the scripted AI, on the reference or fast path."""
    if reference:
        monkeypatch.setenv(REFERENCE_ENV, "1")
    else:
        monkeypatch.delenv(REFERENCE_ENV, raising=False)
    session = EngineSession.create(load_embodiment("nutty_desk"), program=program(name))
    frames = [
        (f.position.copy(), f.stage1.copy(), f.program.copy(), [e.to_dict() for e in f.events])
        for f in scripted_ai.run(session, seconds)
    ]
    return frames, session


def test_fast_path_frames_match_the_reference_over_ten_seconds_of_the_interactive_program(monkeypatch):
    fast, fast_session = run_program("interactive", monkeypatch, reference=False)
    slow, slow_session = run_program("interactive", monkeypatch, reference=True)
    assert fast_session.engine.apu.block("look_at")._kernel is not None  # the fast path really ran
    assert slow_session.engine.apu.block("look_at")._kernel is None
    assert len(fast) == len(slow) == 1000
    worst = max(max(np.abs(a - b).max() for a, b in zip(f[:3], s[:3])) for f, s in zip(fast, slow))
    # Not bit for bit: the IK's 3x3 inverse (cofactors vs LAPACK) and libm vs numpy's vector math differ in
    # the last bits, and the IK's iterations carry them from tick to tick; measured ~1e-7 rad at most.
    assert worst < 1e-6
    assert [f[3] for f in fast] == [s[3] for s in slow]  # the same speech, sounds and expressions
    moved = np.ptp(np.array([f[0] for f in fast]), axis=0)
    assert moved.max() > 0.5  # the script made the robot move: the comparison covered real motion


@pytest.mark.parametrize("name", ["idle", "greet", "breathe-anything"])
def test_fast_path_matches_the_reference_on_every_shipped_program(monkeypatch, name):
    fast, _ = run_program(name, monkeypatch, reference=False, seconds=4.0)
    slow, _ = run_program(name, monkeypatch, reference=True, seconds=4.0)
    for f, s in zip(fast, slow):
        for a, b in zip(f[:3], s[:3]):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
        assert f[3] == s[3]


def test_mixer_kernel_matches_blend_layers_and_fades(desk):
    rng = np.random.default_rng(3)
    n = desk.n_channels
    entry = entry_point(mixer_tick, MIXER_SIG)
    modes = [BlendMode.override, BlendMode.additive, BlendMode.average]
    for _trial in range(200):
        layers = int(rng.integers(1, 7))
        mode_list = [modes[int(k)] for k in rng.integers(0, 3, layers)]
        values = rng.normal(desk.rest, 0.5, (layers, n))
        values[:, desk.enum_mask] = rng.integers(0, 4, (layers, int(desk.enum_mask.sum())))
        masks = rng.random((layers, n)) < 0.6
        layer_masks = rng.random((layers, n)) < 0.8
        weights = np.where(rng.random(layers) < 0.2, 0.0, rng.random(layers))
        level, target = rng.random(layers), (rng.random(layers) < 0.5).astype(float)
        fade_time = np.where(rng.random(layers) < 0.3, 0.0, rng.uniform(0.1, 2.0, layers))
        signal = rng.random(layers)
        # reference
        ref_level = advance_fades(level, target, fade_time, 0.01)
        w = weights * ref_level * signal
        ref, ref_mask = blend_layers(
            values, masks & layer_masks, w, mode_list, desk.rest, desk.rest, desk.enum_mask
        )
        # kernel
        lvl, out, out_mask, w_out = level.copy(), np.empty(n), np.empty(n, dtype=bool), np.empty(layers)
        entry(
            values.ravel().copy(),
            masks.ravel().copy(),
            layer_masks,
            weights,
            lvl,
            target,
            fade_time,
            signal,
            0.01,
            np.array([MODE_CODES[m] for m in mode_list], dtype=np.int64),
            desk.rest,
            desk.rest,
            desk.enum_mask,
            out,
            out_mask,
            w_out,
        )
        np.testing.assert_array_equal(lvl, ref_level)
        np.testing.assert_allclose(out, ref, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(out_mask, ref_mask)


@pytest.mark.parametrize("robot", ["desk", "odd"])
def test_chain_kernel_matches_chain_kinematics(robot, desk, tmp_path):
    if robot == "desk":
        chain = chain_for(desk, None, desk.gaze["eye_link"])
    else:
        path = tmp_path / "odd.urdf"
        path.write_text(ODD_URDF)
        chain = Chain(path, None, "tip")
        assert not chain._identity_map and not chain._all_revolute
    args = chain_args(chain)
    rng = np.random.default_rng(5)
    point, direction = np.array([0.07, 0.01, 0.08]), np.array([1.0, 0.0, 0.0])
    for _ in range(100):
        q = rng.uniform(chain.lower, chain.upper)
        _tip, p, d, jp, jd = chain.kinematics(q, point, direction)
        kp, kd, kjp, kjd = _kinematics(q, point, direction, *args)
        for a, b in ((p, kp), (d, kd), (jp, kjp), (jd, kjd)):
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-12)


def twin_blocks(type_name: str, params: dict, emb, seed: int = 0):
    """The same block on the fast path and on its numpy reference."""
    cls = BLOCKS[type_name]
    made = []
    for compiled in (True, False):
        ctx = BlockContext(embodiment=emb, rate=100.0, seed=seed, compiled=compiled)
        made.append(cls(cls.Params.model_validate(params), ctx, "node"))
    return made


def random_frame(rng, emb, p_set: float = 0.7) -> PartialFrame:
    values = np.clip(rng.normal(emb.rest, 0.3), emb.min, emb.max)
    return PartialFrame(values, rng.random(emb.n_channels) < p_set, [])


def assert_same(a, b, atol=1e-12):
    assert a.keys() == b.keys()
    for port in a:
        x, y = a[port], b[port]
        if isinstance(x, PartialFrame):
            np.testing.assert_allclose(x.values, y.values, rtol=0, atol=atol)
            np.testing.assert_array_equal(x.mask, y.mask)
            assert x.events == y.events
        else:
            assert x == y


@pytest.mark.parametrize(
    "type_name,params,inputs",
    [
        ("breathe", {"dofs": ["stationary:*"], "amplitudes": {"ear_left": 0.1}, "phase_spread": 0.7}, ()),
        ("noise", {"dofs": ["head_*"], "smoothing": 0.4}, ()),
        ("noise", {"dofs": ["head_*"], "smoothing": 0.0}, ()),
        ("weight_shift", {"min_interval": 0.5, "max_interval": 1.0, "shift_duration": 0.4}, ()),
        ("gain_offset", {"dofs": ["neck_pitch", "head_*"], "gain": 1.7, "offset": -0.1}, ("in",)),
        ("safety_limiter", {"velocity_scale": 0.5, "margin": 0.1}, ("in",)),
        ("output", {}, ("in",)),
        ("motion_filter", {"dofs": ["head_*"], "preset": "C"}, ("in",)),
        ("nmf_stage2", {"preset": "D"}, ("in",)),
        ("ik", {"mode": "look_at", "weight": 0.7, "target": [0.5, 0.3, 0.4]}, ("in",)),
        ("ik", {"mode": "reach", "target": [0.2, 0.1, 0.5]}, ("in",)),
        ("gaze", {"follow_lag": 0.3}, ("target",)),
        (
            "layer_mixer",
            {
                "layers": [
                    {"name": "base"},
                    {"name": "pose", "mode": "override", "weight": 0.6},
                    {"name": "idle", "mode": "additive"},
                    {"name": "avg", "mode": "average"},
                ]
            },
            ("base", "pose", "idle", "avg", "idle_weight"),
        ),
    ],
)
def test_block_fast_path_matches_its_reference_tick_by_tick(desk, type_name, params, inputs):
    fast, slow = twin_blocks(type_name, params, desk)
    assert getattr(fast, "_kernel", None) is not None and getattr(slow, "_kernel", None) is None
    rng = np.random.default_rng(11)
    given_target: list[float] = []
    last: dict = {}
    for tick in range(300):
        given = {}
        for port in inputs:
            if port == "target":
                given[port] = (
                    list(rng.uniform([-0.5, -1.0, 0.0], [1.5, 1.0, 1.0])) if tick % 40 == 0 else given_target
                )
            elif port.endswith("_weight"):
                given[port] = float(rng.random())
            elif rng.random() < 0.05:
                continue  # now and then nothing arrives on a port
            else:
                given[port] = random_frame(rng, desk) if tick % 7 == 0 or port not in last else last[port]
        if "target" in given:
            given_target = given["target"]
        last = {k: v for k, v in given.items() if isinstance(v, PartialFrame)} if tick else {}
        a, b = fast.tick(0.01, dict(given)), slow.tick(0.01, dict(given))
        # the IK and the gaze iterate: their last bits differ and carry over, as in the program test
        assert_same(a, b, atol=1e-9 if type_name in ("ik", "gaze") else 1e-12)


def test_clip_player_fast_path_matches_its_reference_through_plays_crossfades_and_releases(desk, tmp_path):
    from backend.engine.library import RobotLibrary

    lib = RobotLibrary(tmp_path, desk)
    for p in (ROBOT / "clips").glob("*.json"):
        lib.save("clips", p.stem, json.loads(p.read_text()))
    # an absolute clip with an enum track and every interpolation, beside the bundled (relative) ones
    lib.save(
        "clips",
        "absolute",
        {
            "format": "nutty-clip/1",
            "name": "absolute",
            "tracks": {
                "head_yaw": [
                    {"t": 0, "v": -0.4, "interp": "linear"},
                    {"t": 0.3, "v": 0.2, "interp": "constant"},
                    {"t": 0.6, "v": 0.5, "interp": "quad"},
                    {"t": 1.0, "v": -0.1},
                ],
                "mouth": [{"t": 0, "v": "neutral"}, {"t": 0.5, "v": "smile"}],
                "eye_leds": [{"t": 0, "v": [1.0, 0.0, 0.2]}, {"t": 0.8, "v": [0.0, 1.0, 0.5]}],
            },
        },
    )
    made = []
    for compiled in (True, False):
        ctx = BlockContext(embodiment=desk, rate=100.0, resources=lib, compiled=compiled)
        made.append(BLOCKS["clip_player"](BLOCKS["clip_player"].Params(crossfade=0.3, release=0.4), ctx, "g"))
    fast, slow = made
    assert fast._kernel is not None and slow._kernel is None
    plays = {
        0: {"clip": "wave"},
        40: {"clip": "absolute", "mode": "ping_pong"},
        170: {"clip": "nod", "speed": 1.7},
        190: {"clip": "absolute", "if_busy": "queue"},
        330: {"clip": "happy", "mode": "loop"},
        420: None,
        470: {"clip": "absolute", "crossfade": 0.0},
    }
    rng = np.random.default_rng(4)
    for tick in range(600):
        if tick in plays:
            for block in made:
                block.handle("play", plays[tick]) if plays[tick] else block.handle("stop", {})
        inputs = {"speed": float(rng.uniform(0.5, 2.0))} if tick % 50 < 20 else {}
        a, b = fast.tick(0.01, dict(inputs)), slow.tick(0.01, dict(inputs))
        assert_same(a, b)


def test_blink_and_led_shortcuts_keep_their_outputs(desk):
    blink_fast, blink_slow = twin_blocks(
        "blink",
        {"mean_interval": 0.6, "min_interval": 0.3, "max_interval": 1.0, "gaze_shift_threshold": 0.1},
        desk,
    )
    rng = np.random.default_rng(2)
    gaze = [1.0, 0.0, 0.3]
    for tick in range(600):
        if tick % 50 == 0:
            gaze = list(rng.uniform(-1, 1, 3))
        assert_same(blink_fast.tick(0.01, {"gaze": gaze}), blink_slow.tick(0.01, {"gaze": list(gaze)}))


def curve_sets() -> list[CurveSet]:
    sets = [
        compile_clip(json.loads(p.read_text()), load_embodiment("nutty_desk")).curves
        for p in sorted((ROBOT / "clips").glob("*.json"))
    ]
    rng = np.random.default_rng(9)
    curves = []
    for interp in INTERPS:
        for easing in ("in", "out", "in_out"):
            times = np.cumsum(rng.uniform(0.1, 0.6, 5))
            curves.append(
                [
                    Key(float(t), float(v), interp, easing, left_type=str(rng.choice(["auto", "vector"])))
                    for t, v in zip(times, rng.normal(0, 1, 5))
                ]
            )
    sets.append(CurveSet(curves))
    return sets


def test_curve_kernel_matches_the_reference_for_every_interpolation(monkeypatch):
    monkeypatch.delenv(REFERENCE_ENV, raising=False)
    for cs in curve_sets():
        for t in np.linspace(cs.start - 0.3, cs.end + 0.3, 700):
            np.testing.assert_allclose(cs.evaluate(t), cs.evaluate_reference(t), rtol=0, atol=1e-12)


def test_simulated_servos_compiled_and_reference_report_the_same(desk):
    from backend.drivers.sim_servo import SimulatedServos

    session = EngineSession.create(desk, program=program("interactive"))
    frames = list(scripted_ai.run(session, 3.0))
    fast, slow = SimulatedServos(desk), SimulatedServos(desk)
    slow.compiled = False
    try:
        for f in frames:
            fast.consume(f)
            slow.consume(f)
        assert fast.report() == slow.report()
    finally:
        fast.close()
        slow.close()
