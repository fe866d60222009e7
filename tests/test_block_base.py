"""The block base class: drivable parameters (port + resolved value), the declared state object and its
adoption in a hot swap, the operator's missing-frame handling and the frame history ring buffer.

The demo blocks here are not registered, so the catalog stays as it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import pytest
from pydantic import Field

from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import (
    FRAME_IN,
    Block,
    BlockContext,
    BlockParams,
    Operator,
    Port,
    PortType,
    drivable,
)
from backend.engine.frames import FrameHistory, PartialFrame
from backend.engine.library import RobotLibrary


class DemoParams(BlockParams):
    gain: float = drivable(
        Field(1.0, ge=0.0, le=2.0, description="scale"), "overrides the gain", clamp="range"
    )
    rate: float = drivable(
        Field(0.5, ge=0.0, le=5.0, description="Hz"), "overrides the rate (Hz)", clamp="floor"
    )
    offset: float = drivable(Field(0.0, ge=-1.0, le=1.0, description="added"))
    target: list[float] = drivable(
        Field([1.0, 0.0, 0.0], min_length=3, max_length=3), "look here", port=PortType.vec3
    )
    label: str | None = drivable(Field(None), "a name", port=PortType.string)
    steps: int = Field(3, ge=1, description="not drivable")


class Demo(Operator):
    type_name = "demo"
    Params = DemoParams
    inputs = {**FRAME_IN, "hold": Port(PortType.bool, "a hand-written port")}

    @dataclass
    class State:
        level: np.ndarray
        count: int = 0

    def reset(self) -> None:
        self.state = self.State(level=np.zeros(self.emb.n_channels))

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        d = self.driven(inputs)
        self.state.count += 1
        self.state.level = self.state.level + d.gain * dt
        return {"out": PartialFrame(frame.values * d.gain + d.offset, frame.mask.copy(), frame.events)}


@pytest.fixture
def ctx(desk):
    return BlockContext(embodiment=desk, rate=100.0)


def frame(desk) -> PartialFrame:
    return PartialFrame(desk.rest.copy(), np.ones(desk.n_channels, bool), [])


# --- drivable parameters ------------------------------------------------------------------------------


def test_drivable_parameters_become_input_ports_after_the_declared_ones():
    assert list(Demo.inputs) == ["in", "hold", "gain", "rate", "offset", "target", "label"]
    assert Demo.inputs["gain"] == Port(PortType.float, "overrides the gain")
    assert Demo.inputs["target"] == Port(PortType.vec3, "look here")
    assert Demo.inputs["label"] == Port(PortType.string, "a name")
    assert Demo.inputs["offset"] == Port(PortType.float, "")
    assert not any(p.required for name, p in Demo.inputs.items() if name in Demo.drivables)
    assert Demo.ports(None)[0] is Demo.inputs


def test_marking_a_parameter_drivable_leaves_its_json_schema_alone():
    class Plain(BlockParams):
        gain: float = Field(1.0, ge=0.0, le=2.0, description="scale")

    class Marked(BlockParams):
        gain: float = drivable(
            Field(1.0, ge=0.0, le=2.0, description="scale"), "overrides the gain", clamp="range"
        )

    plain, marked = Plain.model_json_schema(), Marked.model_json_schema()
    plain.pop("title"), marked.pop("title")
    assert plain == marked
    assert Marked(gain=1.5).gain == 1.5
    with pytest.raises(ValueError):
        Marked(gain=3.0)  # the field's own validation is unchanged


def test_unwired_drivable_parameters_resolve_to_the_parameters(desk, ctx):
    blk = Demo(DemoParams(gain=1.5, rate=2.0, offset=-0.25, label="x"), ctx, "d")
    d = blk.driven({})
    assert (d.gain, d.rate, d.offset, d.label) == (1.5, 2.0, -0.25, "x")
    np.testing.assert_array_equal(d.target, [1.0, 0.0, 0.0])
    assert isinstance(d.target, np.ndarray) and not hasattr(d, "steps")


def test_wired_drivable_parameters_override_and_are_clamped_as_declared(desk, ctx):
    blk = Demo(DemoParams(), ctx, "d")
    d = blk.driven({"gain": 1.25, "rate": 7, "offset": 4.0, "target": (0.0, 2.0, 0.5), "label": "hi"})
    assert d.gain == 1.25 and isinstance(d.rate, float)
    assert d.rate == 7.0  # clamp="floor": only the lower bound
    assert d.offset == 4.0  # no clamp: taken as it is
    np.testing.assert_array_equal(d.target, [0.0, 2.0, 0.5])
    assert d.label == "hi"
    assert blk.driven({"gain": 9.0, "rate": -3.0}).gain == 2.0  # clamp="range": within ge/le
    assert blk.driven({"gain": -1.0, "rate": -3.0}).rate == 0.0
    assert blk.driven({"gain": True}).gain == 1.0  # a bool wired to a float port counts as 0/1


def test_unusable_wired_values_fall_back_to_the_parameter(desk, ctx):
    blk = Demo(DemoParams(gain=0.5, target=[0.0, 0.0, 1.0]), ctx, "d")
    for bad in (math.nan, math.inf, -math.inf, None):
        assert blk.driven({"gain": bad}).gain == 0.5
    for bad in ([math.nan, 0.0, 0.0], [1.0, 2.0], "far", None):
        np.testing.assert_array_equal(blk.driven({"target": bad}).target, [0.0, 0.0, 1.0])


def test_driven_fallbacks_replace_the_parameter_only_while_unwired(desk, ctx):
    blk = Demo(DemoParams(gain=0.5), ctx, "d")
    assert blk.driven({}, gain=1.75).gain == 1.75
    assert blk.driven({"gain": 0.25}, gain=1.75).gain == 0.25
    assert blk.driven({}, label=None).label is None
    with pytest.raises(TypeError, match="steps"):
        blk.driven({}, steps=4)


class NumberParams(BlockParams):
    gain: float = drivable(
        Field(1.0, ge=-2.0, le=2.0, description="scale"), "overrides the gain", clamp="range"
    )
    target: list[float] = drivable(
        Field([1.0, 0.0, 0.0], min_length=3, max_length=3), "look here", port=PortType.vec3
    )


class Numbers(Operator):
    type_name = "numbers"
    Params = NumberParams


def test_driven_gives_the_last_namespace_again_only_for_the_same_inputs(desk, ctx):
    blk = Numbers(NumberParams(), ctx, "n")
    first = blk.driven({"gain": 0.5})
    assert blk.driven({"gain": 0.5}) is first and blk.driven({"gain": 0.25}).gain == 0.25
    # a list changed in place is a new target; an equal list (or tuple) is the same one
    target = [0.1, 0.2, 0.3]
    d = blk.driven({"target": target})
    assert blk.driven({"target": [0.1, 0.2, 0.3]}) is d and blk.driven({"target": (0.1, 0.2, 0.3)}) is d
    target[0] = 0.9
    np.testing.assert_array_equal(blk.driven({"target": target}).target, [0.9, 0.2, 0.3])
    # -0.0 == 0.0, but a zero keeps its sign; 1, 1.0 and True resolve alike
    assert math.copysign(1.0, blk.driven({"gain": 0.0}).gain) == 1.0
    assert math.copysign(1.0, blk.driven({"gain": -0.0}).gain) == -1.0
    assert math.copysign(1.0, blk.driven({"gain": 0.0}).gain) == 1.0
    assert blk.driven({"gain": 1}).gain == blk.driven({"gain": True}).gain == 1.0
    assert blk.driven({"gain": 0}).gain == 0.0 and math.copysign(1.0, blk.driven({"gain": -0.0}).gain) == -1.0
    # arrays are resolved anew every time, and never compared with a number
    arr = np.array([0.5, 0.5, 0.5])
    np.testing.assert_array_equal(blk.driven({"target": arr}).target, arr)
    assert blk.driven({"gain": 0.5}).gain == 0.5
    np.testing.assert_array_equal(blk.driven({"gain": 0.5, "target": arr * 2}).target, arr * 2)
    # fallbacks are part of what is compared; new parameters start over
    assert blk.driven({}, gain=0.75).gain == 0.75 and blk.driven({}, gain=1.5).gain == 1.5
    blk.update_params(NumberParams(gain=-1.0))
    assert blk.driven({}).gain == -1.0 and blk.driven({"gain": 0.5}).gain == 0.5


def test_a_wired_drivable_parameter_drives_the_block(desk, ctx):
    blk = Demo(DemoParams(gain=1.0), ctx, "d")
    f = frame(desk)
    unwired = blk.tick(0.01, {"in": f})["out"]
    wired = blk.tick(0.01, {"in": f, "gain": 2.0})["out"]
    np.testing.assert_allclose(unwired.values, desk.rest)
    np.testing.assert_allclose(wired.values, 2.0 * desk.rest)


def test_a_port_declared_by_hand_and_as_drivable_is_an_error():
    with pytest.raises(TypeError, match="gain"):

        class Clash(Block):
            Params = DemoParams
            inputs = {"gain": Port(PortType.float, "by hand")}


def test_clamping_needs_the_bounds_it_clamps_to():
    class Unbounded(BlockParams):
        gain: float = drivable(Field(1.0, ge=0.0), clamp="range")

    with pytest.raises(TypeError, match="gain"):

        class NoUpper(Block):
            Params = Unbounded


def test_subclasses_derive_ports_from_their_own_parameters():
    class Base(Block):
        inputs = FRAME_IN

    class WithDemo(Base):
        Params = DemoParams

    assert list(Base.inputs) == ["in"]
    assert list(WithDemo.inputs) == ["in", "gain", "rate", "offset", "target", "label"]


# --- state ---------------------------------------------------------------------------------------------


def test_state_lives_in_one_declared_object(desk, ctx):
    blk = Demo(DemoParams(), ctx, "d")
    assert isinstance(blk.state, Demo.State) and blk.state.count == 0
    blk.tick(0.01, {"in": frame(desk)})
    blk.reset()
    assert blk.state.count == 0 and not blk.state.level.any()


def test_a_state_without_arguments_is_made_by_the_base_reset(ctx):
    class Counter(Block):
        @dataclass
        class State:
            n: int = 0

    blk = Counter(BlockParams(), ctx, "c")
    assert blk.state == Counter.State(n=0)


def test_adopt_state_takes_the_whole_state_over_with_arrays_copied(desk, ctx):
    old = Demo(DemoParams(), ctx, "d")
    for _ in range(3):
        old.tick(0.01, {"in": frame(desk), "gain": 2.0})
    new = Demo(DemoParams(offset=0.5), ctx, "d")
    new.adopt_state(old)
    assert new.state.count == 3
    np.testing.assert_allclose(new.state.level, 0.06)
    assert new.state.level is not old.state.level  # the old block cannot change the new one's state
    new.tick(0.01, {"in": frame(desk)})
    assert old.state.count == 3 and new.state.count == 4


def test_adopt_state_keeps_the_fresh_state_when_an_array_changed_shape(desk, ctx):
    old = Demo(DemoParams(), ctx, "d")
    old.tick(0.01, {"in": frame(desk)})
    old.state.level = np.zeros(3)  # e.g. parameters that changed the DoF set
    new = Demo(DemoParams(), ctx, "d")
    new.adopt_state(old)
    assert new.state.count == 0 and new.state.level.shape == (desk.n_channels,)


def test_adopt_state_ignores_a_state_of_another_class(desk, ctx):
    class Other(Block):
        @dataclass
        class State:
            count: int = 7

    new = Demo(DemoParams(), ctx, "d")
    new.adopt_state(Other(BlockParams(), ctx, "d"))
    assert new.state.count == 0


def _ticking_inputs(desk, cls, block) -> dict[str, Any]:
    ins, _ = cls.ports(block.params)
    return {name: frame(desk) for name, port in ins.items() if port.type is PortType.frame}


@pytest.mark.parametrize("type_name", sorted(BLOCKS))
def test_every_block_keeps_its_state_in_a_dataclass_that_survives_a_swap(desk, type_name):
    cls = BLOCKS[type_name]
    ctx = BlockContext(embodiment=desk, rate=100.0, resources=RobotLibrary(desk.urdf_path.parent, desk))
    try:
        old, new = cls(cls.Params(), ctx, "n"), cls(cls.Params(), ctx, "n")
    except (ValueError, TypeError):
        pytest.skip(f"{type_name} needs parameters")
    assert not hasattr(cls, "state_attrs")
    if cls.State is None:
        return
    assert isinstance(old.state, cls.State)
    inputs = _ticking_inputs(desk, cls, old)
    for _ in range(5):
        old.tick(0.01, inputs)
    new.adopt_state(old)
    for f in fields(old.state):
        mine, theirs = getattr(new.state, f.name), getattr(old.state, f.name)
        if isinstance(theirs, np.ndarray):
            assert mine is not theirs and np.array_equal(mine, theirs, equal_nan=True), f.name
        else:
            assert mine is theirs or mine == theirs, f.name


# --- operators and the history buffer ------------------------------------------------------------------


def test_an_operator_without_an_input_frame_outputs_an_empty_frame_and_stands_still(desk, ctx):
    blk = Demo(DemoParams(), ctx, "d")
    out = blk.tick(0.01, {"gain": 2.0})["out"]
    assert out.is_empty and out.values.shape == (desk.n_channels,)
    assert blk.state.count == 0


def test_frame_history_reads_each_channel_its_lag_back_and_starts_primed():
    h = FrameHistory.for_delay(0.05, 100.0, 2)  # 5 ticks of delay at most
    assert h.values.shape == (7, 2)
    lag = np.array([0, 2])
    outs = [
        h.push_read(np.array([k, k], dtype=float), np.array([True, k % 2 == 0]), lag) for k in range(1, 6)
    ]
    assert [float(v[0]) for v, _ in outs] == [1, 2, 3, 4, 5]
    assert [float(v[1]) for v, _ in outs] == [1, 1, 1, 2, 3]  # before the first frame: the first frame
    assert [bool(m[1]) for _, m in outs] == [False, False, False, True, False]
    big = h.push_read(
        np.array([6.0, 6.0]), np.array([True, True]), np.array([0, 99])
    )  # capped at capacity - 1
    assert float(big[0][1]) == 1.0
