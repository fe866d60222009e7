"""Animation Frames (AF) and Partial Animation Frames (PAF).

Both are structure-of-arrays over the embodiment's channels (see `Embodiment`): one float64 vector
per quantity, never one object per DoF. Events (speech, sounds, one-shot display changes) ride
along as a short list, since they are discrete and rare. `FrameHistory` keeps the last frames for
operators that look back in time (delays).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numba import njit

from backend.engine import warm_up
from backend.engine.embodiment import DofType, Embodiment

if TYPE_CHECKING:  # only named in annotations (the joint stage imports the embodiment, not frames)
    from backend.engine.joint_net import JointLimits


@dataclass(slots=True)
class FrameEvent:
    """A discrete event on an event DoF (or a one-shot on a display DoF).

    `kind` examples: "say" (payload {"text"}), "sound" (payload {"clip"}), "expression".
    """

    dof: str
    kind: str
    payload: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"dof": self.dof, "kind": self.kind, "payload": dict(self.payload)}


@dataclass(slots=True)
class PartialFrame:
    """A PAF: values for the channels whose `mask` is True, plus events. An empty PAF has no effect.

    Read-only to its readers: a block may hand the same frame out on several ticks (an idle blink, a
    face showing one expression), and a compiled step rewrites its own in place each tick, so a reader
    copies what it keeps."""

    values: np.ndarray  # (C,) float64
    mask: np.ndarray  # (C,) bool
    events: list[FrameEvent] = field(default_factory=list)
    #: Whether this object's arrays and events never change (see `SteadyFrame`).
    steady: ClassVar[bool] = False

    @classmethod
    def empty(cls, n_channels: int) -> PartialFrame:
        return cls(np.zeros(n_channels), np.zeros(n_channels, dtype=bool), [])

    @classmethod
    def full(cls, values: np.ndarray, events: list[FrameEvent] | None = None) -> PartialFrame:
        return cls(np.asarray(values, dtype=float), np.ones(len(values), dtype=bool), list(events or []))

    @property
    def is_empty(self) -> bool:
        return not self.events and not bool(self.mask.any())

    def copy(self) -> PartialFrame:
        return PartialFrame(self.values.copy(), self.mask.copy(), list(self.events))

    def apply_to(self, base: np.ndarray) -> np.ndarray:
        """The full vector obtained by writing this PAF over `base` (out-of-place)."""
        return np.where(self.mask, self.values, base)


@dataclass(slots=True)
class SteadyFrame(PartialFrame):
    """A frame its block hands out on many ticks, whose arrays and events list never change: the block
    makes a new one when what it shows changes (an idle blink, a face showing one expression, a
    posture held). A reader that copied it once may skip copying the same object again (the compiled
    core's imports do); a frame that is the same object but rewritten in place (a compiled step's) is
    a plain `PartialFrame`."""

    steady: ClassVar[bool] = True


@dataclass(slots=True)
class AnimationFrame:
    """A complete AF for every DoF of an embodiment.

    Header: embodiment name, time `t` (s since the engine started), `dt` (s), sequence number `seq`.
    `position` holds every channel (rad, m, colour component or enum index); `velocity`,
    `acceleration` and `jerk` are finite differences of the emitted positions (per s, s², s³).
    `stage1` is the pose before the stage-2 post-processors (the paper's *ghost*), if there are any.
    `program` is the program's own frame before the engine's safety net, and `corrected` marks the
    channels the net had to change on this frame (None when it passed everything through).
    `joints` are the actuated URDF joints' positions (rad or m, `Embodiment.joint_names` order) the
    motors get: the channels composed (own DoF plus symbolic DoFs) and limited by the net's joint stage.
    `requested` is what the net was handed (the program's frame after the swap transition), and `net`
    says, on a frame the net corrected, what it changed and which limit each correction enforced.
    `made` is the wall time of the tick that made it.
    """

    embodiment: str
    t: float
    dt: float
    seq: int
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    events: list[FrameEvent] = field(default_factory=list)
    stage1: np.ndarray | None = None
    corrected: np.ndarray | None = None  # (C,) bool: channels the safety net corrected (None: none)
    program: np.ndarray | None = None  # (C,) the program's frame before the safety net
    joints: np.ndarray | None = None  # (J,) the joints the motors get (None: compose `position`)
    requested: np.ndarray | None = None  # (C,) the frame handed to the safety net (None: `program`)
    net: NetCorrection | None = None  # what the net changed (None: it passed everything through)
    #: When the engine's clock made the frame (Unix time, s; None: not made by an engine's tick). Sinks
    #: get frames a hand-over later; stamps that follow the wall clock take this time.
    made: float | None = field(default=None, compare=False)

    def joint_values(self, embodiment: Embodiment) -> np.ndarray:
        """The joints the motors get (rad or m): the net's `joints`, or the channels composed."""
        return self.joints if self.joints is not None else embodiment.joint_positions(self.position)

    def to_dict(self, embodiment: Embodiment, derivatives: bool = True) -> dict[str, Any]:
        """JSON-friendly form keyed by DoF name: continuous -> float, enum -> option, colour -> [r,g,b]."""
        dofs: dict[str, Any] = {}
        # Python floats of whole vectors at once (what float() of each element gives, without the calls).
        position = self.position.tolist()
        if derivatives:
            velocity, acceleration, jerk = (
                self.velocity.tolist(),
                self.acceleration.tolist(),
                self.jerk.tolist(),
            )
        else:
            velocity = acceleration = jerk = []  # not read without derivatives
        for d in embodiment.dofs:
            sl = d.channels
            if d.type is DofType.continuous:
                c = sl.start
                dofs[d.name] = (
                    {
                        "position": position[c],
                        "velocity": velocity[c],
                        "acceleration": acceleration[c],
                        "jerk": jerk[c],
                    }
                    if derivatives
                    else {"position": position[c]}
                )
            elif d.type is DofType.enum:
                index = round(position[sl.start])
                dofs[d.name] = {"index": index, "option": d.options[index] if d.options else None}
            elif d.type is DofType.colour:
                dofs[d.name] = {"rgb": position[sl]}
        out: dict[str, Any] = {
            "embodiment": self.embodiment,
            "t": self.t,
            "dt": self.dt,
            "seq": self.seq,
            "dofs": dofs,
            "events": [e.to_dict() for e in self.events],
        }
        if embodiment.joint_names:
            out["joints"] = dict(zip(embodiment.joint_names, self.joint_values(embodiment).tolist()))
        return out


#: Which limit a safety-net correction enforced (`NetCorrection`): the trajectory-helper's classes
#: (1 velocity, 2 acceleration, 3 jerk), then position; 0: not corrected.
LIMIT_NAMES = ("ok", "velocity", "acceleration", "jerk", "position")
LIMIT_POSITION = 4


@dataclass(slots=True)
class NetCorrection:
    """What the safety net changed on one frame it corrected: the joints the request composes to (rad or
    m, `Embodiment.joint_names` order) and, per channel and per joint, the limit each correction enforced
    (`LIMIT_NAMES` codes, 0 where the request was delivered as it was)."""

    requested_joints: np.ndarray  # (J,)
    channel_limits: np.ndarray  # (C,) int8
    joint_limits: np.ndarray  # (J,) int8


@njit(cache=True)
def _limit_codes(x, x1, x2, x3, d, dv, da, dj, lo, hi, V, A, J, h, out):
    """The kernel of `limits_enforced`, in place into `out` (one compiled pass over the entries)."""
    slack = 1.0 + 1e-9
    for i in range(x.shape[0]):
        gap = x[i] - d[i]
        if gap == 0.0:
            out[i] = 0
        elif not math.isfinite(x[i]) or x[i] < lo[i] or x[i] > hi[i]:
            out[i] = LIMIT_POSITION
        elif abs((x[i] - 3.0 * x1[i] + 3.0 * x2[i] - x3[i]) / h**3) > J[i] * slack:
            out[i] = 3
        elif abs((x[i] - 2.0 * x1[i] + x2[i]) / h**2) > A[i] * slack:
            out[i] = 2
        elif abs((x[i] - x1[i]) / h) > V[i] * slack:
            out[i] = 1
        else:  # the request's own motion is legal: what delivering it from the net's state would need
            sv = abs(dv[i] + gap / h) / V[i]
            sa = abs(da[i] + gap / h**2) / A[i]
            sj = abs(dj[i] + gap / h**3) / J[i]
            out[i] = -(3 if sj >= sa and sj >= sv else (2 if sa >= sv else 1))  # negative: by the state


@njit(cache=True)
def _differences(x, x1, x2, x3, h):
    """Backward finite differences (v, a, j) of `x` after x1, x2, x3 (newest first), in one pass."""
    v, a, j = np.empty_like(x), np.empty_like(x), np.empty_like(x)
    for i in range(x.shape[0]):
        v[i] = (x[i] - x1[i]) / h
        a[i] = (x[i] - 2.0 * x1[i] + x2[i]) / h**2
        j[i] = (x[i] - 3.0 * x1[i] + 3.0 * x2[i] - x3[i]) / h**3
    return v, a, j


@warm_up.warm_later
def _warm_net_correction() -> None:
    """Load `net_correction`'s compiled code for the argument types it is called with (warm_up.py)."""
    one, out = np.ones(1), np.zeros(1, dtype=np.int8)
    limit = np.ones(1)
    limit.flags.writeable = False  # an embodiment's limits are read-only; a joint table's are not
    _limit_codes(one, one, one, one, one, one, one, one, limit, limit, limit, limit, limit, 0.01, out)
    _limit_codes(one, one, one, one, one, one, one, one, one, one, one, one, one, 0.01, out)
    _differences(one, one, one, one, 0.01)


def limits_enforced(
    request: tuple[np.ndarray, ...],
    delivered: np.ndarray,
    moved: tuple[np.ndarray, ...],
    limits: tuple[np.ndarray, ...],
    h: float,
) -> np.ndarray:
    """Per entry (channel or joint), the limit a correction enforced: an int8 `LIMIT_NAMES` code, 0 where
    the request was delivered as it was.

    Position when the request lies outside [lo, hi] (or is not a number); otherwise the class of the
    request's own motion (its finite differences over `request`: this tick's and the three before, newest
    first; most severe wins, jerk > acceleration > velocity, as the trajectory-helper); when that motion
    is within the limits (the net is catching up after a jump, or braking ahead of a limit), the one of
    velocity, acceleration and jerk that delivering the request from the net's state needs most relative
    to its limit (`moved`: the delivered finite differences (v, a, j); the request's from there add
    gap/h, gap/h², gap/h³); those codes are negative (`net_correction` tells them apart). limits: (lo,
    hi, V, A, J), positive V, A, J."""
    out = np.zeros(len(delivered), dtype=np.int8)
    x, x1, x2, x3 = request
    dv, da, dj = moved
    lo, hi, V, A, J = limits
    _limit_codes(x, x1, x2, x3, delivered, dv, da, dj, lo, hi, V, A, J, float(h), out)
    return out


def net_correction(
    frame: AnimationFrame,
    emb: Embodiment,
    joints: JointLimits,
    requested: tuple[np.ndarray, ...],
    delivered: tuple[np.ndarray, ...],
) -> NetCorrection:
    """What the net changed on `frame` (one it corrected): `requested` and `delivered` hold the channels
    handed to the net and the joints delivered on the three ticks before (newest first). Compiled over
    the entries; a few µs, paid only on corrected frames."""
    request = frame.requested if frame.requested is not None else frame.position
    h = frame.dt
    channels = limits_enforced(
        (request, *requested),
        frame.position,
        (frame.velocity, frame.acceleration, frame.jerk),
        (emb.min, emb.max, emb.vel_limit, emb.acc_limit, emb.jerk_limit),
        h,
    )
    q = frame.joint_values(emb)
    q1, q2, q3 = delivered
    moved = _differences(q, q1, q2, q3, h)
    wanted = tuple(joints.compose(x) for x in (request, *requested))  # the requests' joints
    limits = (joints.lower, joints.upper, joints.velocity, joints.acceleration, joints.jerk)
    joint_codes = limits_enforced(wanted, q, moved, limits, h)
    # A channel whose own request was legal, corrected because its joint was (the joint stage carries a
    # joint's correction back onto its own channel): the joint's limit is the one enforced.
    hit = np.flatnonzero((joint_codes != 0) & (joints.own >= 0))
    carried = hit[channels[joints.own[hit]] < 0]
    channels[joints.own[carried]] = joint_codes[carried]
    return NetCorrection(wanted[0], np.abs(channels), np.abs(joint_codes))


@dataclass
class FrameHistory:
    """A ring buffer of the last frames (values and masks), read back per channel a number of ticks ago
    (the state of the delay and asymmetry operators)."""

    values: np.ndarray  # (capacity, channels)
    mask: np.ndarray  # (capacity, channels) bool
    head: int = 0
    primed: bool = False

    @classmethod
    def for_delay(cls, max_seconds: float, rate: float, n_channels: int) -> FrameHistory:
        """Room for delays up to `max_seconds` at `rate` Hz."""
        capacity = math.ceil(max_seconds * rate) + 2
        return cls(np.zeros((capacity, n_channels)), np.zeros((capacity, n_channels), dtype=bool))

    def push_read(
        self, values: np.ndarray, mask: np.ndarray, lag: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Store this tick's frame and read each channel `lag[c]` ticks back (0 = now)."""
        cap = self.values.shape[0]
        if not self.primed:  # start as if the first frame had always been there: no jump at start
            self.values[:] = values
            self.mask[:] = mask
            self.primed = True
        self.values[self.head] = values
        self.mask[self.head] = mask
        rows = (self.head - np.minimum(lag, cap - 1)) % cap
        cols = np.arange(values.shape[0])
        out_v, out_m = self.values[rows, cols], self.mask[rows, cols]
        self.head = (self.head + 1) % cap
        return out_v, out_m
