"""The layer mixer: the Level 2 APU, blending several chains (layers) into one frame."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from operator import is_
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from backend.engine.blend import BlendMode, advance_fades, blend_layers
from backend.engine.blocks.base import (
    Block,
    BlockCommandError,
    BlockParams,
    Port,
    PortRule,
    PortType,
    Role,
)
from backend.engine.compiled import entry_point
from backend.engine.compiled.blend import MIXER_SIG, MODE_CODES, mixer_tick
from backend.engine.frames import PartialFrame
from backend.engine.selectors import channel_mask

_LAYER_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_\-]*$")


class LayerSpec(BaseModel):
    """One layer of the mixer; its name is also the name of its input port."""

    model_config = ConfigDict(extra="forbid")
    name: str = Field(..., description="layer (and input port) name")
    mode: BlendMode = Field(default=BlendMode.override, description="override, additive or average")
    weight: float = Field(default=1.0, ge=0.0, le=1.0, description="blend weight (0..1)")
    fade: float = Field(default=0.5, ge=0.0, le=30.0, description="fade-in/out time on (de)activation (s)")
    mask: list[str] = Field(
        default=["*"], description="DoF selectors this layer may set", json_schema_extra={"x-widget": "dofs"}
    )
    active: bool = Field(default=True, description="whether the layer starts active")

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        if not _LAYER_NAME.match(v):
            raise ValueError("layer names start with a letter or _ and use letters, digits, _ or -")
        return v


class MixerParams(BlockParams):
    layers: list[LayerSpec] = Field(
        default=[LayerSpec(name="base")],
        min_length=1,
        description="layers from bottom to top (later layers override earlier ones)",
        json_schema_extra={"x-widget": "layers"},
    )

    @field_validator("layers")
    @classmethod
    def _unique(cls, v: list[LayerSpec]) -> list[LayerSpec]:
        names = [layer.name for layer in v]
        dup = {n for n in names if names.count(n) > 1}
        clash = sorted(n for n in names if n.endswith("_weight") and n[: -len("_weight")] in names)
        if clash:
            raise ValueError(f"layer names {clash} clash with the weight ports of other layers")
        if dup:
            raise ValueError(f"layer names must be unique; repeated: {sorted(dup)}")
        return v


class LayerMixer(Block[MixerParams]):
    """Blends layers into one frame: override by priority, additive offsets, weighted averages.

    Each layer has a blend mode, a weight, a DoF mask and a fade time; activating or deactivating a
    layer fades it in or out. Average layers blend over the rest pose; overrides then apply bottom to
    top; additive layers add their offset from the rest pose (idle breathing over a gesture).
    """

    type_name = "layer_mixer"
    title = "Layer mixer"
    category = "layers"
    role = Role.mixer
    outputs = {"out": Port(PortType.frame, "blended frame")}

    @dataclass
    class State:
        fade_level: np.ndarray  # each layer's fade 0..1
        fade_target: np.ndarray  # 1 for an active layer, 0 for an inactive one

    # One frame input per layer, then an optional live weight per layer (a clip player's envelope, an
    # emotion mapping).
    port_rules = (
        PortRule(side="inputs", each="layers", name="{name}", type="frame", doc="layer '{name}' ({mode})"),
        PortRule(
            side="inputs",
            each="layers",
            name="{name}_weight",
            type="float",
            doc="multiplies layer '{name}''s weight (0..1)",
        ),
    )

    @classmethod
    def check_wiring(cls, params: MixerParams, node: Any) -> None:
        """Warn about layers that can have no effect: weight 0, or nothing connected."""
        for k, layer in enumerate(params.layers):
            if layer.weight == 0:
                node.warning(
                    "zero_weight_layer",
                    port=layer.name,
                    at=("layers", k, "weight"),
                    message=f"layer '{layer.name}' of '{node.node_id}' has weight 0, so it has no effect",
                )
            if not node.connected(layer.name):
                node.warning(
                    "empty_layer",
                    port=layer.name,
                    at=("layers", k),
                    message=f"layer '{layer.name}' of '{node.node_id}' has nothing connected",
                )

    def configure(self) -> None:
        layers = self.params.layers
        self.names = [layer.name for layer in layers]
        self.modes = [layer.mode for layer in layers]
        self.weights = np.array([layer.weight for layer in layers])
        self.fade_time = np.array([layer.fade for layer in layers])
        self.layer_masks = np.stack([channel_mask(self.emb, layer.mask) for layer in layers])
        self._values = np.zeros((len(layers), self.emb.n_channels))
        self._masks = np.zeros((len(layers), self.emb.n_channels), dtype=bool)
        self.weight_ports = [f"{name}_weight" for name in self.names]
        self.signal_weights = np.ones(len(layers))
        # The compiled tick: layers concatenated, a missing frame as zeros with an empty mask.
        self._kernel = entry_point(mixer_tick, MIXER_SIG) if self.ctx.compiled else None
        self._mode_codes = np.array([MODE_CODES[m] for m in self.modes], dtype=np.int64)
        self._no_values = np.zeros(self.emb.n_channels)
        self._no_mask = np.zeros(self.emb.n_channels, dtype=bool)
        self._w = np.zeros(len(layers))
        # (the layers' mask objects, their concatenation), read only
        self._masks_memo: tuple[list[np.ndarray], np.ndarray] | None = None

    def reset(self) -> None:
        active = np.array([1.0 if layer.active else 0.0 for layer in self.params.layers])
        self.state = self.State(fade_level=active.copy(), fade_target=active)

    def adopt_state(self, old: Block) -> None:
        # Layers are matched by name, so reordering or adding layers keeps each one's fade.
        if not isinstance(old, LayerMixer):
            return
        mine, theirs = self.state, old.state
        for i, name in enumerate(self.names):
            if name in old.names:
                j = old.names.index(name)
                mine.fade_level[i] = theirs.fade_level[j]
                mine.fade_target[i] = theirs.fade_target[j]
        self._follow_written_active(old.params.layers)

    def update_params(self, params: MixerParams) -> None:
        before = self.params.layers
        super().update_params(params)
        self._follow_written_active(before)

    def _follow_written_active(self, before: list[LayerSpec]) -> None:
        """A layer whose written `active` changed (the editor's mute, saved in the program) fades to it;
        one left as written keeps what run-time commands made of it."""
        was = {layer.name: layer.active for layer in before}
        for i, layer in enumerate(self.params.layers):
            if was.get(layer.name, layer.active) != layer.active:
                self.state.fade_target[i] = 1.0 if layer.active else 0.0

    def effective_weights(self) -> np.ndarray:
        return self.weights * self.state.fade_level * self.signal_weights

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        if self._kernel is not None and self.ctx.compiled:
            frames = [inputs.get(name) for name in self.names]
            try:
                vals = np.concatenate([self._no_values if f is None else f.values for f in frames])
                layer_masks = [self._no_mask if f is None else f.mask for f in frames]
                # The same mask objects as last tick (masks never change in place): the same concatenation.
                memo = self._masks_memo
                if memo is not None and all(map(is_, layer_masks, memo[0])):
                    masks = memo[1]
                else:
                    masks = np.concatenate(layer_masks)
                    self._masks_memo = (layer_masks, masks)
            except ValueError:  # frames of other shapes: the reference broadcasts them (or says why not)
                vals = masks = None
            if (
                vals is not None
                and masks is not None
                and vals.dtype == np.float64
                and masks.dtype == np.bool_
                and vals.shape == masks.shape == (self._values.size,)
            ):
                return self._tick_compiled(self._kernel, dt, inputs, frames, vals, masks)
        return self._tick_reference(dt, inputs)

    def _read_weight_ports(self, inputs: dict[str, Any]) -> None:
        # An unconnected weight port stays at 1 (configure); only connected ones are in `inputs`.
        for i, port in enumerate(self.weight_ports):
            if port in inputs:
                self.signal_weights[i] = min(max(float(self.signal(inputs, port, 1.0)), 0.0), 1.0)

    def _tick_compiled(
        self,
        kernel: Callable[..., None],
        dt: float,
        inputs: dict[str, Any],
        frames: list,
        vals: np.ndarray,
        masks: np.ndarray,
    ) -> dict[str, Any]:
        s, emb, w = self.state, self.emb, self._w
        self._read_weight_ports(inputs)
        values, mask = np.empty(emb.n_channels), np.empty(emb.n_channels, dtype=bool)
        kernel(
            vals,
            masks,
            self.layer_masks,
            self.weights,
            s.fade_level,
            s.fade_target,
            self.fade_time,
            self.signal_weights,
            float(dt),
            self._mode_codes,
            emb.rest,
            emb.rest,
            emb.enum_mask,
            values,
            mask,
            w,
        )
        events = []
        for i, frame in enumerate(frames):
            if frame is not None and frame.events and w[i] > 0.0:
                events.extend(frame.events)
        return {"out": PartialFrame(values, mask, events)}

    def _tick_reference(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        """The numpy definition of a tick (the compiled kernel's reference)."""
        s = self.state
        s.fade_level = advance_fades(s.fade_level, s.fade_target, self.fade_time, dt)
        self._read_weight_ports(inputs)
        w = self.effective_weights()
        events = []
        self._masks[:] = False
        for i, name in enumerate(self.names):
            frame: PartialFrame | None = inputs.get(name)
            if frame is None:
                continue
            self._values[i] = frame.values
            np.logical_and(frame.mask, self.layer_masks[i], out=self._masks[i])
            if w[i] > 0.0 and frame.events:
                events.extend(frame.events)
        emb = self.emb
        values, mask = blend_layers(
            self._values, self._masks, w, self.modes, emb.rest, emb.rest, emb.enum_mask
        )
        return {"out": PartialFrame(values, mask, events)}

    # --- commands -------------------------------------------------------------------------------
    def layer_index(self, name: str) -> int:
        if name not in self.names:
            raise BlockCommandError(f"mixer '{self.node_id}' has no layer '{name}' (layers: {self.names})")
        return self.names.index(name)

    def set_layer_active(self, name: str, active: bool, fade: float | None = None) -> None:
        i = self.layer_index(name)
        if fade is not None:
            if not 0.0 <= fade <= 30.0:
                raise BlockCommandError(f"fade must be within [0, 30] s, got {fade}")
            self.fade_time[i] = fade
        self.state.fade_target[i] = 1.0 if active else 0.0

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command in ("activate", "deactivate"):
            self.set_layer_active(str(args.get("layer", "")), command == "activate", args.get("fade"))
            return {"layer": args.get("layer"), "active": command == "activate"}
        if command == "set_weight":
            i = self.layer_index(str(args.get("layer", "")))
            weight = float(args.get("weight", 1.0))
            if not 0.0 <= weight <= 1.0:
                raise BlockCommandError(f"weight must be within [0, 1], got {weight}")
            self.weights[i] = weight
            return {"layer": args.get("layer"), "weight": weight}
        return super().handle(command, args)

    def layer_states(self) -> list[dict[str, Any]]:
        w, s = self.effective_weights(), self.state
        return [
            {
                "name": n,
                "mode": m.value,
                "weight": float(self.weights[i]),
                "fade": float(s.fade_level[i]),
                "effective": float(w[i]),
                "active": bool(s.fade_target[i] > 0.5),
            }
            for i, (n, m) in enumerate(zip(self.names, self.modes))
        ]
