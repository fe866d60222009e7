"""Swaps, resets and parking move the robot within its limits, through the engine's own paths.

The situation found by hand: with the gaze turned, swapping in the bundled idle program moved
body_yaw 0.54 -> 0.00 rad in one 10 ms frame (35x its velocity limit). Every frame recorded here,
in-process and through a real server's REST API, stays within every DoF's position, velocity and
acceleration limits (and jerk, which the safety net also guarantees).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import httpx
import numpy as np
import pytest
from joint_truth import joint_truth
from server_process import running_server
from test_safety import ROUNDING

from backend.engine.runtime import Sink
from backend.engine.safety import SafetyNet
from backend.session import EngineSession

PROGRAMS = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs"


def program(name: str) -> dict:
    return json.loads((PROGRAMS / f"{name}.json").read_text())


def worst_ratios(desk, positions: np.ndarray, rate: float) -> dict[str, float]:
    """Worst |v|/V, |a|/A, |j|/J from the finite differences: over the continuous channels against their
    own limits, except the own channels of the joints the net's joint stage steps (they carry their joint's
    correction), and over every joint the frames compose to against the joint's limits (tests/joint_truth.py)."""
    net = SafetyNet(desk, rate)
    cont = desk.continuous_mask.copy()
    cont[net.joints.own[net.joints.governed]] = False
    p = positions[:, cont]
    v = np.diff(p, axis=0) * rate
    a = np.diff(v, axis=0) * rate
    j = np.diff(a, axis=0) * rate
    joints = joint_truth(desk.name).worst(joint_truth(desk.name).compose(desk, positions), rate)
    return {
        "v": max(float((np.abs(v) / desk.vel_limit[cont]).max()), joints["v"]),
        "a": max(float((np.abs(a) / desk.acc_limit[cont]).max()), joints["a"]),
        "j": max(float((np.abs(j) / desk.jerk_limit[cont]).max()), joints["j"]),
        "outside": max(float(np.maximum(desk.min[cont] - p, p - desk.max[cont]).max()), joints["outside"]),
    }


def recorded_frames(path: Path) -> list[dict]:
    """The frames a `--record F.jsonl` driver wrote, in order."""
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def recorded_positions(desk, rows: list[dict]) -> np.ndarray:
    """Every channel's position per recorded frame (continuous DoFs as recorded, the rest at rest),
    after checking that no frame is missing between the first and the last."""
    assert np.all(np.diff([r["seq"] for r in rows]) == 1)  # every frame recorded
    cont = [d for d in desk.dofs if d.type.value == "continuous"]
    full = np.tile(desk.rest, (len(rows), 1))
    full[:, [d.channels.start for d in cont]] = [[r["dofs"][d.name]["position"] for d in cont] for r in rows]
    return full


def assert_smooth(desk, positions, rate):
    r = worst_ratios(desk, positions, rate)
    assert r["v"] <= 1 + ROUNDING and r["a"] <= 1 + ROUNDING and r["j"] <= 1 + ROUNDING, r
    assert r["outside"] <= 1e-12, r


def turned_gaze(desk, rate=100.0) -> tuple[EngineSession, list]:
    session = EngineSession.create(desk, rate=rate, program=program("interactive"))
    frames = list(session.run_headless(20))
    session.execute({"type": "set_gaze", "target": [0.4, 0.6, 0.3]})
    frames += list(session.run_headless(int(2.5 * rate)))
    assert abs(frames[-1].position[desk.channel_index["body_yaw"]]) > 0.3  # really turned
    return session, frames


@pytest.mark.parametrize("swap_to", ["idle", "greet", "breathe-anything", "new"])
def test_swapping_with_the_gaze_turned_stays_within_limits(desk, swap_to):
    session, frames = turned_gaze(desk)
    if swap_to == "new":
        from backend.commands.serve import builtin_idle

        doc = builtin_idle(desk.name)
    else:
        doc = program(swap_to)
    for k in range(3):  # there and back again, twice
        session.load_program(doc if k % 2 == 0 else program("interactive"))
        frames += list(session.run_headless(120))
    session.load_program(doc)
    frames += list(session.run_headless(400))
    pos = np.array([f.position for f in frames])
    assert_smooth(desk, pos, 100.0)
    # The program arrives: after the transition the output is the new program's own.
    assert np.array_equal(frames[-1].position, frames[-1].program)


def test_the_jump_is_blended_out_not_only_clipped(desk):
    """A swap is an inertialized transition: the safety net has little or nothing left to correct."""
    session, _frames = turned_gaze(desk)
    before = session.engine.safety.corrected_ticks
    session.load_program(program("idle"))
    list(session.run_headless(300))
    assert session.engine.safety.corrected_ticks - before <= 5


def test_reset_restores_the_program_and_commands_work_after_it(desk):
    session, _ = turned_gaze(desk)
    session.execute({"type": "set_layer", "layer": "gesture", "active": False})
    list(session.run_headless(10))
    session.execute({"type": "reset", "fade": 0.5})
    frames = list(session.run_headless(300))
    mixer = next(s.block for s in session.engine.apu.steps if s.block.type_name == "layer_mixer")
    declared = mixer.params.model_dump()["layers"]
    assert [s["fade"] for s in mixer.layer_states()] == [
        1.0 if layer.get("active", True) else 0.0 for layer in declared
    ]
    assert session.inputs()["gaze_target"] == session.program.input("gaze_target").coerce(
        session.program.input("gaze_target").default
    )
    yaw = desk.channel_index["body_yaw"]
    assert abs(frames[-1].position[yaw]) < 0.05  # looking ahead again
    # The defect: after reset every layer but the base stayed off and clips did nothing.
    head = [desk.channel_index[n] for n in ("head_pitch", "head_yaw", "ear_left", "ear_right")]
    still = np.array([f.position[head] for f in session.run_headless(50)])
    session.execute({"type": "play_clip", "clip": "nod", "layer": "gesture"})
    moving = np.array([f.position[head] for f in session.run_headless(150)])
    assert np.ptp(moving, axis=0).max() > 3 * np.ptp(still, axis=0).max() + 0.02
    assert_smooth(desk, np.array([f.position for f in frames]), 100.0)


@pytest.mark.parametrize("rate", [100.0, 500.0])
def test_park_reaches_the_exact_rest_pose_within_the_bound(desk, rate):
    session, frames = turned_gaze(desk, rate)
    session.execute({"type": "play_clip", "clip": "wave", "layer": "gesture"})
    frames += list(session.run_headless(30))
    result = session.park(timeout=3.0)
    assert result["reached_rest"], result
    assert result["seconds"] <= 3.0 and result["max_error"] == 0.0
    last = session.engine.last_frame
    assert np.array_equal(last.position, desk.rest)
    assert not np.any(last.velocity) and not np.any(last.acceleration)


def test_park_with_the_clock_running(desk):
    session, _ = turned_gaze(desk)
    seen: list = []
    session.engine.add_sink(Sink("record", seen.append, max_queue=10_000))
    session.engine.start()
    try:
        result = session.park(timeout=3.0)
    finally:
        session.engine.close()
    assert result["reached_rest"], result
    assert np.array_equal(seen[-1].position, desk.rest)
    assert_smooth(desk, np.array([f.position for f in seen]), 100.0)


def wait_for_ticks(client, n: int, timeout: float = 60.0) -> None:
    """Poll the server until its clock has ticked `n` more times (the timeout only bounds a hang)."""
    target = client.status()["ticks"] + n
    deadline = time.monotonic() + timeout
    while client.status()["ticks"] < target:
        assert time.monotonic() < deadline, "the server's clock stopped ticking"
        time.sleep(0.05)


def test_swaps_through_the_real_server_stay_within_limits(tmp_path):
    """PUT /api/program back and forth on a real `nutty serve`, the frames recorded by its driver."""
    record = tmp_path / "frames.jsonl"
    with running_server("--no-previz", "--record", str(record)) as (url, _port, client):
        client.look_at(0.4, 0.6, 0.3)
        wait_for_ticks(client, 250)  # 2.5 s of the robot's time: the gaze has turned
        for name in ("idle", "interactive", "idle", "greet", "interactive"):
            r = httpx.put(f"{url}/api/program", json=program(name), timeout=10.0)
            assert r.status_code == 200, r.text
            wait_for_ticks(client, 60)
        status = client.status()
    assert status["safety"]["enabled"] is True
    from backend.engine.embodiment import load_embodiment

    desk = load_embodiment("nutty_desk")
    rows = recorded_frames(record)
    assert len(rows) > 300
    assert_smooth(desk, recorded_positions(desk, rows), 100.0)
