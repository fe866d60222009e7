"""Rotation maths of the importers: quaternions (x, y, z, w), vectorised over leading axes.

- `quat_*`: product, conjugate, axis-angle, matrix conversions, slerp, rotation vectors;
- `swing_twist` / `twist_angle`: the rotation about one axis (twist) and the rest (swing);
- `davenport`: angles about two or three given axes applied in order (generalised Euler angles),
  q = R(n1, a1) R(n2, a2) [R(n3, a3)], the way a chain of joints composes at rest (product of
  exponentials with the axes expressed in the robot's world frame at rest);
- `axis_conversion`: the rotation taking a source's axes (up, forward) to the robot's (+Z up, +X
  forward);
- `principal_axis`: the axis a series of rotations turns about most.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


class RotationError(ValueError):
    """Bad axes or rotations (no direction, parallel axes)."""


def unit(v: ArrayLike) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(3)
    n = float(np.linalg.norm(v))
    if not math.isfinite(n) or n < 1e-12:
        raise RotationError(f"axis {v.tolist()} has no direction")
    return v / n


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b of quaternions (..., 4) in x, y, z, w order."""
    ax, ay, az, aw = np.moveaxis(np.asarray(a, dtype=float), -1, 0)
    bx, by, bz, bw = np.moveaxis(np.asarray(b, dtype=float), -1, 0)
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def quat_conj(q: np.ndarray) -> np.ndarray:
    return np.asarray(q, dtype=float) * np.array([-1.0, -1.0, -1.0, 1.0])


def quat_normalise(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    return q / np.where(n == 0, 1.0, n)


def quat_axis_angle(axis: ArrayLike, angle: np.ndarray | float) -> np.ndarray:
    """Quaternions (x, y, z, w) for rotations by `angle` (rad, scalar or (N,)) about `axis`."""
    axis = unit(axis)
    half = 0.5 * np.asarray(angle, dtype=float)
    s = np.sin(half)[..., None]
    return np.concatenate([s * axis, np.cos(half)[..., None]], axis=-1)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of quaternions (..., 4) (normalised first)."""
    x, y, z, w = np.moveaxis(quat_normalise(q), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def quat_from_matrix(m: np.ndarray) -> np.ndarray:
    """Quaternions (..., 4) of rotation matrices (..., 3, 3); any scale or shear is removed first
    (the nearest rotation, by SVD)."""
    m = np.asarray(m, dtype=float)
    u, _, vt = np.linalg.svd(m)
    r = u @ vt
    det = np.linalg.det(r)
    if np.any(det < 0):  # a mirror: flip the smallest singular direction
        u = u.copy()
        u[..., :, -1] *= np.sign(det)[..., None]
        r = u @ vt
    flat = r.reshape(-1, 3, 3)
    out = np.empty((flat.shape[0], 4))
    for i, a in enumerate(flat):
        tr = a[0, 0] + a[1, 1] + a[2, 2]
        if tr > 0:
            s = math.sqrt(tr + 1.0) * 2
            out[i] = [(a[2, 1] - a[1, 2]) / s, (a[0, 2] - a[2, 0]) / s, (a[1, 0] - a[0, 1]) / s, 0.25 * s]
        elif a[0, 0] > a[1, 1] and a[0, 0] > a[2, 2]:
            s = math.sqrt(1.0 + a[0, 0] - a[1, 1] - a[2, 2]) * 2
            out[i] = [0.25 * s, (a[0, 1] + a[1, 0]) / s, (a[0, 2] + a[2, 0]) / s, (a[2, 1] - a[1, 2]) / s]
        elif a[1, 1] > a[2, 2]:
            s = math.sqrt(1.0 + a[1, 1] - a[0, 0] - a[2, 2]) * 2
            out[i] = [(a[0, 1] + a[1, 0]) / s, 0.25 * s, (a[1, 2] + a[2, 1]) / s, (a[0, 2] - a[2, 0]) / s]
        else:
            s = math.sqrt(1.0 + a[2, 2] - a[0, 0] - a[1, 1]) * 2
            out[i] = [(a[0, 2] + a[2, 0]) / s, (a[1, 2] + a[2, 1]) / s, 0.25 * s, (a[1, 0] - a[0, 1]) / s]
    return quat_normalise(out).reshape((*m.shape[:-2], 4))


def quat_angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle (rad, in [0, pi]) of quaternions (..., 4)."""
    q = np.asarray(q, dtype=float)
    return 2.0 * np.arctan2(np.linalg.norm(q[..., :3], axis=-1), np.abs(q[..., 3]))


def rotation_vectors(q: np.ndarray) -> np.ndarray:
    """Rotation vectors (axis * angle, rad) of quaternions (..., 4), angles in [0, pi]."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., 3:4] < 0, -q, q)
    v = q[..., :3]
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    ang = 2.0 * np.arctan2(n, q[..., 3:4])
    return np.where(n > 1e-15, v / np.where(n == 0, 1.0, n) * ang, 2.0 * v)


def hemisphere(q: np.ndarray) -> np.ndarray:
    """A sequence of quaternions (N, 4) with signs flipped so successive ones have dot >= 0."""
    q = np.array(q, dtype=float, copy=True)
    if len(q) > 1:
        dots = np.sum(q[1:] * q[:-1], axis=1)
        flips = np.cumprod(np.where(dots < 0, -1.0, 1.0))
        q[1:] *= flips[:, None]
    return q


def slerp(a: np.ndarray, b: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Spherical interpolation between quaternions a and b (..., 4) at fractions u (...)."""
    a = quat_normalise(a)
    b = quat_normalise(b)
    u = np.asarray(u, dtype=float)
    d = np.sum(a * b, axis=-1)
    b = np.where(d[..., None] < 0, -b, b)
    d = np.abs(d)
    theta = np.arccos(np.clip(d, -1.0, 1.0))
    s = np.sin(theta)
    small = s < 1e-9
    wa = np.where(small, 1.0 - u, np.sin((1.0 - u) * theta) / np.where(small, 1.0, s))
    wb = np.where(small, u, np.sin(u * theta) / np.where(small, 1.0, s))
    return quat_normalise(wa[..., None] * a + wb[..., None] * b)


# --------------------------------------------------------------------------------------------------
# Swing-twist, Davenport angles
# --------------------------------------------------------------------------------------------------


def swing_twist(q: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split rotations `q` (..., 4) into (swing, twist) with q = swing * twist, twist about `axis`.

    The twist is the projection of the quaternion's vector part onto the axis, renormalised; a
    rotation of exactly 180 degrees about an axis perpendicular to `axis` has no defined twist and
    gets the identity."""
    q = np.asarray(q, dtype=float)
    axis = unit(axis)
    proj = np.sum(q[..., :3] * axis, axis=-1)
    twist = np.concatenate([proj[..., None] * axis, q[..., 3:4]], axis=-1)
    norm = np.linalg.norm(twist, axis=-1, keepdims=True)
    degenerate = norm[..., 0] < 1e-12
    twist = np.where(degenerate[..., None], IDENTITY, twist / np.where(norm == 0, 1, norm))
    swing = quat_mul(q, quat_conj(twist))
    return swing, twist


def twist_angle(q: np.ndarray, axis: np.ndarray, unwrap: bool = True) -> np.ndarray:
    """Angle (rad) of the twist of each rotation `q` (N, 4) about `axis`, in (-pi, pi].

    With `unwrap`, a sequence is made continuous (no 2*pi jumps between successive samples)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    axis = unit(axis)
    s = q[:, :3] @ axis
    w = q[:, 3]
    ang = 2.0 * np.arctan2(s, w)
    ang = (ang + math.pi) % (2 * math.pi) - math.pi
    ang = np.where(np.isclose(ang, -math.pi), math.pi, ang)
    if unwrap and len(ang) > 1:
        ang = np.unwrap(ang)
    return ang


def _rot(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) about a unit axis by angles (N,) (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    s = np.sin(angle)[:, None, None]
    c = np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1 - c) * (k @ k)


def _angle_about(axis: np.ndarray, frm: np.ndarray, to: np.ndarray) -> np.ndarray:
    """Angles (N,) of the rotations about `axis` taking vectors `frm` (N, 3) closest to `to` (N, 3)."""
    fp = frm - (frm @ axis)[:, None] * axis
    tp = to - (to @ axis)[:, None] * axis
    return np.arctan2(np.cross(fp, tp) @ axis, np.sum(fp * tp, axis=1))


def check_axes(axes: list[np.ndarray]) -> None:
    """Consecutive decomposition axes must not be parallel."""
    for a, b in zip(axes, axes[1:]):
        if np.linalg.norm(np.cross(a, b)) < 1e-6:
            raise RotationError(
                f"axes {np.round(a, 4).tolist()} and {np.round(b, 4).tolist()} are parallel; "
                "one rotation cannot be split between them"
            )


def davenport(q: np.ndarray, axes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Angles (N, k) with q ~= R(n1, a1) R(n2, a2) [R(n3, a3)] for k = 2 or 3 unit axes, and the
    angle (N,) of the rotation left over (what k = 2 axes cannot express, or what no angles reach).

    Closed form (Davenport / generalised Euler angles): n1.R.n3 fixes a2 (the solution nearer 0 is
    taken), then a1 and a3 turn the known vectors into place. With two axes the third is n1 x n2 and
    its angle is the leftover. Angle sequences are unwrapped (no 2*pi jumps)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    k = len(axes)
    if k not in (2, 3):
        raise RotationError("a rotation is split between 2 or 3 axes")
    n = [unit(a) for a in axes]
    check_axes(n)
    if k == 2:
        n.append(unit(np.cross(n[0], n[1])))
    n1, n2, n3 = n
    r = quat_to_matrix(q)
    kk = (n1 @ n2) * (n2 @ n3)
    a = n1 @ n3 - kk
    b = n1 @ np.cross(n2, n3)
    amp = math.hypot(a, b)
    if amp < 1e-9:
        raise RotationError("the first and last axes leave the middle angle undetermined")
    c = np.einsum("i,nij,j->n", n1, r, n3)
    phi = math.atan2(b, a)
    x = np.clip((c - kk) / amp, -1.0, 1.0)
    cands = np.stack([phi + np.arccos(x), phi - np.arccos(x)], axis=1)
    cands = (cands + math.pi) % (2 * math.pi) - math.pi
    a2 = cands[np.arange(len(cands)), np.argmin(np.abs(cands), axis=1)]
    r2 = _rot(n2, a2)
    u = r2 @ n3  # (N, 3)
    a1 = _angle_about(n1, u, r @ n3)
    v = np.transpose(r2, (0, 2, 1)) @ n1
    a3 = -_angle_about(n3, v, np.einsum("nji,j->ni", r, n1))
    angles = np.stack([a1, a2, a3], axis=1)
    if len(angles) > 1:
        angles = np.unwrap(angles, axis=0)
    fit = _rot(n1, angles[:, 0]) @ _rot(n2, angles[:, 1])
    if k == 3:
        fit = fit @ _rot(n3, angles[:, 2])
    rest = np.einsum("nji,njk->nik", fit, r)
    left = np.arccos(np.clip((np.trace(rest, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0))
    return angles[:, :k], left


# --------------------------------------------------------------------------------------------------
# Frames
# --------------------------------------------------------------------------------------------------

_AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}


def parse_axis(name: str) -> np.ndarray:
    """`x`, `-y`, `+z` ... -> unit vector."""
    s = str(name).strip().lower()
    sign = -1.0 if s.startswith("-") else 1.0
    s = s.lstrip("+-")
    if s not in _AXES:
        raise RotationError(f"axis must be one of x, y, z, -x, -y, -z, got '{name}'")
    return sign * np.array(_AXES[s], dtype=float)


def axis_conversion(up: str = "y", forward: str = "x") -> np.ndarray:
    """The quaternion C turning source-frame vectors into robot-frame vectors (+X forward, +Y left,
    +Z up): C maps the source's `forward` axis to +X and its `up` axis to +Z.

    up=y, forward=x (glTF's and BVH's +Y up; Blender's exporter keeps +X): (x, y, z) -> (x, -z, y);
    up=z, forward=x: the identity."""
    u = parse_axis(up)
    f = parse_axis(forward)
    if abs(float(u @ f)) > 1e-9:
        raise RotationError(f"the forward axis ({forward}) must be perpendicular to the up axis ({up})")
    m = np.stack([f, np.cross(u, f), u])  # rows: the source vectors that become x, y, z
    return quat_from_matrix(m)


def principal_axis(q: np.ndarray) -> tuple[np.ndarray, float]:
    """(unit axis, share) of rotations (N, 4): the axis of the largest eigenvalue of sum(r r^T) over
    their rotation vectors r, and the share of sum(|r|^2) it explains (1: all about that axis)."""
    r = rotation_vectors(np.atleast_2d(q))
    m = r.T @ r
    total = float(np.trace(m))
    if total < 1e-18:
        return np.array([0.0, 0.0, 1.0]), 1.0
    w, v = np.linalg.eigh(m)
    axis = v[:, -1]
    i = int(np.argmax(np.abs(axis)))
    if axis[i] < 0:
        axis = -axis
    return axis, float(w[-1] / total)
