"""What the running robot, program and library offer right now: the closed vocabulary tools are made of.

A `Live` snapshot is read once per tool build: the robot's clips and postures (each with its one-line
description, a clip with its duration), the program's exposed inputs, which blocks it has and on which
mixer layers, the display DoFs, the sound and speech channels and the gaze's reachable range. Reading
it changes nothing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from backend.control.ai import Choice
from backend.control.behaviours import behaviour_choices

# A command's tool declaration lists its values as Choices, so the class lives beside the declaration.
from backend.control.session_view import CommandSession
from backend.control.targets import layer_members, layers_of, mixers
from backend.engine.clips import Clip
from backend.engine.embodiment import DofType, Embodiment

__all__ = ["Choice", "Live", "read_live"]


@dataclass
class Live:
    """The running robot, program and library, as tools see them (see `read_live`)."""

    robot: str
    program: str | None
    clips: list[Choice] = field(default_factory=list)
    postures: list[Choice] = field(default_factory=list)
    inputs: list[Any] = field(default_factory=list)  # the program's ExposedInput declarations
    blocks: dict[str, list[str]] = field(default_factory=dict)  # block type -> node ids
    block_layers: dict[str, list[str]] = field(default_factory=dict)  # block type -> layers holding one
    layers: list[Choice] = field(default_factory=list)  # every mixer layer (name, mode)
    mixers: list[str] = field(default_factory=list)
    colour_dofs: list[Choice] = field(default_factory=list)
    enum_dofs: list[Choice] = field(default_factory=list)
    expressions: list[Choice] = field(default_factory=list)  # options of the enum DoFs
    sounds: list[Choice] = field(default_factory=list)
    channels: set[str] = field(default_factory=set)  # event DoF kinds: speech, sound
    gaze_range: dict[str, tuple[float, float]] = field(default_factory=dict)  # yaw/pitch -> (min, max) rad
    behaviours: list[Choice] = field(default_factory=list)
    behaviour_params: dict[str, dict[str, Any]] = field(default_factory=dict)  # name -> declared params

    def has(self, *block_types: str) -> bool:
        return any(self.blocks.get(t) for t in block_types)

    def input(self, name: str) -> Any:
        return next((i for i in self.inputs if i.name == name), None)


def read_live(session: CommandSession) -> Live:
    """The snapshot of `session` (an EngineSession) that tools are generated from."""
    emb = session.embodiment
    program = session.program
    live = Live(
        robot=emb.name,
        program=program.name if program is not None else None,
        clips=_clips(session),
        postures=_postures(session),
        inputs=list(program.inputs) if program is not None else [],
    )
    apu = session.engine.apu
    members = layer_members(session)
    for step in apu.steps if apu is not None else []:
        block = step.block
        live.blocks.setdefault(block.type_name, []).append(block.node_id)
        for name in layers_of(session, block.node_id, members):
            if name not in live.block_layers.setdefault(block.type_name, []):
                live.block_layers[block.type_name].append(name)
    for mixer in mixers(session):
        live.mixers.append(mixer.node_id)
        live.layers += [
            Choice(s["name"], f"{s['mode']} layer of mixer '{mixer.node_id}'") for s in mixer.layer_states()
        ]
    for dof in emb.dofs:
        if dof.type is DofType.colour:
            live.colour_dofs.append(Choice(dof.name, dof.description))
        elif dof.type is DofType.enum:
            live.enum_dofs.append(Choice(dof.name, dof.description))
            live.expressions += [
                Choice(o, f"on '{dof.name}'")
                for o in dof.options or ()
                if o not in {c.name for c in live.expressions}
            ]
    for dof in emb.event_dofs:
        if dof.kind is not None:
            live.channels.add(dof.kind)
        if dof.kind == "sound":
            live.sounds += [Choice(s) for s in dof.sounds or ()]
    live.gaze_range = _gaze_range(emb)
    live.behaviours, live.behaviour_params = behaviour_choices(session)
    return live


def _clips(session: CommandSession) -> list[Choice]:

    out = []
    for name in _names(session, "clips"):
        try:
            clip = Clip.model_validate(session.library.get("clips", name))
        except ValueError:  # a broken file cannot be played: it is not offered
            continue
        out.append(Choice(name, " ".join(clip.description.split()), round(clip.length, 3)))
    return out


def _postures(session: CommandSession) -> list[Choice]:
    out = []
    for name in _names(session, "postures"):
        try:
            doc = session.library.get("postures", name)
        except ValueError:
            continue
        out.append(Choice(name, " ".join(str(doc.get("description", "")).split())))
    return out


def _names(session: CommandSession, kind: str) -> list[str]:
    try:
        return session.library.list(kind)
    except ValueError:  # a robot without a library folder
        return []


def _gaze_range(emb: Embodiment) -> dict[str, tuple[float, float]]:
    """Yaw and pitch (rad) the gaze joints can turn through together: the sums of their limits."""
    out = {}
    for axis in ("yaw", "pitch"):
        names = [n for n in emb.gaze.get(f"{axis}_joints", ()) if emb.has_dof(n)]
        if names:
            dofs = [emb.dof(n) for n in names]
            out[axis] = (round(sum(d.min for d in dofs), 3), round(sum(d.max for d in dofs), 3))
    return out
