"""A scripted AI for the bundled robot: ten seconds of the commands an AI sends a running program (gaze
shifts, emotions, gestures, speech, sounds, LEDs, expressions, postures, a layer switched off and on),
repeated. Used by the fast-path test (tests/test_compiled_blocks.py) and the engine benchmark
(benchmarks/bench_engine.py), so both exercise the program the way users run it.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

PERIOD = 10.0  # s: the script repeats after this

SCRIPT: tuple[tuple[float, dict[str, Any]], ...] = (
    (0.5, {"type": "set_gaze", "target": [0.6, 0.3, 0.4]}),
    (1.0, {"type": "set_emotion", "valence": 0.7, "arousal": 0.5}),
    (1.5, {"type": "play_clip", "clip": "wave", "layer": "gesture"}),
    (2.0, {"type": "say", "text": "Hello there, nice to meet you"}),
    (2.5, {"type": "set_led", "colour": [1.0, 0.2, 0.1]}),
    (3.0, {"type": "go_posture", "posture": "curious", "duration": 1.0}),
    (3.2, {"type": "set_face", "expression": "smile"}),
    (4.0, {"type": "set_gaze", "target": [0.4, -0.5, 0.2]}),
    (4.5, {"type": "play_clip", "clip": "nod", "layer": "gesture"}),
    (5.0, {"type": "set_emotion", "valence": -0.8, "arousal": -0.6}),
    (5.5, {"type": "play_sound", "sound": "beep"}),
    (6.0, {"type": "set_gaze", "target": [-0.3, 0.1, 0.9]}),
    (6.5, {"type": "set_layer", "mixer": "mix", "layer": "wander", "active": False}),
    (7.0, {"type": "go_posture", "posture": "sad", "duration": 0.8}),
    (7.5, {"type": "set_gaze", "target": [1.0, 0.0, 0.35]}),
    (8.0, {"type": "play_clip", "clip": "surprised", "layer": "gesture"}),
    (8.5, {"type": "set_layer", "mixer": "mix", "layer": "wander", "active": True}),
    (9.0, {"type": "set_emotion", "valence": 0.0, "arousal": 0.9}),
)


def timeline(seconds: float) -> Iterator[tuple[float, dict[str, Any]]]:
    """(t, command) for `seconds` of the script, repeated; t in s from the start."""
    start = 0.0
    while start < seconds:
        for t, command in SCRIPT:
            if start + t < seconds:
                yield start + t, dict(command)
        start += PERIOD


def run(session: Any, seconds: float) -> Iterator[Any]:
    """Tick `session` headless for `seconds` of engine time, sending the script's commands when their
    time comes; commands the running program cannot take (no gaze input, no mixer) are skipped.
    Yields every frame."""
    engine = session.engine
    pending = list(timeline(seconds))
    k = 0
    for _ in range(round(seconds * engine.rate)):
        while k < len(pending) and pending[k][0] <= engine.t + 1e-9:
            # CommandError (a ValueError): a program without the command's target skips it
            with contextlib.suppress(ValueError):
                session.execute(pending[k][1])
            k += 1
        yield engine.tick()
