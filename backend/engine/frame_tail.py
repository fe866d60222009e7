"""The engine's tail of a tick in one compiled call: the program's frame through the safety net (the
channel stage, the joints composed, the joint stage and its carry-back) to the frame's derivatives.

The same numbers as the Python path (`SafetyNet.step`, then `frames.derivatives`): the kernel calls
the same compiled functions (`safety._net_step`, `joint_net.compose_joints`, `compiled.frames.
derivatives`) on the same state arrays, in the same order, and carries a joint's correction back with
the same arithmetic. The two paths share the net's state, so a tick may take either: the engine takes
this one on a plain tick (no channel overridden, no swap transition, the net enabled, the kernel
loaded) and the Python path otherwise. `tests/test_frame_tail.py` checks they agree bit for bit.

Why one call: a tick that wakes from a sleep pays for every distinct piece of code it touches (caches
cold after the sleep, ~10-40 µs each on the 2-core VM measured in issue 36), and the Python path
touches ten numpy operations and four compiled calls here. The kernel reads the net's arrays by
address (`compiled.pointers`): the net's `reset` replaces its state arrays and counts `generation`,
and the tail lists them again when that count moved.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from backend.engine.compiled import entry_point, f8, f8_1, f8_2, i8, i8_2
from backend.engine.compiled.frames import DERIVATIVES_SIG, derivatives
from backend.engine.compiled.lazy_entry import LazyEntry, LoadOnSecondAsk
from backend.engine.compiled.pointers import AddressTable, b1, f1, f2, i1
from backend.engine.core.program import core_enabled
from backend.engine.frames import AnimationFrame, net_correction
from backend.engine.joint_net import compose_joints
from backend.engine.safety import _net_step

if TYPE_CHECKING:
    from backend.engine.safety import SafetyNet

#: Rows of the frame buffer a tail writes (one (BUFFER_ROWS, C) array per tick; the frame's arrays are
#: its rows): the program's frame, the output position, its velocity, acceleration and jerk, stage 1.
PROGRAM, POSITION, VELOCITY, ACCELERATION, JERK, STAGE1 = range(6)
BUFFER_ROWS = 6

# Rows of the address table: the channel stage, the joint stage, the carry-back, the last frame.
(IDX, STATE, LIMITS, LOCKED, CORRECTED, COUNTS, GAINS, STARTS) = range(8)
(J_STARTS, J_COLS, J_COEFS, J_OFFSET, J_IDX, J_STATE, J_LIMITS, J_LOCKED, J_CORRECTED, J_COUNTS) = range(
    8, 18
)
OWN, CARRIED, CARRIED_N, COMPOSED, LAST = range(18, 23)
TABLE_ROWS = 23

TAIL_SIG = (i8_2, f8_1, f8_1, f8_2, f8_1, f8, f8, i8)  # refs, final, stage1, buf, q, h, dt, seq


@njit(cache=True)
def frame_tail(refs, final, stage1, buf, q, h, dt, seq):
    """One tick's tail (see the module doc), in place: `buf` rows get the program's frame, the output
    and its derivatives and stage 1, `q` the joints the motors get. Returns how many stages and
    channels the net corrected (0: it passed everything through), as `SafetyNet.step` counts them."""
    n = final.shape[0]
    program, pos, s1 = buf[PROGRAM], buf[POSITION], buf[STAGE1]
    for c in range(n):
        program[c] = final[c]
        pos[c] = final[c]
        s1[c] = stage1[c]
    corrected, carried, carried_n = b1(refs, CORRECTED), i1(refs, CARRIED), i1(refs, CARRIED_N)
    for k in range(carried_n[0]):  # last step's carried-back joint corrections
        corrected[carried[k]] = False
    carried_n[0] = 0
    idx = i1(refs, IDX)
    fixed = 0
    if idx.shape[0]:
        fixed = _net_step(
            pos, idx, f2(refs, STATE), f2(refs, LIMITS), b1(refs, LOCKED), corrected, i1(refs, COUNTS), h,
            f2(refs, GAINS), i1(refs, STARTS),
        )  # fmt: skip
    compose_joints(pos, i1(refs, J_STARTS), i1(refs, J_COLS), f1(refs, J_COEFS), f1(refs, J_OFFSET), q)
    jidx = i1(refs, J_IDX)
    if jidx.shape[0]:
        composed = f1(refs, COMPOSED)
        for k in range(jidx.shape[0]):
            composed[k] = q[jidx[k]]
        jcorrected = b1(refs, J_CORRECTED)
        if _net_step(
            q, jidx, f2(refs, J_STATE), f2(refs, J_LIMITS), b1(refs, J_LOCKED), jcorrected, i1(refs, J_COUNTS),
            h, f2(refs, GAINS), i1(refs, STARTS),
        ):  # fmt: skip
            fixed += 1
            own, m = i1(refs, OWN), 0
            for k in range(jidx.shape[0]):  # SafetyNet._carry_back
                g = jidx[k]
                if jcorrected[g] and own[g] >= 0:
                    c = own[g]
                    pos[c] += q[g] - composed[k]
                    corrected[c] = True
                    carried[m] = c
                    m += 1
            carried_n[0] = m
    last = f2(refs, LAST)
    vel, acc, jerk = buf[VELOCITY], buf[ACCELERATION], buf[JERK]
    derivatives(pos, last[0], last[1], last[2], dt, seq, vel, acc, jerk)
    for c in range(n):
        last[0, c], last[1, c], last[2, c] = pos[c], vel[c], acc[c]
    return fixed


#: The kernel, loaded once per process on a thread of its own (started by an engine's second tick).
TAIL = LazyEntry(frame_tail, TAIL_SIG, "frame-tail")


class FrameTail:
    """The tail of one engine's ticks over its safety net: the compiled kernel on a plain tick (see the
    module doc), the Python path otherwise; and the record of the last requests and joints that
    explains a corrected frame (`explain`). `compiled=False` (the blocks' numpy references) or
    `NUTTY_CORE=0` keep the Python path on every tick, for comparisons."""

    def __init__(self, net: SafetyNet, compiled: bool = True):
        n_channels = net.emb.n_channels
        self.net = net
        self.fused = fused = compiled and core_enabled()
        # the compiled finite differences of the Python path (None: numpy's)
        self._derivatives = entry_point(derivatives, DERIVATIVES_SIG) if compiled else None
        self.shape = (BUFFER_ROWS, n_channels)
        self.table = AddressTable(TABLE_ROWS)
        #: The last frame's position, velocity and acceleration, which the next tick differentiates from.
        self.last = np.zeros((3, n_channels))
        self._made: np.ndarray | None = None  # the position array the kernel last made
        self._generation = -1
        self._kernel = LoadOnSecondAsk(TAIL)
        self._checked: tuple[object, object] = (None, None)  # the frames `takes` last found readable
        self._n_joints = len(net.joints.names)
        #: The requests handed to the net and the joints it delivered on the last 3 ticks (newest first),
        #: and the same before the last tick (what explains the last frame).
        self.past: tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]] = ((), ())
        self.before = self.past
        self.restart(net.emb.rest)
        if fused:
            self._list(net)

    def _list(self, net: SafetyNet) -> None:
        j, put = net.joints, self.table.put_at
        for row, array in (
            (IDX, net.idx),
            (LIMITS, net.limits),
            (CORRECTED, net.corrected),
            (COUNTS, net.corrections),
            (GAINS, net._gains),
            (STARTS, net._starts),
            (J_STARTS, j.starts),
            (J_COLS, j.cols),
            (J_COEFS, j.coefs),
            (J_OFFSET, j.offset),
            (J_IDX, net._jidx),
            (J_LIMITS, net._jlimits),
            (J_CORRECTED, net.joint_corrected),
            (J_COUNTS, net.joint_corrections),
            (OWN, j.own),
            (CARRIED, net.carried),
            (CARRIED_N, net.carried_n),
            (COMPOSED, np.zeros(len(net._jidx))),
            (LAST, self.last),
        ):
            put(row, array)
        self._bind_state()

    def _bind_state(self) -> None:
        """List the net's state arrays, which its `reset` replaces."""
        net, put = self.net, self.table.put_at
        put(STATE, net.state)
        put(LOCKED, net._locked)
        put(J_STATE, net._jstate)
        put(J_LOCKED, net._jlocked)
        self._generation = net.generation

    def restart(self, position: np.ndarray) -> None:
        """The net was reset at `position` (C,): the explanations start from there."""
        self.past = self.before = ((position,) * 3, (self.net.joint_out,) * 3)

    def ready(self) -> bool:
        """Whether the kernel has loaded; the second ask (an engine's second tick) starts loading it."""
        return TAIL.entry is not None or self._kernel.ready()

    def takes(self, final: np.ndarray, stage1: np.ndarray) -> bool:
        """Whether the kernel can read these frames (the entry point checks types, not shapes): float64,
        1-D, contiguous, one value per channel. Checked once per array object (the APU hands out the
        same arrays tick after tick)."""
        if final is self._checked[0] and stage1 is self._checked[1]:
            return True
        n = self.shape[1]
        ok = all(
            type(a) is np.ndarray and a.dtype == np.float64 and a.shape == (n,) and a.flags.c_contiguous
            for a in (final, stage1)
        )
        if ok:
            self._checked = (final, stage1)
        return ok

    def run(
        self,
        final: np.ndarray,
        stage1: np.ndarray,
        last: tuple[np.ndarray, np.ndarray, np.ndarray],
        dt: float,
        seq: int,
        requested: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, ...]:
        """One tick's frame arrays, new ones: (program, requested, position, velocity, acceleration,
        jerk, stage 1). `final` (C,) is the program's frame; `requested` (program, target), when given,
        are that frame with the engine's overrides and swap transition applied (new arrays). `last` is
        the engine's last position, velocity and acceleration. The net's `joint_out`, `corrected_any`
        and `corrected_ticks` are as `SafetyNet.step` leaves them."""
        checked = self._checked  # (`ready` and `takes` inline for the steady case: they run every tick)
        if (
            requested is None
            and self.fused
            and self.net.enabled
            and (TAIL.entry is not None or self.ready())
            and ((final is checked[0] and stage1 is checked[1]) or self.takes(final, stage1))
        ):
            program, pos, vel, acc, jerk, s1 = self._fused(final, stage1, last, dt, seq)
            return program, program, pos, vel, acc, jerk, s1
        if requested is None:
            program = target = np.array(final, dtype=float)
        else:
            program, target = requested
        pos = self.net.step(target)
        self._remember(target)
        if self._derivatives is not None and pos.shape == last[0].shape and pos.dtype == np.float64:
            vel, acc, jerk = np.empty_like(pos), np.empty_like(pos), np.empty_like(pos)
            self._derivatives(pos, *last, dt, seq, vel, acc, jerk)
        else:
            vel = (pos - last[0]) / dt if seq else np.zeros_like(pos)
            acc = (vel - last[1]) / dt if seq > 1 else np.zeros_like(pos)
            jerk = (acc - last[2]) / dt if seq > 2 else np.zeros_like(pos)
        return program, target, pos, vel, acc, jerk, np.array(stage1, dtype=float)

    def _fused(
        self, final: np.ndarray, stage1: np.ndarray, last: tuple[np.ndarray, ...], dt: float, seq: int
    ) -> tuple[np.ndarray, ...]:
        """The kernel's tick: the rows `PROGRAM` … `STAGE1` of one new buffer."""
        net = self.net
        if net.generation != self._generation:
            self._bind_state()
        if last[0] is not self._made:  # the last frame came from the Python path (or a reset)
            self.last[0], self.last[1], self.last[2] = last
        buf = np.empty(self.shape)
        q = np.empty(self._n_joints)
        fixed = TAIL.entry(self.table.table, final, stage1, buf, q, net.h, dt, seq)
        net.joint_out = q
        net.corrected_any = fixed > 0
        if fixed:
            net.corrected_ticks += 1
        rows = tuple(buf)
        self._made = rows[POSITION]
        past = self.before = self.past  # (`_remember`, inline: this runs every tick)
        self.past = ((rows[PROGRAM], *past[0][:2]), (q, *past[1][:2]))
        return rows

    def _remember(self, requested: np.ndarray) -> None:
        """This tick's request to the net and the joints it delivered, for the explanations of the next
        two ticks (`before`: the last three ticks' before this one)."""
        past = self.before = self.past
        self.past = ((requested, *past[0][:2]), (self.net.joint_out, *past[1][:2]))

    def explain(self, frame: AnimationFrame) -> None:
        """Say on a corrected `frame`, the one `run` made last, what the net changed (`frame.net`)."""
        frame.net = net_correction(frame, self.net.emb, self.net.joints, *self.before)
