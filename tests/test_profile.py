"""Per-node cook times: sampled by the APU, served by /api/profile and /ws/telemetry, printed by
`nutty run --profile`; and the measurement window /api/status reports."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.api_types import Profile, Telemetry
from backend.cli import main
from backend.engine.clock import RingStats, SampledCpu
from backend.engine.frames import PartialFrame
from backend.engine.profile import CookTimes, format_table
from backend.routes.telemetry import PROFILE_PERIOD, Subscription, signal_json, signals_json
from backend.session import EngineSession

PROGRAMS = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs"


@pytest.fixture()
def session(desk):
    s = EngineSession.create(desk, program=json.loads((PROGRAMS / "interactive.json").read_text()))
    yield s
    s.engine.close()


def test_one_tick_in_every_is_timed_node_by_node(session):
    apu = session.engine.apu
    assert apu.cook.every == 10
    session.engine.run_ticks(95)
    summary = session.engine.profile()
    assert summary["samples"] == 9  # ticks 10, 20, ... 90
    assert [n["node"] for n in summary["nodes"]] == [s.node_id for s in apu.steps]  # tick order
    look_at = next(n for n in summary["nodes"] if n["node"] == "look_at")
    assert look_at["type"] == "ik" and 0 < look_at["p50_us"] <= look_at["p99_us"] <= look_at["max_us"]
    apu_mean = summary["apu"]["mean_us"]
    for n in summary["nodes"]:
        assert n["share"] == pytest.approx(n["mean_us"] / apu_mean)
    # The nodes are timed inside the APU's tick, so their shares can't add past the whole; how far short
    # they fall (the loop between them, a thread taking the GIL) depends on the machine's load.
    assert 0 < sum(n["share"] for n in summary["nodes"]) <= 1.0 + 1e-9
    assert summary["apu"]["mean_us"] >= max(n["mean_us"] for n in summary["nodes"])
    Profile.model_validate(summary)


def test_a_fast_clock_times_ten_ticks_a_second(desk):
    s = EngineSession.create(desk, rate=500, program=json.loads((PROGRAMS / "idle.json").read_text()))
    try:
        assert s.engine.apu.cook.every == 50  # a timed tick runs the blocks one by one, not the core
        s.engine.run_ticks(120)
        assert s.engine.profile()["samples"] == 2
    finally:
        s.engine.close()


def test_profiling_every_tick_and_a_fresh_window(session):
    session.engine.set_profiling(every=1, window=50)
    session.engine.run_ticks(80)
    summary = session.engine.profile()
    assert summary["every"] == 1 and summary["window"] == 50 and summary["samples"] == 50
    session.engine.reset_stats()
    assert session.engine.profile()["samples"] == 0
    assert session.engine.stats()["tick_cost"]["samples"] == 0
    assert session.engine.ticks == 80  # the counters go on
    session.load_program(json.loads((PROGRAMS / "idle.json").read_text()))  # a new program keeps the setting
    session.engine.run_ticks(3)
    assert session.engine.profile()["samples"] == 3


def test_cpu_time_is_read_on_one_plain_tick_in_every():
    ring = RingStats()
    cpu = SampledCpu(ring, every=4)
    plain = [True, True, True, True, False, False, True, True, True, True, True]
    asked = []

    def is_plain(k: int) -> bool:
        asked.append(k)
        return plain[k]

    def tick_starts(plain: Any) -> bool:  # as the engine's tick calls it
        cpu.due -= 1
        return cpu.due <= 0 and cpu.start(plain) >= 0.0

    read = [tick_starts(lambda k=k: is_plain(k)) for k in range(len(plain))]
    # due at the first tick, then four later; a tick that isn't plain moves the reading to the next one
    assert read == [True, False, False, False, False, False, True, False, False, False, True]
    assert asked == [0, 4, 5, 6, 10]  # asked only on the ticks due to be read
    assert not tick_starts(None) and [tick_starts(None) for _ in range(3)] == [False, False, True]


def test_the_engine_reads_its_cpu_time_between_the_timed_ticks(session):
    engine = session.engine
    timed, plain = [], []
    original = engine._cpu.start

    def start(is_plain) -> float:
        def asked() -> bool:
            plain.append(is_plain())
            timed.append(engine.apu._untimed + 1 >= engine.apu.cook.every)
            return plain[-1]

        return original(asked)

    engine._cpu.start = start
    engine.run_ticks(200)
    summary = engine.stats()["tick_cpu"]
    assert 15 <= summary["samples"] <= 20 and summary["p50_ms"] > 0  # one tick in ten, about
    assert not any(p and t for p, t in zip(plain, timed))  # a timed tick is never called plain


def test_cook_time_table_most_expensive_first():
    cook = CookTimes(["a", "b"], ["sine", "ik"], every=1, window=4)
    for costs in ([1000, 9000, 10500], [3000, 7000, 10400]):
        cook.row[:] = costs
        cook.record()
    table = format_table(cook.summary()).splitlines()
    assert table[1].split()[:3] == ["b", "ik", "8.0"] and table[2].split()[0] == "a"
    assert table[-1].startswith("APU tick") and "2 timed ticks" in table[-1]


def test_profile_routes_and_telemetry(session):
    session.engine.run_ticks(30)
    with TestClient(create_app(session, frontend_dir=None)) as client:
        got = client.get("/api/profile").json()
        Profile.model_validate(got)
        assert got["samples"] == 3 and len(got["nodes"]) == len(session.engine.apu.steps)
        fresh = client.delete("/api/profile").json()
        assert fresh["samples"] == 0 and client.get("/api/status").json()["tick_cost"]["samples"] == 0
        status = client.get("/api/status").json()
        assert {"tick_cpu", "started_at", "clock_priority"} <= status.keys()
    session.engine.run_ticks(20)
    sub = Subscription()
    sub.update({"type": "subscribe", "signals": [{"node": "mix", "port": "out"}], "frames": True, "rate": 30})
    frame = session.engine.last_frame
    seq, text = sub.text(session, frame, slot=("a", 1))
    message = json.loads(text)
    assert seq == frame.seq and message["profile"]["samples"] == 2  # the first message carries the cook times
    Telemetry.model_validate(message)
    _, again = sub.text(session, frame, slot=("a", 1))
    assert "profile" not in json.loads(again)  # then about once every PROFILE_PERIOD seconds
    sub.profile_at -= PROFILE_PERIOD
    assert "profile" in json.loads(sub.text(session, frame, slot=("a", 2))[1])


def test_clients_subscribed_alike_share_one_message_per_slot(session):
    session.engine.run_ticks(5)
    subs = []
    for _ in range(3):
        sub = Subscription()
        sub.update(
            {
                "type": "subscribe",
                "signals": [{"node": "gaze", "port": "on_target"}],
                "frames": True,
                "rate": 30,
            }
        )
        sub.profile_at = float("inf")  # no cook times in these messages
        subs.append(sub)
    first = subs[0].text(session, session.engine.last_frame, slot=(30.0, 7))
    session.engine.run_ticks(1)  # a newer frame: the same slot still gets the same message
    assert all(s.text(session, session.engine.last_frame, slot=(30.0, 7)) == first for s in subs[1:])
    newer = subs[1].text(session, session.engine.last_frame, slot=(30.0, 8))
    assert newer[0] == first[0] + 1


def test_signals_are_written_together_as_one_at_a_time(session, desk):
    """The telemetry's batched writing of node outputs gives each output's JSON exactly, on every
    output of the running interactive program and on odd values."""
    apu = session.engine.apu
    session.engine.run_ticks(3)
    ports = [(step.node_id, port) for step in apu.steps for port in apu.results[apu.index[step.node_id]]]
    assert len(ports) > 20
    for _ in range(5):
        session.engine.run_ticks(7)
        values = [apu.signal_value(node, port) for node, port in ports]
        assert [signal_json(desk, v) for v in values] == signals_json(desk, values)
    odd = [
        float("nan"),
        np.float64(0.25),
        3,
        True,
        "text",
        None,
        np.arange(20.0),
        PartialFrame.empty(desk.n_channels),
    ]
    assert signals_json(desk, odd) == [signal_json(desk, v) for v in odd]
    short = PartialFrame(np.ones(3), np.ones(3, dtype=bool))  # not over the robot's channels: one at a time
    assert signals_json(desk, [short, odd[-1]]) == [signal_json(desk, short), signal_json(desk, odd[-1])]


def test_run_profile_prints_a_table(capsys, tmp_path):
    out = tmp_path / "out.csv"
    code = main(
        ["run", str(PROGRAMS / "interactive.json"), "--seconds", "0.3", "--out", str(out), "--profile"]
    )
    printed = capsys.readouterr().out.splitlines()
    assert code == 0 and printed[0].split()[:2] == ["node", "type"]
    rows = [line.split() for line in printed[1:-1]]
    nodes = {n["id"] for n in json.loads((PROGRAMS / "interactive.json").read_text())["nodes"]}
    assert {r[0] for r in rows} == nodes and len(rows) == len(nodes)  # one row per node, each once
    means = [float(r[2]) for r in rows]
    assert means == sorted(means, reverse=True)
    assert "30 timed ticks, 1 in 1" in printed[-1]


def test_a_ring_keeps_its_last_samples_and_forgets_them_on_reset():
    ring = RingStats(size=4)
    for x in (0.009, 0.001, 0.002, 0.003, 0.004, 0.005):  # (s) the first two fall out
        ring.add(x)
    summary = ring.summary()
    assert summary["samples"] == 4 and summary["max_ms"] == 5.0 and summary["p50_ms"] == 3.5
    ring.reset()
    assert ring.summary()["samples"] == 0
    ring.add(0.002)
    assert ring.summary() == {"p50_ms": 2.0, "p99_ms": 2.0, "max_ms": 2.0, "samples": 1}
