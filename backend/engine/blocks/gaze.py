"""The gaze block: turns head and body toward a 3D target, head first, with arcs."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import Field

from backend.engine.blocks import gaze_reach
from backend.engine.blocks.base import (
    FRAME_OUT,
    BlockParams,
    Port,
    PortType,
    Source,
    drivable,
    soft_range,
)
from backend.engine.blocks.cells import cell
from backend.engine.blocks.gaze_reach import yaw_pitch
from backend.engine.compiled import entry_point
from backend.engine.compiled.chain import GAZE_SIG, chain_args, gaze_constants, gaze_tick, gaze_workspace
from backend.engine.embodiment import Dimension, DofType
from backend.engine.frames import PartialFrame
from backend.engine.kinematics import chain_for, joint_depths

ARC_SMOOTHING = 0.08  # s, first-order smoothing of the arc dip (no jumps when a turn starts or stops)
_GAIN_STEP = 1e-4  # rad, finite-difference step for each DoF's effect on the gaze direction


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class GazeParams(BlockParams):
    target: list[float] = drivable(
        Field(
            default=[1.0, 0.0, 0.3],
            min_length=3,
            max_length=3,
            description="point to look at (m, robot base frame); used when `target` is unconnected",
        ),
        "point to look at (m, robot base frame); overrides the target parameter",
        port=PortType.vec3,
    )
    yaw_dofs: list[str] | None = Field(
        default=None,
        description="DoFs that turn the gaze left/right, leader first (default: the robot's gaze.yaw_joints, "
        "most distal first)",
        json_schema_extra={"x-widget": "dofs"},
    )
    pitch_dofs: list[str] | None = Field(
        default=None,
        description="DoFs that turn the gaze down/up, leader first (default: the robot's gaze.pitch_joints, "
        "most distal first)",
        json_schema_extra={"x-widget": "dofs"},
    )
    weights: dict[str, float] = Field(
        default_factory=dict,
        description="DoF name -> share of its axis once settled (normalised per axis; unlisted DoFs take 1)",
    )
    eye_link: str | None = Field(
        default=None, description="URDF link of the eyes (default: the robot's gaze.eye_link)"
    )
    eye_offset: list[float] | None = Field(
        default=None,
        min_length=3,
        max_length=3,
        description="eye point in the eye link's frame (m; default: gaze.eye_offset)",
    )
    follow_lag: float = Field(
        default=0.25,
        ge=0.0,
        le=5.0,
        description="first-order time constant added per follower stage (s): the 2nd DoF of "
        "an axis lags by this, the 3rd by twice this, …",
        json_schema_extra=soft_range(0, 2, 0.01),
    )
    max_speed: float = Field(
        default=3.0,
        gt=0.0,
        le=20.0,
        description="speed cap for every gaze DoF (rad/s)",
        json_schema_extra=soft_range(0, 8, 0.05),
    )
    speed_fraction: float = Field(
        default=0.8, gt=0.0, le=1.0, description="fraction of each DoF's velocity limit allowed (0..1]"
    )
    arc_dip: float = Field(
        default=0.05,
        ge=0.0,
        le=1.0,
        description="pitch dip (rad, + = down) per rad/s of yaw speed: turns follow an arc",
    )
    arc_max: float = Field(default=0.08, ge=0.0, le=0.5, description="largest arc dip (rad)")
    strength: float = drivable(
        Field(default=1.0, ge=0.0, le=1.0, description="0 = rest pose, 1 = full gaze (blend, 0..1)"),
        "overrides the strength parameter (0..1)",
        clamp="range",
    )
    tolerance: float = Field(
        default=0.05, gt=0.0, le=1.0, description="`on_target` when the gaze is within this angle (rad)"
    )


class Gaze(Source[GazeParams]):
    """Looks at a 3D target: head leads, body follows, turns follow an arc.

    Each tick the block computes, from the eye point (the robot's gaze eye link and offset, posed by forward
    kinematics at the gaze's current pose, other joints at rest), the yaw and pitch still needed to face
    the target, and spreads them over the yaw and pitch DoFs by their `weights`. Intention: the first DoF of
    each axis (the eyes/head) turns at once and carries the whole gaze; each later DoF (neck, body) follows
    its share with an extra first-order lag of `follow_lag` per stage while the leader gives the difference
    back, so the gaze reaches the target fast and the body settles under it. Arcs: while the gaze turns,
    the pitch DoFs dip by `arc_dip` per rad/s of yaw speed (at most `arc_max`). Every DoF stays in its
    position limits and below `max_speed` and `speed_fraction` of its velocity limit; `strength` blends
    from the rest pose (0) to the full gaze (1). Output: rest + gaze angles on the gaze DoFs only.
    """

    type_name = "gaze"
    title = "Gaze / look-at"
    outputs = {
        **FRAME_OUT,
        "on_target": Port(PortType.bool, "the gaze points at the target (within tolerance)"),
    }

    @dataclass
    class State:
        x: np.ndarray  # each gaze DoF's angle from rest, without the arc dip (rad)
        # the smoothed arc dip (rad) in a one-element array: the compiled core steps it in place
        dip_cell: np.ndarray = field(default_factory=lambda: np.zeros(1))
        # the ticks in a row a look_at in progress has seen the gaze stand still, counted in place likewise
        still_cell: np.ndarray = field(default_factory=lambda: np.zeros(1))

        dip = cell("dip_cell", 0, "The smoothed arc dip (rad).")
        still = cell("still_cell", 0, "Ticks in a row the gaze stood still during a look_at (GazeWatch).")

    # --- configuration ----------------------------------------------------------------------------
    def configure(self) -> None:
        emb, p = self.emb, self.params
        cfg = emb.gaze or {}
        eye_link = p.eye_link or cfg.get("eye_link")
        if not eye_link:
            raise ValueError(f"robot '{emb.name}' has no gaze.eye_link: set the eye_link parameter")
        self.eye_offset = np.asarray(
            p.eye_offset if p.eye_offset is not None else cfg.get("eye_offset", [0, 0, 0]), dtype=float
        )
        self.chain = chain_for(emb, None, eye_link)
        yaw = self._dofs(p.yaw_dofs, cfg.get("yaw_joints"), "yaw")
        pitch = self._dofs(p.pitch_dofs, cfg.get("pitch_joints"), "pitch")
        both = set(yaw) & set(pitch)
        if both:
            raise ValueError(f"DoFs {sorted(both)} are both yaw and pitch DoFs")
        names = yaw + pitch
        unknown = sorted(set(p.weights) - set(names))
        if unknown:
            raise ValueError(f"weights name DoFs that are not gaze DoFs: {unknown}")
        n = len(names)
        self.names = names
        self.idx = np.array([emb.dof(d).channels.start for d in names], dtype=np.intp)
        self.axis = np.array([0] * len(yaw) + [1] * len(pitch), dtype=np.intp)
        self.stage = np.array(list(range(len(yaw))) + list(range(len(pitch))), dtype=float)
        self.leader = self.stage == 0
        self.has_axis = np.array([len(yaw) > 0, len(pitch) > 0])
        w = np.array([max(float(p.weights.get(d, 1.0)), 0.0) for d in names])
        total = np.bincount(self.axis, weights=w, minlength=2)
        if np.any((total <= 0) & self.has_axis):
            raise ValueError("the weights of an axis must not all be 0")
        self.share = w / np.where(total > 0, total, 1.0)[self.axis]
        self.tau = self.stage * p.follow_lag
        self.follow_share = np.where(self.leader, 0.0, self.share)
        follow_total = np.bincount(self.axis, weights=self.follow_share, minlength=2)
        self.follow_total = np.where(follow_total > 0, follow_total, np.inf)
        rest = emb.rest[self.idx]
        self.lo, self.hi = emb.min[self.idx] - rest, emb.max[self.idx] - rest
        self.vmax = np.minimum(p.max_speed, p.speed_fraction * emb.vel_limit[self.idx])
        self.gain = self._gains()
        state = getattr(self, "state", None)
        if state is not None and state.x.shape != (n,):  # a new DoF set: start from rest (no old state fits)
            state.x = np.zeros(n)
        self.mask = np.zeros(emb.n_channels, dtype=bool)
        self.mask[self.idx] = True
        self._kernel = entry_point(gaze_tick, GAZE_SIG) if self.ctx.compiled else None
        chain = self.chain
        j_rows, j_off, jlo, jhi = chain.channel_map()
        consts = gaze_constants(
            emb.rest,
            self.gain,
            self.share,
            self.follow_share,
            self.follow_total,
            self.tau,
            self.lo,
            self.hi,
            self.vmax,
            self.eye_offset,
            j_off,
            jlo,
            jhi,
        )
        chain_arrays = chain_args(chain)
        self._kernel_args = (
            self.idx.astype(np.int64),
            self.axis.astype(np.int64),
            self.leader,
            consts,
            p.arc_dip,
            p.arc_max,
            ARC_SMOOTHING,
            p.tolerance,
            j_rows,
            *chain_arrays,
            gaze_workspace(emb.n_channels, len(self.idx), len(j_off), chain_arrays[7].shape[0]),
        )

    def _dofs(self, given: list[str] | None, default: list[str] | None, label: str) -> list[str]:
        emb = self.emb
        if given is None:
            names = [n for n in (default or []) if emb.has_dof(n)]
            depth = joint_depths(emb)
            names.sort(key=lambda n: -depth.get(emb.dof(n).joint or "", 0))  # most distal (head) leads
        else:
            names = list(given)
        for n in names:
            if not emb.has_dof(n):
                raise ValueError(f"robot '{emb.name}' has no DoF '{n}' ({label} DoFs)")
            d = emb.dof(n)
            if d.dimension is not Dimension.stationary or d.type is not DofType.continuous:
                raise ValueError(f"{label} DoF '{n}' is not a stationary joint DoF")
        if len(set(names)) != len(names):
            raise ValueError(f"{label} DoFs are listed twice: {names}")
        return names

    def _gains(self) -> np.ndarray:
        """d(gaze yaw or pitch)/d(DoF) at rest, by finite differences (handles symbolic DoFs and axis signs)."""
        rest = self.emb.rest.copy()
        base = yaw_pitch(self.chain.fk(self.chain.q_from_channels(rest))[:3, 0])
        gains = np.empty(len(self.names))
        for i, (c, a) in enumerate(zip(self.idx, self.axis)):
            v = rest.copy()
            step = _GAIN_STEP if v[c] + _GAIN_STEP <= self.emb.max[c] else -_GAIN_STEP
            v[c] += step
            moved = yaw_pitch(self.chain.fk(self.chain.q_from_channels(v))[:3, 0])
            gains[i] = _wrap(moved[a] - base[a]) / step
            if abs(gains[i]) < 1e-3:
                raise ValueError(f"DoF '{self.names[i]}' does not turn the gaze's {('yaw', 'pitch')[a]}")
        return gains

    def reset(self) -> None:
        self.state = self.State(x=np.zeros(len(self.names)))
        self._end_watch("cancelled", reached=False)

    # --- look_at: reach and the end of the move ------------------------------------------------------
    def reach(self, target: Any) -> dict[str, Any]:
        """Whether the gaze can face `target` (m, base frame), and where it stops if not (gaze_reach)."""
        return gaze_reach.reach(self, target)

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "watch":  # a look_at: report its end (a newer one replaces it)
            self._end_watch("cancelled", reached=False, replaced=True)
            self._watch = gaze_reach.GazeWatch(str(args.get("command_id")))
            self.state.still = 0.0
            self.ctx.notify(self.node_id, "started", command_id=self._watch.command_id)
            return {"watching": True}
        if command == "unwatch":  # its command was cancelled (the hub reports that)
            watch = getattr(self, "_watch", None)
            if watch is not None and watch.command_id == args.get("command_id"):
                self._watch = None
            return {"stopped": True}
        if command == "stop":  # stop_all, reset: the look_at in progress ends as cancelled
            self._end_watch("cancelled", reached=False)
            return {"stopped": True}
        return super().handle(command, args)

    def _end_watch(self, event: str, **details: Any) -> None:
        watch = getattr(self, "_watch", None)
        if watch is not None:
            self._watch = None
            self.ctx.notify(self.node_id, event, command_id=watch.command_id, **details)

    def _follow_watch(self, on_target: bool, x_old: np.ndarray, x: np.ndarray) -> None:
        """A look_at in progress ends when the gaze is on target, or stood still for STILL_TICKS ticks."""
        if getattr(self, "_watch", None) is None:
            return
        s = self.state
        s.still = s.still + 1.0 if float(np.abs(x - x_old).max(initial=0.0)) < gaze_reach.STILL else 0.0
        if on_target or s.still >= gaze_reach.STILL_TICKS:
            self.watch_completed(on_target)

    def watch_completed(self, on_target: bool) -> None:
        """The look_at in progress is done (the gaze is on target, or stood still short of it)."""
        self._end_watch("completed", reached=on_target, _channels=tuple(self.idx.tolist()))

    # --- run time -----------------------------------------------------------------------------------
    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        p, emb, s = self.params, self.emb, self.state
        d = self.driven(inputs)
        target, strength = d.target, d.strength
        if self._kernel is not None and self.ctx.compiled:  # the compiled twin of the lines below
            out = np.empty(emb.n_channels)
            x = s.x.copy()  # a new array each tick, as below (an adopted state never shares it)
            on_target = self._kernel(
                x, s.dip_cell, out, target, float(strength), float(dt), *self._kernel_args
            )
            x_old, s.x = s.x, x
            self._follow_watch(bool(on_target), x_old, x)
            return {"out": PartialFrame(out, self.mask, []), "on_target": bool(on_target)}
        # Where the eyes are and look now (the gaze pose without the arc dip, other joints at rest).
        values = emb.rest.copy()
        values[self.idx] += s.x
        pose = self.chain.fk(self.chain.q_from_channels(values))
        eye = pose[:3, :3] @ self.eye_offset + pose[:3, 3]
        look = pose[:3, 0]
        to_target = target - eye
        dist = float(np.linalg.norm(to_target))
        x_old = s.x
        if dist > 1e-6:
            u = to_target / dist
            on_target = bool(math.acos(min(1.0, float(look @ u))) < p.tolerance)
            ty, tp = yaw_pitch(u)
            ly, lp = yaw_pitch(look)
            err = np.array([_wrap(ty - ly), tp - lp])
            desired = np.bincount(self.axis, weights=self.gain * x_old, minlength=2) + err
            # Followers: their share, lagged per stage; then the leader of each axis makes up the rest.
            goal = np.clip(self.share * desired[self.axis] / self.gain, self.lo, self.hi)
            # What a DoF at its limit cannot take goes to the followers of its axis.
            missing = desired - np.bincount(self.axis, weights=self.gain * goal, minlength=2)
            goal = np.clip(
                goal + (missing / self.follow_total)[self.axis] * self.follow_share / self.gain,
                self.lo,
                self.hi,
            )
            alpha = 1.0 - np.exp(-dt / np.maximum(self.tau, 1e-9))
            x = self._limit(x_old, x_old + alpha * (goal - x_old), dt)
            followers = np.bincount(self.axis, weights=np.where(self.leader, 0.0, self.gain * x), minlength=2)
            lead_goal = (desired[self.axis] - followers[self.axis]) / self.gain
            x = self._limit(x_old, np.where(self.leader, lead_goal, x), dt)
        else:
            on_target, x = True, x_old.copy()
        s.x = x
        # Arcs: a pitch dip that follows the (smoothed) yaw speed, outside the gaze feedback loop.
        yaw_speed = abs(float(np.sum(np.where(self.axis == 0, self.gain * (x - x_old), 0.0)))) / max(dt, 1e-9)
        dip_goal = min(p.arc_dip * yaw_speed, p.arc_max)
        s.dip += (1.0 - math.exp(-dt / ARC_SMOOTHING)) * (dip_goal - s.dip)
        rel = x + np.where(self.axis == 1, self.share * s.dip / self.gain, 0.0)
        out = emb.rest.copy()
        out[self.idx] += np.clip(strength * rel, self.lo, self.hi)
        mask = np.zeros(emb.n_channels, dtype=bool)
        mask[self.idx] = True
        self._follow_watch(on_target, x_old, x)
        return {"out": PartialFrame(out, mask, []), "on_target": on_target}

    def _limit(self, old: np.ndarray, new: np.ndarray, dt: float) -> np.ndarray:
        step = self.vmax * dt
        return old + np.clip(np.clip(new, self.lo, self.hi) - old, -step, step)
