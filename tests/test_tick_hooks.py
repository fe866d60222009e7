"""Tick hooks (backend/engine/tick_hooks.py): a hook with nothing to do sleeps (`IDLE`) until woken, so
an idle behaviour player costs a tick no call; woken, hooks run again in the order they were added."""

from __future__ import annotations

import threading
from pathlib import Path

from backend.engine.runtime import Engine
from backend.engine.tick_hooks import IDLE, TickHooks
from backend.session import EngineSession

INTERACTIVE = (
    Path(__file__).resolve().parents[1] / "robots/nutty_desk/programs/interactive.json"
).read_text()


def test_an_idle_hook_sleeps_until_woken_and_wakes_in_its_place():
    hooks, calls = TickHooks(), []
    idle = {"b": True}

    def a(t):
        calls.append(("a", t))

    def b(t):
        calls.append(("b", t))
        return IDLE if idle["b"] else None

    def broken(t):
        raise RuntimeError("a hook's bug")

    for fn in (a, b, broken):
        hooks.add(fn)
    hooks.run(0.0)
    hooks.run(0.01)  # b slept after its first call; the broken hook's fault stopped nothing
    assert calls == [("a", 0.0), ("b", 0.0), ("a", 0.01)]
    hooks.wake(b)
    hooks.wake(b)  # waking an awake hook changes nothing
    assert hooks.awake == (a, b, broken)
    idle["b"] = False
    calls.clear()
    hooks.run(0.02)
    hooks.run(0.03)
    assert calls == [("a", 0.02), ("b", 0.02), ("a", 0.03), ("b", 0.03)]


def test_a_hook_woken_from_another_thread_runs_from_the_next_tick(desk):
    engine = Engine(desk, rate=100.0)
    seen = []

    def hook(t):
        seen.append(round(t, 3))
        return IDLE

    engine.add_tick_hook(hook)
    engine.start()
    try:
        for _ in range(3000):  # (the clock's first ticks: well within 30 s)
            if seen:
                break
            threading.Event().wait(0.01)
        engine.wake_tick_hook(hook)  # from this thread: carried out at a tick boundary
        engine.call(lambda: None)  # one boundary later it has run
        engine.call(lambda: None)
    finally:
        engine.close()
    assert len(seen) == 2 and seen[1] > seen[0]


def test_the_behaviour_player_sleeps_while_idle_and_plays_when_asked(desk):
    session = EngineSession.create(desk, rate=100, program_text=INTERACTIVE)
    engine = session.engine
    player_hook = session.behaviours._tick
    engine.run_ticks(3)
    assert player_hook not in engine.hooks.awake  # idle: the ticks call nothing of it
    session.execute({"type": "play_behaviour", "behaviour": "greet", "id": "g1", "params": {"name": "Ana"}})
    assert player_hook in engine.hooks.awake
    for _ in range(600):
        engine.tick()
        if any(n.get("command_id") == "g1" and n["event"] == "completed" for n in session.notes):
            break
    else:
        raise AssertionError("the behaviour never completed")
    engine.tick()
    assert player_hook not in engine.hooks.awake  # done: asleep again
