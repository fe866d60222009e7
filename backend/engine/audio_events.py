"""Speech and sound events as they go out: their start time, and the file a sound event plays."""

from __future__ import annotations

from backend.engine.frames import FrameEvent
from backend.engine.sounds import SoundLibrary, sound_url


def stamp_audio(sounds: SoundLibrary, events: list[FrameEvent], t: float) -> list[FrameEvent]:
    """A tick's events as they go out (`Engine.set_event_stamp`): every speech and sound event gets
    its start `t` (s, frame time), and one that plays a file of `sounds` (a sound's `clip`, a say's
    `audio`) also the sound's name, length (s) and URL, so a driver or a browser can fetch and play it."""
    out = []
    for ev in events:
        if ev.kind not in ("sound", "say"):
            out.append(ev)
            continue
        payload = {**ev.payload, "t": round(t, 6)}
        name = payload.get("clip") if ev.kind == "sound" else payload.get("audio")
        # none: a sound the robot plays by name, with no file to point at
        info = sounds.find(name) if isinstance(name, str) else None
        if info is not None:
            payload.update(sound=info.name, url=sound_url(info.name), duration=round(info.duration, 4))
        out.append(FrameEvent(ev.dof, ev.kind, payload))
    return out
