"""Nutty > Live link: puppeteer the running robot from Blender.

While the link is on, the rig's current pose (every control bone's angle and every DoF property, within
its limits) goes to the server as a `puppet` command over /ws/control whenever the frame changes or
something is posed, and at least every KEEPALIVE seconds while nothing changes, so the program's puppet
layer (docs/program-format.md) keeps it. The engine runs the pose through its stage 2 (motion filter,
safety limits) as any other layer. Stopping the link sends `release` (the layer fades out); if Blender
or the connection goes away, the server's watchdog fades it out by itself.
"""

from __future__ import annotations

import contextlib
import threading
import time
from typing import Any

import bpy

from . import rig
from .bake import bake_reasons, local_y_angle
from .client import Client, NuttyError

KEEPALIVE = 0.2  # s between messages while nothing changes (the puppet block's watchdog is 0.5 s)
FIRST_REPLY = 5.0  # s to wait for the server's answer to the first pose


class LiveLink:
    """The one live link of this Blender session (see the module doc)."""

    def __init__(self) -> None:
        self.ws: Any = None
        self.rig_name = ""
        self.plan: Any = None
        self.last: dict[str, Any] | None = None
        self.last_sent = 0.0
        self.sent = 0
        self.status = "off"
        self.server_error = ""  # the latest error the server answered (e.g. a DoF it refused)
        self.dropped = ""
        self._reader: threading.Thread | None = None
        self._stop = threading.Event()

    @property
    def running(self) -> bool:
        return self.ws is not None

    # --- the pose -------------------------------------------------------------------------------
    def pose(self) -> dict[str, Any]:
        """DoF -> target of the rig as the viewport shows it now (each control bone's evaluated angle about
        its joint axis, rad; the properties), within limits."""
        ob = bpy.data.objects.get(self.rig_name)
        if ob is None:
            raise NuttyError(f"the rig '{self.rig_name}' is gone")
        bones = {b.dof: b for b in self.plan.bones if b.dof}
        names = rig.control_bones(ob, self.plan)  # by the bones' DoF: a renamed bone keeps its DoF
        missing = [dof for dof in bones if dof not in names]
        if missing:
            raise NuttyError(
                f"'{ob.name}' has no bone for DoF{'s' if len(missing) > 1 else ''} {', '.join(missing)} "
                f"(deleted?): use Nutty > Load robot again"
            )
        # NLA, constraints, IK or other drivers: what the viewport shows, the evaluated pose (as Export
        # clip bakes it); else the bones' channels, as the exported keys give them to the engine
        evaluated = bool(bake_reasons(ob, rig.fcurves(ob)))
        ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()) if evaluated else ob
        out: dict[str, Any] = {}
        for dof, b in bones.items():
            pb = ev.pose.bones[names[dof]]
            v = round(local_y_angle(pb), 6) if evaluated else float(pb.rotation_euler[rig.DOF_INDEX])
            if b.limits is not None:
                v = min(max(v, b.limits[0]), b.limits[1])  # what Limit Rotation shows
            out[dof] = v
        for p in self.plan.props:
            value = ev.get(p.name, ob.get(p.name, p.default))
            if p.kind == "float":
                v = float(value)
                out[p.name] = min(
                    max(v, p.min if p.min is not None else v), p.max if p.max is not None else v
                )
            elif p.kind == "colour":
                out[p.name] = [min(max(float(c), 0.0), 1.0) for c in value]
            elif p.kind == "enum" and p.options:
                out[p.name] = p.options[min(max(int(value), 0), len(p.options) - 1)]
        return out

    def send_pose(self, force: bool = False) -> bool:
        """Send the pose if it changed or KEEPALIVE passed (or `force`); whether it was sent."""
        if not self.running:
            return False
        pose = self.pose()
        now = time.monotonic()
        if not force and pose == self.last and now - self.last_sent < KEEPALIVE:
            return False
        self.ws.send({"type": "puppet", "values": pose})
        self.last, self.last_sent = pose, now
        self.sent += 1
        return True

    # --- life cycle -----------------------------------------------------------------------------
    def start(self, client: Client, rig_ob: Any) -> None:
        if self.running:
            self.stop()
        self.plan = rig.plan_of(rig_ob)
        self.rig_name = rig_ob.name
        self.ws = client.websocket("/ws/control")
        self.server_error = self.dropped = ""
        self.sent, self.last = 0, None
        self._stop.clear()
        try:
            self._first_pose()
        except NuttyError:
            self.stop(release=False)
            raise
        for handlers in (bpy.app.handlers.frame_change_post, bpy.app.handlers.depsgraph_update_post):
            if _on_change not in handlers:
                handlers.append(_on_change)
        if not bpy.app.timers.is_registered(_tick):
            bpy.app.timers.register(_tick, first_interval=KEEPALIVE)
        self.status = f"live: {self.rig_name} -> {client.url}"

    def _first_pose(self) -> None:
        """Send the pose and wait for the server's answer, so a program that cannot be puppeteered (no
        puppet block) or a refused target is reported by the operator, not found out later."""
        pose = self.pose()
        self.ws.send({"type": "puppet", "id": "blender-live-link", "values": pose})
        deadline = time.monotonic() + FIRST_REPLY
        while time.monotonic() < deadline:
            msg = self.ws.receive(timeout=max(0.0, deadline - time.monotonic()))
            if (
                isinstance(msg, dict)
                and msg.get("id") == "blender-live-link"
                and msg.get("type") in ("ack", "error")
            ):
                if msg["type"] == "error":
                    raise NuttyError(f"the server refused the live link: {msg.get('message', 'error')}")
                break
        else:
            raise NuttyError(f"the server did not answer the live link within {FIRST_REPLY:g} s")
        self.last, self.last_sent = pose, time.monotonic()
        self.sent += 1
        self._reader = threading.Thread(target=self._read, name="nutty-live-link", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        """Acks and events are read (so the server never waits on this client) and dropped; errors kept."""
        ws = self.ws
        while not self._stop.is_set():
            try:
                msg = ws.receive(timeout=0.25)
            except NuttyError as exc:
                if not self._stop.is_set():
                    self.dropped = str(exc)
                return
            if isinstance(msg, dict) and msg.get("type") == "error":
                self.server_error = str(msg.get("message", "error"))

    def stop(self, release: bool = True) -> None:
        """End the link: `release` tells the server to fade the puppet layer out now."""
        for handlers in (bpy.app.handlers.frame_change_post, bpy.app.handlers.depsgraph_update_post):
            while _on_change in handlers:
                handlers.remove(_on_change)
        if bpy.app.timers.is_registered(_tick):
            bpy.app.timers.unregister(_tick)
        ws, self.ws = self.ws, None
        self._stop.set()
        if ws is not None:
            if release and not ws.closed:
                with contextlib.suppress(NuttyError):
                    ws.send({"type": "puppet", "release": True})
            ws.close()
        if self._reader is not None:
            self._reader.join(2.0)
            self._reader = None
        self.status = "off" if not self.dropped else f"dropped: {self.dropped}"

    def tick(self) -> float | None:
        """The timer: keep the pose alive, notice a dropped connection. Returns the next interval."""
        if not self.running:
            return None
        if self.dropped:
            self.stop(release=False)
            print(f"Nutty live link: {self.status}")
            return None
        try:
            self.send_pose()
        except NuttyError as exc:
            self.dropped = str(exc)
            self.stop(release=False)
            print(f"Nutty live link: {self.status}")
            return None
        return KEEPALIVE


LINK = LiveLink()


def _on_change(scene: Any, depsgraph: Any = None) -> None:
    """frame_change_post / depsgraph_update_post: send the pose if it changed."""
    if not LINK.running:
        return
    try:
        LINK.send_pose()
    except NuttyError as exc:
        LINK.dropped = str(exc)  # the timer stops the link (a handler must not unregister itself)


def _tick() -> float | None:
    return LINK.tick()
