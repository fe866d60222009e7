"""The safety net's joint stage: the joints the motors receive stay within their limits.

A motor receives a *joint*, not a channel. A joint's value is its own DoF plus every symbolic DoF that
drives it (`embodiment.yaml`'s `drives`): `q = joint_matrix @ channels + joint_offset`. Limiting each
channel bounds nothing about the sum (two channels at their velocity limit in the same direction give
the joint 1.7x its limit; two channels inside their ranges can put it outside its URDF range), so after
the channel stage the net composes the joints and runs the same discrete-time tracker
(`backend.engine.safety._net_step`) on them, with per joint:

- position within the URDF range [lower, upper] (a continuous joint: +-2 pi), velocity within the URDF
  velocity (or the documented default), acceleration and jerk within the joint's own DoF entry (or the
  documented defaults: ACC_PER_VEL x velocity, JERK_PER_ACC x acceleration);
- measured on the finite differences of the delivered joint values at the engine rate;
- exact pass-through when the composition is feasible, correction otherwise, re-lock after.

A correction is carried back onto the joint's own channel (its coefficient is 1), so the frame's
channels still compose into the joints the motors get and the symbolic channels keep their meaning.
A joint with no own channel (driven by symbolic DoFs only) has its delivered value in the frame's
`joints` vector, which is the authority for every driver.

A joint that only its own channel drives (coefficient 1, no offset) and whose channel limits are at
least as tight as the joint's is already guaranteed by the channel stage (the finite differences are
the same numbers): it is composed but not stepped again, which keeps the stage nearly free on robots
without symbolic DoFs.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from backend.engine.dofs import ACC_PER_VEL, JERK_PER_ACC, Dimension, DofType
from backend.engine.embodiment import Embodiment
from backend.engine.net_rows import limit_rows


@njit(cache=True)
def compose_joints(values, starts, cols, coefs, offset, q):
    """q[j] = offset[j] + sum of coefs * values[cols] over joint j's entries (CSR rows `starts`), in place."""
    for j in range(offset.shape[0]):
        s = 0.0
        for e in range(starts[j], starts[j + 1]):
            s += coefs[e] * values[cols[e]]
        q[j] = s + offset[j]


class JointLimits:
    """Each actuated joint's limits and how the channels compose into it (built once per embodiment).

    Arrays over `emb.joint_names`: lower, upper (rad or m), velocity (per s), acceleration (per s^2),
    jerk (per s^3); `own[j]` the joint's own channel (-1: none); CSR rows (`starts`, `cols`, `coefs`)
    of `emb.joint_matrix`; `governed` the joints the joint stage steps (see the module doc).
    """

    def __init__(self, emb: Embodiment, channel_governed: np.ndarray):
        joints = emb.joints
        n = len(joints)
        self.names = list(emb.joint_names)
        self.lower = np.array([j.lower for j in joints], dtype=float)
        self.upper = np.array([j.upper for j in joints], dtype=float)
        self.velocity = np.array([j.velocity for j in joints], dtype=float)
        self.acceleration = ACC_PER_VEL * self.velocity
        self.jerk = JERK_PER_ACC * self.acceleration
        self.own = np.full(n, -1, dtype=np.int64)
        index = {name: i for i, name in enumerate(self.names)}
        for d in emb.dofs:
            if (
                d.dimension is Dimension.stationary
                and d.type is DofType.continuous
                and not d.drives
                and d.joint in index
            ):
                j = index[d.joint]
                self.own[j] = d.channels.start
                # The joint's own DoF entry gives its acceleration and jerk (yaml or its documented defaults).
                self.acceleration[j] = d.acceleration
                self.jerk[j] = d.jerk
        m = emb.joint_matrix
        starts, cols, coefs = [0], [], []
        for j in range(n):
            nz = np.flatnonzero(m[j])
            cols.extend(nz.tolist())
            coefs.extend(m[j, nz].tolist())
            starts.append(len(cols))
        self.starts = np.array(starts, dtype=np.int64)
        self.cols = np.array(cols, dtype=np.int64)
        self.coefs = np.array(coefs, dtype=float)
        self.offset = np.ascontiguousarray(emb.joint_offset, dtype=float)
        finite = (
            np.isfinite(self.velocity)
            & np.isfinite(self.acceleration)
            & np.isfinite(self.jerk)
            & (self.velocity > 0)
            & (self.acceleration > 0)
            & (self.jerk > 0)
        )
        driven = np.diff(self.starts) > 0
        covered = np.array([self._covered_by_channel(emb, j, channel_governed) for j in range(n)], dtype=bool)
        self.governed = np.flatnonzero(finite & driven & ~covered).astype(np.int64)

    def _covered_by_channel(self, emb: Embodiment, j: int, channel_governed: np.ndarray) -> bool:
        """Whether the channel stage alone already keeps joint j within all of its limits."""
        c = int(self.own[j])
        s0, s1 = self.starts[j], self.starts[j + 1]
        if c < 0 or s1 - s0 != 1 or self.cols[s0] != c or self.coefs[s0] != 1.0 or self.offset[j] != 0.0:
            return False
        if not channel_governed[c]:
            return False
        return bool(
            emb.min[c] >= self.lower[j]
            and emb.max[c] <= self.upper[j]
            and emb.vel_limit[c] <= self.velocity[j]
            and emb.acc_limit[c] <= self.acceleration[j]
            and emb.jerk_limit[c] <= self.jerk[j]
        )

    def rows(self) -> np.ndarray:
        """The limits array of the governed joints, by row (`net_rows.LIM_LO` … `LIM_J`), as the net's
        kernel takes them."""
        g = self.governed
        return limit_rows(self.lower[g], self.upper[g], self.velocity[g], self.acceleration[g], self.jerk[g])

    def compose(self, values: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Joint values (rad or m) of a channel vector, unclipped: what the motors would get."""
        q = np.empty(len(self.names)) if out is None else out
        compose_joints(np.asarray(values, dtype=float), self.starts, self.cols, self.coefs, self.offset, q)
        return q
