"""Playing behaviours on the engine's clock: each item becomes its command at its tick.

One behaviour plays at a time (`if_busy` of play_behaviour decides about the next: replace, queue or
reject). The player is an Engine tick hook: at the start of the tick whose frame is at or after an
item's start it runs the item's command (backend.behaviours.items) under the command id
`<behaviour id>:<item id>`, so the program's blocks carry it out and report its end; ramps and
followed look_ats are updated every tick by the player itself. Its notes, under the behaviour's id:

- `started` when the first tick runs, then exactly one of `completed` (every item ended and the
  plan's time is over), `cancelled` (cancel, stop_all, reset, replaced) or `failed` (an item's command
  was refused; what the behaviour started is stopped); the terminal event names the behaviour;
- `item` per item as it starts and ends: {"item", "kind", "state": started|completed|cancelled|failed,
  "t": s since the behaviour started}.

Cancelling stops what the behaviour started and has not finished: clips fade out (the item's
`fade_out`, else the player's release), speech and sounds stop, posture moves stop, ramps stop where
they are, a followed gaze stops following, LEDs and faces it set as engine overrides are released.
Everything it does goes through the program's layers and the safety net like any command.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import uuid
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from backend.behaviours.items import REPORTED, command_for
from backend.behaviours.plan import Plan, PlannedItem
from backend.engine.tick_hooks import IDLE

log = logging.getLogger(__name__)
NODE = "behaviour"  # the `node` of the player's notes
#: s after an item's planned end that the player waits for its block's report before it moves on
#: (a program swapped meanwhile has other blocks, which will never report it)
REPORT_GRACE = 2.0
EPS = 1e-9


@dataclass
class _Item:
    plan: PlannedItem
    sub: str  # the command id of the item's command
    state: str = "waiting"  # waiting, started, completed, cancelled, failed
    origin: Any = None  # a ramp's value at its start
    reported: bool = False  # its block reports its end (else it ends at its planned end)


@dataclass
class _Run:
    cid: str
    plan: Plan
    name: str
    items: list[_Item]
    t0: float | None = None  # engine time of its first frame
    channels: set[int] = field(default_factory=set)  # continuous channels its items move

    @property
    def open(self) -> list[_Item]:
        return [i for i in self.items if i.state in ("waiting", "started")]


class BehaviourPlayer:
    """See the module doc. `play`, `cancel` and `stop_all` may be called from any thread."""

    def __init__(self, session: Any):
        self.session = session
        self.current: _Run | None = None
        self.queue: list[_Run] = []
        self._subs: dict[str, tuple[_Run, _Item]] = {}
        self._lock = threading.Lock()  # guards `_subs` (read by `owns` from the event path)
        session.engine.add_tick_hook(self._tick)
        session.on_note(self._on_note)

    # --- requests (any thread; carried out at a tick boundary) -------------------------------------
    def play(self, plan: Plan, cid: str | None, name: str, if_busy: str = "replace") -> dict[str, Any]:
        """Start (or queue) a behaviour; returns the command's result. BusyError for `reject` while one plays."""
        cid = cid or uuid.uuid4().hex[:12]
        run = _Run(cid, plan, name, [_Item(p, f"{cid}:{p.id}") for p in plan.items])
        run.channels = _channels(self.session, plan)
        return self.session.engine.call(lambda: self._play(run, if_busy))

    def _play(self, run: _Run, if_busy: str) -> dict[str, Any]:
        busy = self.current is not None or bool(self.queue)
        if busy and if_busy == "reject":
            playing = self.current or self.queue[-1]
            raise BusyError(
                f"behaviour '{playing.name}' is playing (command id '{playing.cid}')", playing.cid
            )
        if busy and if_busy == "replace":
            self._stop_everything("replaced")
        with self._lock:
            self._subs.update({i.sub: (run, i) for i in run.items})
        self.queue.append(run)
        self.session.engine.wake_tick_hook(self._tick)
        out = {"behaviour": run.name, "duration": round(run.plan.duration, 4), "items": len(run.items)}
        return {**out, "queued": True} if self.current is not None else out

    def cancel(self, cid: str) -> bool:
        """Cancel the behaviour `cid` (playing or queued); False when it is not here."""
        return bool(self.session.engine.call(lambda: self._cancel(cid, "cancelled")))

    def stop_all(self) -> None:
        self.session.engine.call(lambda: self._stop_everything("stopped"))

    def owns(self, cid: Any) -> bool:
        """Whether `cid` is the command id of one of the player's item commands (their events are the
        behaviour's item events, not commands of their own)."""
        with self._lock:
            return isinstance(cid, str) and cid in self._subs

    # --- the clock thread ------------------------------------------------------------------------------
    def _tick(self, t: float) -> Any:
        if self.current is None:
            if not self.queue:
                return IDLE  # not called again until a behaviour is queued (`_play` wakes it)
            self.current = self.queue.pop(0)
            self.current.t0 = t
            self._note(
                self.current,
                "started",
                behaviour=self.current.name,
                duration=round(self.current.plan.duration, 4),
            )
        run = self.current
        now = t - (run.t0 if run.t0 is not None else t)
        for item in run.items:
            p = item.plan
            if item.state == "waiting" and p.start <= now + EPS:
                self._start(run, item, now)
                if self.current is not run:  # it failed
                    return
            if item.state == "started":
                self._advance(run, item, now)
        if not run.open and now >= run.plan.duration - EPS:
            self._finish(run, "completed", _channels=sorted(run.channels))

    def _start(self, run: _Run, item: _Item, now: float) -> None:
        from backend import control  # the commands: the player is made by the session, which they import

        p = item.plan
        item.state = "started"
        item.origin = self._input(p.spec["input"]) if p.kind == "ramp" else None
        target = self._input(p.follow) if p.follow else None
        spec = command_for(p, target)
        result: Any = None
        if spec is not None:
            try:
                result = control.execute(self.session, control.parse_command(spec), item.sub)
            except (ValueError, TypeError, KeyError) as exc:  # CommandError, a block's refusal
                item.state = "failed"
                self._item_note(run, item, "failed", now, error=str(exc))
                self._abort(run, "failed", error=f"item '{p.id}' ({p.kind}): {exc}", item=p.id)
                return
        item.reported = p.kind in REPORTED and not (isinstance(result, dict) and result.get("done"))
        self._item_note(run, item, "started", now)

    def _advance(self, run: _Run, item: _Item, now: float) -> None:
        """A started item's time goes on: ramps move, followed gazes follow, timed items end."""
        p = item.plan
        if p.kind == "ramp":
            self._ramp(p, item.origin, now)
        elif p.follow and now < p.end - EPS:
            value = self._input(p.follow)
            if value is not None:
                with contextlib.suppress(ValueError, TypeError):
                    self._set_inputs({"gaze_target": list(value)})
        if item.reported:  # its block reports its end (see _on_note), or it is lost
            if now >= p.end + REPORT_GRACE + 0.2 * (p.end - p.start):
                item.state = "completed"
                self._item_note(run, item, "completed", now, unconfirmed=True)
        elif now >= p.end - EPS:
            if p.kind == "ramp":
                self._ramp(p, item.origin, p.end)
            item.state = "completed"
            self._item_note(run, item, "completed", now)

    def _ramp(self, p: PlannedItem, origin: Any, now: float) -> None:
        span = max(p.end - p.start, EPS)
        u = min(1.0, max(0.0, (now - p.start) / span))
        if p.spec.get("easing", "smooth") == "smooth":
            u = u * u * (3.0 - 2.0 * u)
        to = np.asarray(p.spec["to"], dtype=float)
        start = np.asarray(origin if origin is not None else to, dtype=float)
        value = start + (to - start) * u
        with contextlib.suppress(ValueError, TypeError):  # an input of another shape: the ramp holds
            self._set_inputs({p.spec["input"]: value.tolist() if value.ndim else float(value)})

    def _on_note(self, note: dict[str, Any]) -> None:
        """A block's report on an item's command (clock thread): the item ends with it."""
        cid = note.get("command_id")
        with self._lock:
            found = self._subs.get(cid) if isinstance(cid, str) else None
        if found is None:
            return
        run, item = found
        event = note.get("event")
        if event == "completed" and not item.reported:
            return  # a look_at's gaze arriving: the item lasts its duration all the same
        if event in ("completed", "cancelled", "failed") and item.state == "started":
            item.state = event
            now = self.session.engine.t - (run.t0 or 0.0)
            self._item_note(run, item, event, now)

    # --- ending ------------------------------------------------------------------------------------------
    def _cancel(self, cid: str, reason: str) -> bool:
        if self.current is not None and self.current.cid == cid:
            self._abort(self.current, "cancelled", reason=reason)
            return True
        for run in self.queue:
            if run.cid == cid:
                self.queue.remove(run)
                self._finish(run, "cancelled", reason=reason)
                return True
        return False

    def _stop_everything(self, reason: str) -> None:
        for run in list(self.queue):
            self.queue.remove(run)
            self._finish(run, "cancelled", reason=reason)
        if self.current is not None:
            self._abort(self.current, "cancelled", reason=reason)

    def _abort(self, run: _Run, event: str, **details: Any) -> None:
        """Stop what `run` started and has not finished, then end it with `event`."""
        from backend import control  # as in _start

        now = self.session.engine.t - (run.t0 or 0.0)
        for item in run.items:
            if item.state != "started":
                continue
            p = item.plan
            with contextlib.suppress(Exception):  # a block that cannot stop: the item is cancelled regardless
                if p.kind == "play_clip":
                    self._fade_clip(item)
                elif p.kind in ("say", "play_sound", "go_posture", "look_at"):
                    command = command_for(p, [1.0, 0.0, 0.0]) or {}
                    control.cancel_command(self.session, command.get("type"), item.sub)
            item.state = "cancelled"
            self._item_note(run, item, "cancelled", now)
        self._release_overrides(run)
        self._finish(run, event, **details)

    def _fade_clip(self, item: _Item) -> None:
        from backend.control.targets import blocks_of  # as in _start

        fade = item.plan.spec.get("fade_out")
        for block in blocks_of(self.session, ("clip_player",)):
            block.handle("stop", {"command_id": item.sub, **({"fade": fade} if fade is not None else {})})

    def _release_overrides(self, run: _Run) -> None:
        """LEDs and faces the behaviour set as engine overrides go back to the program."""
        from backend.control.targets import blocks_of  # as in _start

        emb = self.session.embodiment
        mask = np.zeros(emb.n_channels, dtype=bool)
        for item in run.items:
            p = item.plan
            if p.kind not in ("set_led", "set_face") or item.state == "waiting":
                continue
            want = "colour" if p.kind == "set_led" else "enum"
            dof = (
                emb.dof(p.spec["dof"])
                if p.spec.get("dof")
                else next(d for d in emb.dofs if d.type.value == want)
            )
            blocks = blocks_of(self.session, ("led",) if p.kind == "set_led" else ("face",))
            if any(getattr(getattr(b, "dof", None), "name", None) == dof.name for b in blocks):
                continue  # the program's own block showed it: nothing is held on top of the program
            mask[dof.channels] = True
        if mask.any():
            self.session.engine.release_override(mask)

    def _finish(self, run: _Run, event: str, **details: Any) -> None:
        if self.current is run:
            self.current = None
        with self._lock:
            for item in run.items:
                self._subs.pop(item.sub, None)
        self._note(run, event, behaviour=run.name, **details)

    # --- helpers -----------------------------------------------------------------------------------------
    def _note(self, run: _Run, event: str, **data: Any) -> None:
        # as a block's notify, with item fields of the player's own (`kind` is the item's)
        self.session.engine.ctx.events.append({"node": NODE, "event": event, "command_id": run.cid, **data})

    def _item_note(self, run: _Run, item: _Item, state: str, now: float, **data: Any) -> None:
        p = item.plan
        self._note(run, "item", item=p.id, kind=p.kind, state=state, t=round(max(0.0, now), 4), **data)

    def _input(self, name: str) -> Any:
        return self.session.engine.ctx.inputs.get(name)

    def _set_inputs(self, values: dict[str, Any]) -> None:
        from backend.control.targets import set_inputs  # as in _start

        set_inputs(self.session, values)


class BusyError(ValueError):
    """A behaviour plays and the new one said `if_busy: reject`."""

    def __init__(self, message: str, playing: str):
        super().__init__(message)
        self.playing = playing


def _channels(session: Any, plan: Plan) -> set[int]:
    """The continuous channels a plan's motion items move (the behaviour's completion waits until
    the robot's motion on them has settled)."""
    emb = session.embodiment
    names: set[str] = set()
    for p in plan.items:
        if p.kind == "play_clip":
            with contextlib.suppress(ValueError):
                names |= set(session.library.get("clips", p.spec["clip"]).get("tracks", {}))
        elif p.kind == "go_posture":
            with contextlib.suppress(ValueError):
                names |= set(session.library.get("postures", p.spec["posture"]).get("values", {}))
        elif p.kind == "look_at":
            gaze = emb.gaze or {}
            names |= set(gaze.get("yaw_joints", ())) | set(gaze.get("pitch_joints", ()))
    out: set[int] = set()
    for name in names:
        if emb.has_dof(name):
            sl = emb.dof(name).channels
            out |= {c for c in range(sl.start, sl.stop) if emb.continuous_mask[c]}
    return out
