"""No tick loads compiled code: what the clock reaches now and then is loaded beside it (warm_up.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numba.core.dispatcher as numba_dispatcher
import scripted_ai

from backend.engine import warm_up
from backend.session import EngineSession

PROGRAMS = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs"


def test_a_corrected_frame_loads_no_compiled_code_on_the_clock(desk, monkeypatch):
    session = EngineSession.create(desk, program=json.loads((PROGRAMS / "interactive.json").read_text()))
    try:
        session.engine.run_ticks(2)  # the second tick starts the warm-up thread
        assert warm_up.wait(120)
        loads = []
        original = numba_dispatcher.Dispatcher._compile_for_args

        def spy(self, *args, **kw):
            loads.append(self.py_func.__qualname__)
            return original(self, *args, **kw)

        monkeypatch.setattr(numba_dispatcher.Dispatcher, "_compile_for_args", spy)
        frames = scripted_ai.run(session, 10.0)
        assert any(f.net is not None for f in frames)  # the net corrected, and said why
        assert loads == []
    finally:
        session.engine.close()


def test_the_sounds_are_read_before_the_clock_plays_them(desk):
    session = EngineSession.create(desk)
    try:
        sounds = session.library.sounds
        assert sounds.warming is not None
        sounds.warming.join(30)
        assert sounds.list() and set(sounds._info) == set(sounds.list())  # no file read in a tick
    finally:
        session.engine.close()
