"""The IK stage-2 block: points a chain's tip at a target (look-at) or moves it there (reach)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field

from backend.engine.blocks.base import BlockParams, Operator, PortType, Role, drivable
from backend.engine.compiled import entry_point, plain_frame
from backend.engine.compiled.chain import IK_SIG, chain_args, ik_constants, ik_tick, ik_workspace
from backend.engine.frames import PartialFrame
from backend.engine.kinematics import chain_for
from backend.engine.selectors import select_dofs

MAX_STEP = 0.5  # rad (or m): largest joint step of one iteration, keeps far-off targets stable
CONVERGED = 1e-4  # error (rad for look_at, m for reach) below which a tick stops iterating
NULL_RANGE = (
    0.05  # the null-space pull fades out as the error grows to this (rad or m), so it never blocks the task
)
NULL_GAIN = 0.2  # per iteration: pull toward the stage-1 pose within the task's null space


class IkParams(BlockParams):
    mode: Literal["look_at", "reach"] = Field(
        default="look_at",
        description="look_at: point the tip's axis at the target; reach: move the tip point to the target",
    )
    base_link: str | None = Field(
        default=None, description="URDF link the chain starts from (default: the URDF root)"
    )
    tip_link: str | None = Field(
        default=None, description="URDF link at the end of the chain (default: the robot's gaze.eye_link)"
    )
    tip_offset: list[float] | None = Field(
        default=None,
        min_length=3,
        max_length=3,
        description="point in the tip link's frame (m) that looks or reaches (default: gaze.eye_offset for the eye link)",
    )
    axis: list[float] = Field(
        default=[1.0, 0.0, 0.0],
        min_length=3,
        max_length=3,
        description="pointing direction in the tip link's frame (look_at)",
    )
    dofs: list[str] | None = Field(
        default=None,
        description="DoF selectors the IK may change (default: every joint DoF of the chain); "
        "symbolic DoFs are never changed",
        json_schema_extra={"x-widget": "dofs"},
    )
    target: list[float] | None = drivable(
        Field(
            default=None,
            min_length=3,
            max_length=3,
            description="target point (m, robot base frame) when `target` is unconnected",
        ),
        "target point (m, robot base frame); overrides the target parameter",
        port=PortType.vec3,
    )
    weight: float = drivable(
        Field(
            default=1.0, ge=0.0, le=1.0, description="blend from the stage-1 pose (0) to the IK solution (1)"
        ),
        "overrides the weight parameter (0..1)",
        clamp="range",
    )
    damping: float = Field(
        default=0.05, ge=0.0, le=1.0, description="damping λ of the damped least squares (rad or m)"
    )
    iterations: int = Field(
        default=4, ge=1, le=20, description="solver iterations per tick (warm-started from the last tick)"
    )


class InverseKinematics(Operator[IkParams]):
    """Points a chain's tip at a target (look-at) or moves it to the target (reach).

    A stage-2 post-processor: each tick it starts from the stage-1 pose plus the correction it found last
    tick, runs a few damped-least-squares iterations on the chain from `base_link` to `tip_link` (joint
    limits respected at every iteration) and blends the result with the stage-1 pose by `weight`. Symbolic
    DoFs (e.g. gaze_yaw) are resolved first, so the IK corrects the joints they drive; it changes only the
    chain's joint DoFs selected by `dofs`. Every other channel passes through, and with no target (or a NaN
    one) or weight 0 the frame passes through unchanged.
    """

    type_name = "ik"
    title = "Inverse kinematics"
    category = "stage2"
    role = Role.stage2

    @dataclass
    class State:
        held: np.ndarray  # the last stage-1 value of every channel
        delta: np.ndarray  # the correction found last tick, per moved joint (warm start)

    def configure(self) -> None:
        emb, p = self.emb, self.params
        cfg = emb.gaze or {}
        tip = p.tip_link or cfg.get("eye_link")
        if not tip:
            raise ValueError(f"robot '{emb.name}' has no gaze.eye_link: set the tip_link parameter")
        self.chain = chain = chain_for(emb, p.base_link, tip)
        offset = p.tip_offset
        if offset is None:
            offset = cfg.get("eye_offset", [0.0, 0.0, 0.0]) if tip == cfg.get("eye_link") else [0.0, 0.0, 0.0]
        self.offset = np.asarray(offset, dtype=float)
        axis = np.asarray(p.axis, dtype=float)
        norm = float(np.linalg.norm(axis))
        if norm < 1e-9:
            raise ValueError("axis must not be the zero vector")
        self.axis = axis / norm
        allowed = chain.dof_channels >= 0
        if p.dofs is not None:
            chosen = {
                d.channels.start for d in select_dofs(emb, p.dofs) if d.channels.stop > d.channels.start
            }
            allowed &= np.isin(chain.dof_channels, list(chosen))
        self.var = np.flatnonzero(allowed)  # chain joint indices the IK moves
        self.var_ch = chain.dof_channels[self.var]  # their (1:1) DoF channels
        if p.dofs is not None and len(self.var) == 0:
            raise ValueError(f"none of the DoFs {p.dofs} drives a joint of the chain {chain.joint_names}")
        self.j_rows = emb.joint_matrix[chain.emb_index]
        self.j_off = emb.joint_offset[chain.emb_index]
        self.dof_lo, self.dof_hi = emb.min[self.var_ch], emb.max[self.var_ch]
        self.mask_add = np.zeros(emb.n_channels, dtype=bool)
        self.mask_add[self.var_ch] = True
        state = getattr(self, "state", None)
        if state is not None and state.delta.shape != self.var.shape:
            state.delta = np.zeros(len(self.var))
        self._kernel = entry_point(ik_tick, IK_SIG) if self.ctx.compiled else None
        chain_arrays = chain_args(chain)
        pre, select = chain_arrays[7], chain_arrays[9]
        self._kernel_args = (
            np.ascontiguousarray(self.j_rows),
            self.var.astype(np.int64),
            self.var_ch.astype(np.int64),
            ik_constants(
                self.j_off, chain.lower, chain.upper, self.dof_lo, self.dof_hi, self.offset, self.axis
            ),
            p.mode == "look_at",
            p.damping**2 + 1e-12,
            p.iterations,
            MAX_STEP,
            CONVERGED,
            NULL_GAIN,
            NULL_RANGE,
            *chain_arrays,
            ik_workspace(len(self.j_off), len(self.var), pre.shape[0], select.shape[1]),
        )

    def reset(self) -> None:
        self.state = self.State(held=self.emb.rest.copy(), delta=np.zeros(len(self.var)))

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        s = self.state
        d = self.driven(inputs)
        target, weight = d.target, d.weight
        n = self.emb.n_channels
        if (
            target is not None
            and weight > 0.0
            and len(self.var)
            and self._kernel is not None
            and self.ctx.compiled
            and plain_frame(frame, n)
            and s.held.shape == (n,)
        ):
            # the compiled twin of the reference below
            out, mask = np.empty(n), np.empty(n, dtype=bool)
            self._kernel(
                frame.values,
                frame.mask,
                s.held,
                target,
                float(weight),
                s.delta,
                out,
                mask,
                self.mask_add,
                *self._kernel_args,
            )
            return {"out": PartialFrame(out, mask, list(frame.events))}
        s.held = np.where(frame.mask, frame.values, s.held)
        if target is None or weight <= 0.0 or len(self.var) == 0:
            if target is None:
                s.delta = np.zeros(len(self.var))
            return {"out": PartialFrame(frame.values.copy(), frame.mask, list(frame.events))}
        values = s.held
        chain = self.chain
        q0 = np.clip(self.j_rows @ values + self.j_off, chain.lower, chain.upper)
        ch = values[self.var_ch]
        lo = np.maximum(chain.lower[self.var], q0[self.var] + self.dof_lo - ch)
        hi = np.minimum(chain.upper[self.var], q0[self.var] + self.dof_hi - ch)
        q = q0.copy()
        q[self.var] = np.clip(q0[self.var] + s.delta, lo, hi)
        self._solve(q, target, lo, hi, q0)
        s.delta = q[self.var] - q0[self.var]
        out = frame.values.copy()
        out[self.var_ch] = ch + weight * s.delta
        return {"out": PartialFrame(out, frame.mask | self.mask_add, list(frame.events))}

    def _solve(
        self, q: np.ndarray, target: np.ndarray, lo: np.ndarray, hi: np.ndarray, q0: np.ndarray
    ) -> None:
        """Damped least squares on the chain joints `self.var`, in place on `q`.

        The task step is the minimum-norm damped solution; in the task's null space the joints are pulled
        back toward the stage-1 pose `q0`, so redundant chains make the smallest correction.
        """
        look = self.params.mode == "look_at"
        lam2 = self.params.damping**2 + 1e-12
        var = self.var
        for _ in range(self.params.iterations):
            _, point, d, jp, jd = self.chain.kinematics(q, self.offset, self.axis)
            if look:
                r = target - point
                dist = float(np.sqrt(r @ r))
                if dist < 1e-6:
                    return
                u = r / dist
                # Log map on the sphere: the tangent at d toward u, as long as the angle between them.
                cos = float(u @ d)
                tangent = u - cos * d
                sin = float(np.sqrt(tangent @ tangent))
                angle = float(np.arctan2(sin, cos))
                if angle < CONVERGED:
                    return
                size = angle
                if sin > 1e-9:
                    err = tangent * (angle / sin)
                else:  # exactly behind: turn about the base z axis
                    err = np.cross(np.array([0.0, 0.0, 1.0]), d) * angle
                jpv = jp[:, var]
                # f = d - u(q): df/dq = Jd + (I - u u^T) Jp / |r|  (the eye point moves as well)
                jac = jd[:, var] + (jpv - np.outer(u, u @ jpv)) / dist
            else:
                err = target - point
                size = float(np.sqrt(err @ err))
                if size < CONVERGED:
                    return
                jac = jp[:, var]
            dq = self._step(jac, err, q[var] - q0[var], size, lam2)
            # Active set: joints the step would push past a limit leave the problem, the rest re-solve.
            blocked = ((q[var] <= lo) & (dq < 0)) | ((q[var] >= hi) & (dq > 0))
            if blocked.any():
                jac = np.where(blocked, 0.0, jac)
                dq = np.where(blocked, 0.0, self._step(jac, err, q[var] - q0[var], size, lam2))
            n = float(np.sqrt(dq @ dq))
            if n > MAX_STEP:
                dq *= MAX_STEP / n
            q[var] = np.clip(q[var] + dq, lo, hi)

    @staticmethod
    def _step(jac: np.ndarray, err: np.ndarray, moved: np.ndarray, size: float, lam2: float) -> np.ndarray:
        """Damped least-squares step for `err`, plus a pull back by `moved` within the task's null space."""
        pinv = jac.T @ np.linalg.inv(jac @ jac.T + lam2 * np.eye(3))
        dq = pinv @ err
        pull = NULL_GAIN * (1.0 - size / NULL_RANGE)
        if pull > 0.0:
            dq -= pull * (moved - pinv @ (jac @ moved))
        return dq
