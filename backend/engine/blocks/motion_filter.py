"""The Nutty Motion Filter as blocks: an operator for one chain, and a stage-2 post-processor.

Limits default to the embodiment's per-DoF limits. With the tanh limiter the filter's velocity
never reaches V/2, so the robot's velocity limit Vr is passed as V = 2 Vr (the output then stays
below Vr); acceleration and jerk limits are passed as they are (the spec bounds the output by A and
J). With the hard limiter V = Vr. `limit_scale` uses a fraction of the limits; `vel_limit`,
`acc_limit`, `jerk_limit` replace the robot's limits for every filtered DoF (same meaning: bounds
of the output). Parameter changes reach the running filter through `set_params`: its state stays.
The spec's jerk bound on the output is only guaranteed while one tick's jerk budget J/rate is at least
0.2 A (see backend/engine/nmf/__init__.py); the bundled robot's J = 10 A gives 0.12 at 100 Hz, where the
output measured at most 0.62 J on a square wave, but without that guarantee.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal, TypedDict, TypeVar

import numpy as np
from pydantic import Field

from backend.engine.blocks.base import (
    Block,
    BlockParams,
    DofSelection,
    Port,
    PortType,
    Role,
    drivable,
    soft_range,
)
from backend.engine.compiled import entry_point, plain_frame
from backend.engine.compiled.frames import FILTER_SIG, filter_tick
from backend.engine.embodiment import ChannelKind
from backend.engine.frames import PartialFrame
from backend.engine.nmf import MotionFilter, preset
from backend.engine.selectors import channel_mask

PresetName = Literal["W", "A", "B", "C", "D", "E", "custom"]


class FilterParams(BlockParams):
    preset: PresetName = Field(
        default="D",
        description="the paper's character presets (W regular, A slow & smooth, "
        "B slow & vivid, C fast & vivid, D fast & smooth, E fast & very "
        "smooth) or custom σ/ρ",
    )
    sigma: float | None = drivable(
        Field(default=None, ge=0.0, le=1.0, description="smoothness σ (0..1); overrides the preset"),
        "overrides σ",
        clamp="range",
    )
    rho: float | None = drivable(
        Field(default=None, ge=0.0, le=1.0, description="responsiveness ρ (0..1); overrides the preset"),
        "overrides ρ",
        clamp="range",
    )
    bypass: bool = Field(
        default=False, description="bypass H: the regular filter W (limits only, no character)"
    )
    order: Literal[1, 2, 3] = Field(
        default=3, description="continuity order: 1 velocity, 2 acceleration, 3 jerk limited"
    )
    limiter: Literal["tanh", "hard"] = Field(
        default="tanh", description="tanh (smooth, keeps headroom) or hard clip"
    )
    limit_scale: float = Field(
        default=1.0,
        gt=0.0,
        le=1.0,
        description="fraction of the robot's velocity, acceleration and jerk limits to use (0..1]",
    )
    vel_limit: float | None = Field(
        default=None,
        gt=0.0,
        le=1e6,
        description="velocity bound of the output for every "
        "filtered DoF (units/s); default: the robot's per-DoF limits",
        json_schema_extra=soft_range(0, 20, 0.1),
    )
    acc_limit: float | None = Field(
        default=None,
        gt=0.0,
        le=1e8,
        description="acceleration bound of the output (units/s²); default: the robot's per-DoF limits",
        json_schema_extra=soft_range(0, 200, 1),
    )
    jerk_limit: float | None = Field(
        default=None,
        gt=0.0,
        le=1e10,
        description="jerk bound of the output (units/s³); default: the robot's per-DoF limits",
        json_schema_extra=soft_range(0, 5000, 10),
    )
    beta: float = Field(
        default=5.0,
        ge=1.0,
        le=200.0,
        description="position-saturation exponent β (>= 1)",
        json_schema_extra=soft_range(1, 50, 0.5),
    )


class MotionFilterParams(FilterParams):
    dofs: DofSelection = Field(default=["stationary:*", "spatial:*"])


class Stage2Params(FilterParams):
    skip: DofSelection = Field(
        default=[],
        description="DoFs the filter passes through untouched (the safety net still bounds them): e.g. "
        "a lip-sync mouth on a screen, which must follow speech without the filter's lag",
    )


FP = TypeVar("FP", bound=FilterParams)


class _Limits(TypedDict):
    """The filter's per-DoF bounds, as `MotionFilter` and its `set_params` take them."""

    vel_limit: np.ndarray
    acc_limit: np.ndarray
    jerk_limit: np.ndarray


class _Range(TypedDict):
    pmin: np.ndarray
    pmax: np.ndarray


class _FilterBlock(Block[FP]):
    inputs = {"in": Port(PortType.frame, "set-points (a stepped, CGI-style frame)", required=True)}
    outputs = {"out": Port(PortType.frame, "filtered, motor-safe frame")}

    def selection(self) -> np.ndarray:
        raise NotImplementedError

    def _character(self, sigma: float | None = None, rho: float | None = None) -> tuple[float, float, bool]:
        p = self.params
        if p.preset == "custom":
            s, r, bypass = 0.5, 0.5, p.bypass
        else:
            pr = preset(p.preset)
            s, r, bypass = pr.sigma, pr.rho, pr.bypass or p.bypass
        s = p.sigma if p.sigma is not None else s
        r = p.rho if p.rho is not None else r
        if sigma is not None:
            s = sigma
        if rho is not None:
            r = rho
        return s, r, bypass

    def configure(self) -> None:
        emb, p = self.emb, self.params
        self.sel = self.selection()
        idx = np.flatnonzero(self.sel)
        self.idx = idx
        scale = p.limit_scale

        def limit(override: float | None, robot: np.ndarray) -> np.ndarray:
            return (robot[idx] if override is None else np.full(idx.size, float(override))) * scale

        # tanh keeps the output's velocity below V/2: V = 2 x the bound (see the module doc)
        vel = limit(p.vel_limit, emb.vel_limit) * (2.0 if p.limiter == "tanh" else 1.0)
        acc = limit(p.acc_limit, emb.acc_limit)
        jerk = limit(p.jerk_limit, emb.jerk_limit)
        groups = []
        for members in emb.groups.values():
            local = [int(np.searchsorted(idx, m)) for m in members if self.sel[m]]
            if len(local) > 1:
                groups.append(local)
                for arr in (vel, acc, jerk):  # a coupled group shares its most conservative limit
                    arr[local] = arr[local].min()
        self._limits = _Limits(vel_limit=vel, acc_limit=acc, jerk_limit=jerk)
        self._groups = groups
        self._pos = _Range(pmin=emb.min[idx], pmax=emb.max[idx])
        sigma, rho, bypass = self._character()
        old = getattr(self, "filter", None)
        if old is not None and old.n == max(1, idx.size) and old.groups == groups:
            old.set_params(
                order=p.order,
                limiter=p.limiter,
                sigma=sigma,
                rho=rho,
                bypass=bypass,
                beta=p.beta,
                **self._limits,
                **self._pos,
            )
        else:
            self._new_filter()
        self._sigma_rho = (sigma, rho)
        # The compiled tick calls the filter's own kernel on its buffers (when it runs compiled code).
        f = self.filter
        self._kernel = (
            entry_point(filter_tick, FILTER_SIG)
            if self.ctx.compiled and f is not None and f.compiled
            else None
        )
        self._idx64 = self.idx.astype(np.int64)
        self._no_mask = np.zeros(self.emb.n_channels, dtype=bool)
        # The mask out depends only on the mask in (and idx): for the same mask object in (masks never change in
        # place), the last mask out again, the kernel writing its copy to a scratch buffer.
        self._mask_scratch = np.empty(self.emb.n_channels, dtype=bool)
        self._mask_memo: tuple | None = None

    def _new_filter(self) -> None:
        p = self.params
        sigma, rho, bypass = self._character()
        if self.idx.size == 0:
            self.filter = None
            return
        self.filter = MotionFilter(
            int(self.idx.size),
            self.ctx.rate,
            order=p.order,
            sigma=sigma,
            rho=rho,
            limiter=p.limiter,
            bypass=bypass,
            beta=p.beta,
            groups=self._groups,
            x0=self.emb.rest[self.idx],
            **self._limits,
            **self._pos,
        )
        self._sp = np.full(self.idx.size, np.nan)

    def reset(self) -> None:
        self._new_filter()

    def adopt_state(self, old: Block) -> None:
        if (
            isinstance(old, _FilterBlock)
            and old.filter is not None
            and self.filter is not None
            and np.array_equal(old.idx, self.idx)
        ):
            self.filter.set_state(old.filter.position, old.filter.velocity, old.filter.acceleration)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        frame: PartialFrame | None = inputs.get("in")
        if self.filter is None:
            return {"out": frame if frame is not None else self.empty()}
        if "sigma" in inputs or "rho" in inputs:  # unwired, both resolve to None: nothing to change
            wired = self.driven(
                inputs, sigma=None, rho=None
            )  # wired values only (clamped to 0..1), else None
            if wired.sigma is not None or wired.rho is not None:
                s, r, _ = self._character(wired.sigma, wired.rho)
                if (s, r) != self._sigma_rho:
                    self.filter.set_params(sigma=s, rho=r)
                    self._sigma_rho = (s, r)
        if (
            self._kernel is not None
            and self.ctx.compiled
            and (frame is None or plain_frame(frame, self.emb.n_channels))
        ):
            return self._tick_compiled(self._kernel, self.filter, frame)
        sp = self._sp
        if frame is not None:
            np.copyto(sp, frame.values[self.idx])
            sp[~frame.mask[self.idx]] = np.nan  # channels the frame does not set: hold the latest
        else:
            sp.fill(np.nan)
        pos = self.filter.step(sp)
        if frame is None:
            values, mask, events = self.emb.rest.copy(), np.zeros(self.emb.n_channels, bool), []
        else:
            values, mask, events = frame.values.copy(), frame.mask.copy(), frame.events
        values[self.idx] = pos
        mask[self.idx] = True
        return {"out": PartialFrame(values, mask, events)}

    def _tick_compiled(
        self, kernel: Callable[..., None], f: MotionFilter, frame: PartialFrame | None
    ) -> dict[str, Any]:
        """The compiled twin of the end of `tick`: set-points, one filter step (of `f`, the block's
        filter), the frame out."""
        emb = self.emb
        values = np.empty(emb.n_channels)
        has = frame is not None
        mask_in = frame.mask if has else self._no_mask
        memo = self._mask_memo
        if memo is not None and memo[0] is mask_in and memo[1] is self._idx64:
            mask, written = memo[2], self._mask_scratch
        else:
            mask = written = np.empty(emb.n_channels, dtype=bool)
        kernel(
            frame.values if has else emb.rest,
            mask_in,
            has,
            self._idx64,
            self._sp,
            *f.kernel_buffers(),
            emb.rest,
            values,
            written,
        )
        if written is mask:
            self._mask_memo = (mask_in, self._idx64, mask)
        return {"out": PartialFrame(values, mask, frame.events if has else [])}


class MotionFilterBlock(_FilterBlock[MotionFilterParams]):
    """The Nutty Motion Filter on the selected DoFs: stepped motion in, smooth motor-safe motion out.

    Limits velocity, acceleration and jerk to the robot's limits while the character parameters
    shape the motion: σ (smoothness) and ρ (responsiveness), or one of the paper's presets. Put it in
    a chain (e.g. after a stepped clip) to filter one layer; use the stage-2 filter for the whole robot.
    """

    type_name = "motion_filter"
    title = "Motion filter (NMF)"
    category = "operators"
    role = Role.operator

    def selection(self) -> np.ndarray:
        return channel_mask(self.emb, self.params.dofs, continuous_only=True)


class MotionFilterStage2(_FilterBlock[Stage2Params]):
    """The Nutty Motion Filter on every continuous DoF and colour, as the last stage before the robot.

    The paper's Level 3 post-processor: whatever the layers produce, every DoF reaches the robot within
    its velocity, acceleration and jerk limits (the embodiment's, scaled by `limit_scale`), shaped by σ
    and ρ; DoFs in `skip` pass untouched (the engine's safety net still bounds them). Its input is the
    *ghost* the Pre-Viz shows beside the filtered robot.
    """

    type_name = "nmf_stage2"
    title = "Motion filter (stage 2)"
    category = "stage2"
    role = Role.stage2

    def selection(self) -> np.ndarray:
        filtered = self.emb.channel_kind != ChannelKind.enum
        if self.params.skip:
            filtered &= ~channel_mask(self.emb, self.params.skip)
        return filtered
