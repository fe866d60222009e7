"""From a behaviour document to a plan: every item's start and end (s from the behaviour's start), its
clip anchors, and its fields with the parameters put in — or every error, each on its item and field.

An item's length is known before it plays: a clip's length over its speed (or up to its last anchor's
landing and the rest at its speed), a posture move's duration (the item's, else the program's posture
block's), a sound's or a recording's length, a spoken text's estimate (words over the say block's rate),
a look_at's, ramp's or wait's `duration`; LEDs, faces and the mood take no time. Items timed from
another's end start at that planned end. The plan is what the editor draws and what the engine plays.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import TypeAdapter, ValidationError

from backend.behaviours.format import MAX_ITEMS, MAX_TIME, Behaviour, Item, StartRef
from backend.behaviours.issues import BehaviourInvalid, Issue
from backend.behaviours.params import INSIDE, bind, check_declarations, references, substitute
from backend.behaviours.vocabulary import Vocabulary
from backend.engine.clips import ClipError, time_map
from backend.engine.embodiment import DofType

_ITEM = TypeAdapter(Item)


@dataclass
class PlannedItem:
    id: str
    track: int
    kind: str
    start: float  # s from the behaviour's start
    end: float
    spec: dict[str, Any]  # the item's fields, parameters put in
    anchors: dict[str, float] = field(default_factory=dict)  # clip anchor -> s from the behaviour's start
    follow: str | None = None  # look_at: the exposed input followed while the item lasts
    path: str = ""  # where the item is in the document (`tracks.1.items.0`)
    faulty: bool = False  # it has errors: items timed from it are not blamed for them again

    def to_dict(self) -> dict[str, Any]:
        out = {
            "id": self.id,
            "track": self.track,
            "kind": self.kind,
            "start": round(self.start, 6),
            "end": round(self.end, 6),
        }
        if self.anchors:
            out["anchors"] = {k: round(v, 6) for k, v in self.anchors.items()}
        if self.follow:
            out["follow"] = self.follow
        return out


@dataclass
class Plan:
    behaviour: Behaviour
    items: list[PlannedItem]  # in start order (ties: document order)
    params: dict[str, Any]

    @property
    def duration(self) -> float:
        return max((i.end for i in self.items), default=0.0)

    def to_dict(self) -> dict[str, Any]:
        return {
            "duration": round(self.duration, 6),
            "params": self.params,
            "items": [i.to_dict() for i in self.items],
        }


def parse(doc: Any) -> tuple[Behaviour | None, list[Issue]]:
    """The document as a Behaviour, or the format's errors, each on its item and field."""
    if not isinstance(doc, dict):
        return None, [Issue("a behaviour is a JSON object")]
    try:
        return Behaviour.model_validate(doc), []
    except ValidationError as exc:
        return None, _one_per_field([_located(doc, e) for e in exc.errors()])


def _located(doc: dict[str, Any], err: Any) -> Issue:
    loc = list(err["loc"])
    path = ".".join(str(p) for p in loc)
    message = err["msg"].removeprefix("Value error, ")
    if len(loc) >= 4 and loc[0] == "tracks" and loc[2] == "items" and isinstance(loc[3], int):
        t, i = int(loc[1]), loc[3]
        raw = _raw_item(doc, t, i)
        rest = [str(p) for p in loc[4:]]
        if rest and raw.get("kind") == rest[0]:
            rest = rest[1:]  # the union's tag
        rest = [p for p in rest if not _union_member(p)]
        item_id = raw.get("id") if isinstance(raw.get("id"), str) else f"#{i}"
        return Issue(message, path, track=t, item=item_id, field=".".join(rest) or None)
    return Issue(message, path, field=str(loc[-1]) if loc else None)


def _union_member(part: str) -> bool:
    """Whether a location part names a member of a union (`constrained-float`, `str`), not a field."""
    return "-" in part or "[" in part or part in ("float", "str", "int", "bool")


def _one_per_field(issues: list[Issue]) -> list[Issue]:
    """A value that fits no member of a union fails each: the first member's error (a number's range,
    not the `{param}` pattern's) says enough."""
    seen: set[tuple[Any, ...]] = set()
    out = []
    for i in issues:
        key = (i.track, i.item, i.field)
        if i.item is None or key not in seen:
            out.append(i)
        seen.add(key)
    return out


def _raw_item(doc: dict[str, Any], t: int, i: int) -> dict[str, Any]:
    try:
        raw = doc["tracks"][t]["items"][i]
    except (KeyError, IndexError, TypeError):
        return {}
    return raw if isinstance(raw, dict) else {}


def plan(beh: Behaviour, given: Any, vocab: Vocabulary, strict: bool = True) -> tuple[Plan, list[Issue]]:
    """The plan with the caller's parameters (`given`; None: the defaults). With `strict` False, a
    required parameter without a value is no error (its fields are left unchecked): checking a
    document for saving."""
    issues = check_declarations(beh)
    values, bound = bind(beh, given, vocab)
    if strict:
        issues += bound
    else:
        issues += [i for i in bound if "required" not in i.message]
    entries = beh.items()
    if len(entries) > MAX_ITEMS:
        issues.append(Issue(f"at most {MAX_ITEMS} items, got {len(entries)}", "tracks"))
    by_id: dict[str, tuple[int, int, Any]] = {}
    for t, i, item in entries:
        if item.id in by_id:
            issues.append(
                Issue(f"another item is '{item.id}' too", f"tracks.{t}.items.{i}.id", t, item.id, "id")
            )
        else:
            by_id[item.id] = (t, i, item)
    planned: dict[str, PlannedItem | None] = {}  # None: it cannot be timed (its errors are reported once)
    for _, _, item in entries:
        if by_id.get(item.id, (None, None, None))[2] is item:
            _plan_item(item.id, by_id, values, vocab, planned, issues, [], frozenset(beh.params))
    order = {id(item): k for k, (_, _, item) in enumerate(entries)}
    timed = [p for p in planned.values() if p is not None]
    items = sorted(timed, key=lambda p: (p.start, order[id(by_id[p.id][2])]))
    return Plan(beh, items, values), issues


def _plan_item(
    item_id: str,
    by_id: dict[str, tuple[int, int, Any]],
    values: dict[str, Any],
    vocab: Vocabulary,
    planned: dict[str, PlannedItem | None],
    issues: list[Issue],
    chain: list[str],
    declared: frozenset[str],
) -> PlannedItem | None:
    """Plan one item (after the item it is timed from); None when it cannot be timed."""
    if item_id in planned:
        return planned[item_id]
    t, i, item = by_id[item_id]
    where = f"tracks.{t}.items.{i}"
    if item_id in chain:
        cycle = " -> ".join([*chain[chain.index(item_id) :], item_id])
        issues.append(Issue(f"timing goes round in a circle: {cycle}", f"{where}.start", t, item_id, "start"))
        return None
    start = _start(item, where, t, by_id, values, vocab, planned, issues, [*chain, item_id], declared)
    if start is None:
        planned[item_id] = None
        return None
    spec = substitute(item.model_dump(mode="json", exclude_none=True), values)
    before = len(issues)
    length, anchors, follow = _extent(item, spec, declared, vocab, where, t, issues)
    if start + length > 2 * MAX_TIME:
        issues.append(Issue("the item ends too late", f"{where}.start", t, item_id, "start"))
    anchors = {k: start + v for k, v in anchors.items()}
    p = PlannedItem(
        item_id, t, item.kind, start, start + length, spec, anchors, follow, where, len(issues) > before
    )
    planned[item_id] = p
    return p


def _start(item, where, t, by_id, values, vocab, planned, issues, chain, declared) -> float | None:
    ref = item.start
    if not isinstance(ref, StartRef):
        return float(ref)
    field = f"{where}.start"
    if ref.item not in by_id:
        issues.append(
            Issue(f"no item '{ref.item}' to be timed from", f"{field}.item", t, item.id, "start.item")
        )
        return None
    base = _plan_item(ref.item, by_id, values, vocab, planned, issues, chain, declared)
    if base is None:
        return None
    if base.faulty and ref.at != "start":
        return None  # its end or anchors are not known: its own errors say why
    if ref.at == "start":
        moment = base.start
    elif ref.at == "end":
        moment = base.end
    elif ref.anchor in base.anchors:
        moment = base.anchors[ref.anchor]
    else:
        have = sorted(base.anchors) or "none"
        what = "a clip" if base.kind == "play_clip" else f"a {base.kind}, not a clip"
        issues.append(
            Issue(
                f"'{ref.item}' ({what}) has no anchor '{ref.anchor}' (anchors: {have})",
                f"{field}.anchor",
                t,
                item.id,
                "start.anchor",
            )
        )
        return None
    start = moment + ref.offset
    if start < -1e-9:
        issues.append(
            Issue(
                f"starts {-start:.3f} s before the behaviour does",
                f"{field}.offset",
                t,
                item.id,
                "start.offset",
            )
        )
        return None
    return max(0.0, start)


def _extent(
    item, spec, declared, vocab: Vocabulary, where, t, issues
) -> tuple[float, dict[str, float], str | None]:
    """(length in s, anchor -> s after the item's start, followed input) of one item; its field errors."""

    def bad(message: str, name: str) -> None:
        issues.append(Issue(message, f"{where}.{name}", t, item.id, name))

    pending = {k for k, v in spec.items() if references(v)}  # names of parameters without a value
    if not pending:
        try:
            _ITEM.validate_python(spec)
        except ValidationError as exc:
            for e in exc.errors():
                bad(e["msg"].removeprefix("Value error, "), str(e["loc"][1]) if len(e["loc"]) > 1 else "kind")
            return 0.0, {}, None
    kind = item.kind
    if kind == "play_clip":
        return _clip_extent(spec, vocab, bad) if "clip" not in pending else (0.0, {}, None)
    if kind == "go_posture":
        if "posture" not in pending and not vocab.has_posture(spec["posture"]):
            bad(f"no posture '{spec['posture']}'", "posture")
        return _seconds(spec.get("duration"), vocab.posture_seconds), {}, None
    if kind == "look_at":
        target, follow = spec["target"], None
        if isinstance(target, str) and "target" not in pending:
            follow = target
            if vocab.inputs is not None and (
                target not in vocab.inputs or vocab.inputs[target].type != "vec3"
            ):
                bad(f"'{target}' is no exposed vec3 input of the running program", "target")
        return _seconds(spec["duration"], 0.0), {}, follow
    if kind == "say":
        unknown = [n for n in INSIDE.findall(spec["text"]) if n not in declared]
        if unknown and not pending:
            bad(f"the text names {{{unknown[0]}}}, which is no parameter", "text")
        if spec.get("audio"):
            seconds = vocab.sound_seconds(spec["audio"])
            if seconds is None:
                bad(f"no sound '{spec['audio']}' (sounds: {vocab.sounds})", "audio")
                return 0.0, {}, None
            return seconds, {}, None
        return vocab.say_seconds(spec["text"]), {}, None
    if kind == "play_sound":
        seconds = vocab.sound_seconds(spec["sound"]) if "sound" not in pending else 0.0
        if seconds is None:
            bad(f"no sound '{spec['sound']}' (sounds: {vocab.sounds})", "sound")
        return seconds or 0.0, {}, None
    if kind in ("set_led", "set_face"):
        _display(kind, spec, pending, vocab, bad)
        return 0.0, {}, None
    if kind == "ramp":
        _ramp(spec, pending, vocab, bad)
    return _seconds(spec.get("duration"), 0.0), {}, None


def _seconds(value: Any, default: float) -> float:
    """A number field's value, or `default` when it is unset or names a parameter without a value."""
    return float(value) if isinstance(value, (int, float)) and value else default


def _clip_extent(spec, vocab: Vocabulary, bad) -> tuple[float, dict[str, float], None]:
    facts = vocab.clip(spec["clip"])
    if facts is None:
        bad(f"no clip '{spec['clip']}'", "clip")
        return 0.0, {}, None
    speed = _seconds(spec.get("speed"), 1.0)
    targets = spec.get("anchors") or {}
    try:
        play, clip_t = time_map(facts.length, speed, facts.anchors, targets)
    except ClipError as exc:
        bad(str(exc), "anchors")
        return facts.length / speed, {}, None
    anchors = {name: float(np.interp(ct, clip_t, play)) for name, ct in facts.anchors.items()}
    anchors.update({name: float(v) for name, v in targets.items()})
    return float(play[-1]), anchors, None


def _display(kind: str, spec, pending, vocab: Vocabulary, bad) -> None:
    emb = vocab.embodiment
    want = DofType.colour if kind == "set_led" else DofType.enum
    name = spec.get("dof")
    if name is None:
        dof = next((d for d in emb.dofs if d.type is want), None)
        if dof is None:
            bad(f"robot '{emb.name}' has no {want.value} DoF", "kind")
            return
    elif not emb.has_dof(name) or emb.dof(name).type is not want:
        options = [d.name for d in emb.dofs if d.type is want]
        bad(f"'{name}' is no {want.value} DoF of the robot (those: {options})", "dof")
        return
    else:
        dof = emb.dof(name)
    if kind == "set_face" and "expression" not in pending and spec["expression"] not in (dof.options or ()):
        bad(
            f"'{dof.name}' has no expression '{spec['expression']}' (options: {list(dof.options or ())})",
            "expression",
        )


def _ramp(spec, pending, vocab: Vocabulary, bad) -> None:
    inputs = vocab.inputs
    if inputs is None:
        return
    decl = inputs.get(spec["input"])
    if decl is None:
        bad(f"the running program has no exposed input '{spec['input']}' (inputs: {sorted(inputs)})", "input")
        return
    if "to" in pending:
        return
    to = spec["to"]
    if decl.type in ("float", "int") and not isinstance(to, (int, float)):
        bad(f"'{decl.name}' is a number: `to` must be one", "to")
    elif decl.type in ("vec3", "colour") and not isinstance(to, list):
        bad(f"'{decl.name}' is a {decl.type}: `to` is [x, y, z]", "to")
    elif decl.type not in ("float", "int", "vec3", "colour"):
        bad(f"'{decl.name}' is a {decl.type}: only numbers and vec3 inputs ramp", "input")


def plan_or_raise(doc: Any, given: Any, vocab: Vocabulary) -> Plan:
    """The plan of a document, or BehaviourInvalid with every error."""
    beh, issues = parse(doc)
    if beh is None:
        raise BehaviourInvalid(issues)
    result, issues = plan(beh, given, vocab)
    if issues:
        raise BehaviourInvalid(issues)
    return result
