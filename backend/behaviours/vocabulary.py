"""What a behaviour may name on one robot and program: clips (their lengths and anchors), postures,
sounds (their lengths), DoFs, exposed inputs, and the defaults that decide how long an item lasts.

Read from a session (`vocabulary_of`) for checking, planning and playing; tests build one directly.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from backend.engine.clips import Clip
from backend.engine.embodiment import Embodiment

#: seconds a posture move takes when neither the item nor the program's posture block says
POSTURE_SECONDS = 1.0
WORDS_PER_SECOND = 2.5  # the say block's defaults: the estimated length of a spoken text
MIN_SAY_SECONDS = 0.4
SOUND_SECONDS = 1.0  # a sound the robot plays by name, with no file to measure


@dataclass
class ClipFacts:
    length: float  # s, at speed 1
    anchors: dict[str, float]  # anchor -> clip time (s)


@dataclass
class Vocabulary:
    """See the module doc. `inputs` None: the program is not known (exposed inputs are not checked)."""

    embodiment: Embodiment
    clip: Callable[[str], ClipFacts | None]
    has_posture: Callable[[str], bool]
    sound_seconds: Callable[[str], float | None]  # a file's length; None: no such sound
    inputs: dict[str, Any] | None = None  # exposed input name -> declaration (type, min, max)
    posture_seconds: float = POSTURE_SECONDS
    words_per_second: float = WORDS_PER_SECOND
    min_say_seconds: float = MIN_SAY_SECONDS
    sounds: list[str] = field(default_factory=list)  # the sound DoF's list

    def say_seconds(self, text: str) -> float:
        return max(self.min_say_seconds, len(text.split()) / self.words_per_second)


def vocabulary_of(session: Any) -> Vocabulary:
    """The vocabulary of an EngineSession: its robot's library and the program it runs."""
    emb, library = session.embodiment, session.library
    sound_dof = next((d for d in emb.event_dofs if d.kind == "sound"), None)
    names = list(sound_dof.sounds) if sound_dof is not None else []

    def clip(name: str) -> ClipFacts | None:
        try:
            doc = Clip.model_validate(library.get("clips", name))
        except ValueError:
            return None
        return ClipFacts(doc.length, dict(doc.anchors))

    def has_posture(name: str) -> bool:
        try:
            return library.exists("postures", name)
        except ValueError:
            return False

    def sound_seconds(name: str) -> float | None:
        info = library.sounds.find(name)
        if info is not None:
            return info.duration
        return SOUND_SECONDS if name in names else None

    program = session.program
    vocab = Vocabulary(
        emb,
        clip,
        has_posture,
        sound_seconds,
        inputs={i.name: i for i in program.inputs} if program is not None else None,
        sounds=names,
    )
    _program_defaults(session, vocab)
    return vocab


def _program_defaults(session: Any, vocab: Vocabulary) -> None:
    """The running program's own posture duration and speaking rate, where it has those blocks."""
    apu = session.engine.apu
    for step in apu.steps if apu is not None else []:
        params = step.block.params
        if step.block.type_name == "posture":
            vocab.posture_seconds = float(params.duration)
        elif step.block.type_name == "say":
            vocab.words_per_second = float(params.words_per_second)
            vocab.min_say_seconds = float(params.min_duration)
