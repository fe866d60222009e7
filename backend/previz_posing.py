"""The Pre-Viz side of the clip editor's preview: show a preview pose, and turn a link about its joint.

`PreviewPosing` belongs to a `backend.previz.PreViz`. While a preview is leased (`set`), the solid robot
shows the preview pose with a label saying the robot is not moving, and the ghost shows the live robot.
A click on a link of the solid robot (from a trusted client, while a preview shows) puts a rotation ring
on the nearest joint above it that a DoF of the robot drives directly; turning the ring sets that DoF to
its value at the click plus the angle turned (rad, clamped by the server), reported through `on_grab`.

The ring is viser's transform gizmo turned so its local x axis is the joint's axis, with only the ring
about x left active: a turn of θ about the joint is then the gizmo's rotation about its own x.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from backend.engine.embodiment import DofType
from backend.engine.joint_frames import joint_frames
from backend.previz_pose import _quat_from_matrix

PREVIEW_COLOUR = (255, 170, 60)


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def turn_about_x(q0: np.ndarray, q: np.ndarray) -> float:
    """The angle (rad, in (-π, π]) a frame turned about its own x axis from orientation q0 to q
    (quaternions w, x, y, z); any part of the turn about other axes is ignored."""
    rel = _quat_mul(np.array([q0[0], -q0[1], -q0[2], -q0[3]]), np.asarray(q, dtype=float))
    angle = 2.0 * math.atan2(float(rel[1]), float(rel[0]))
    return (angle + math.pi) % (2 * math.pi) - math.pi if abs(angle) > math.pi else angle


def axis_frame(axis: np.ndarray) -> np.ndarray:
    """A rotation matrix whose first column is `axis` (unit), completed to a right-handed frame."""
    x = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    helper = np.array([0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    y = np.cross(helper, x)
    y /= np.linalg.norm(y)
    return np.column_stack([x, y, np.cross(x, y)])


class PreviewPosing:
    """The preview pose of one PreViz (`pv`) and its link grab ring."""

    def __init__(self, pv: Any):
        self.pv = pv
        self.emb = pv.emb
        self.vector: np.ndarray | None = None
        self.until = 0.0
        #: Called with (dof, value) when a trusted client turns the ring; set by the server (or the child).
        self.on_grab: Callable[[str, float], None] | None = None
        self._lock = threading.Lock()
        self._grab: tuple[str, np.ndarray, float] | None = None  # (dof, gizmo's wxyz at grab, value then)
        self._ring: Any = None
        self.label = pv.server.scene.add_label(
            "/preview_label", "", position=(0.0, 0.0, 0.5), anchor="bottom-center", font_screen_scale=0.9
        )
        self._link_dof = self._links_to_dofs()
        self._attach_clicks()

    # --- which DoF a link turns ---------------------------------------------------------------------
    def _links_to_dofs(self) -> dict[str, tuple[str, str]]:
        """link -> (DoF, joint): the DoF driving the nearest moving joint above the link by itself."""
        by_joint = {d.joint: d.name for d in self.emb.dofs if d.joint and d.type is DofType.continuous}
        frames = joint_frames(self.emb)
        out: dict[str, tuple[str, str]] = {}
        for joint, info in frames.items():
            owner: str | None = joint
            while owner is not None and owner not in by_joint:
                owner = frames[owner]["parent_joint"]
            if owner is None or frames[owner]["type"] not in ("revolute", "continuous"):
                continue
            for link in info["links"]:
                out[link] = (by_joint[owner], owner)
        return out

    def _attach_clicks(self) -> None:
        scene = self.pv._urdf.scene
        if scene is None:
            return
        parents = scene.graph.transforms.parents
        meshes = getattr(self.pv.robot, "_meshes", [])
        for geometry, handle in zip(scene.geometry, meshes):
            link = parents.get(geometry)
            if link in self._link_dof:
                handle.on_click(lambda event, link=link: self.click(link, getattr(event, "client_id", None)))

    # --- the preview pose ---------------------------------------------------------------------------
    def set(self, vector: Any, label: str, lease: float) -> None:
        with self._lock:
            if vector is None:
                self.vector, self.until = None, 0.0
            else:
                self.vector = np.asarray(vector, dtype=float).copy()
                self.until = time.monotonic() + float(lease)
        self.label.text = f"Preview: {label} (the robot is not moved)" if vector is not None else ""
        if vector is None:
            self._drop_ring()

    def current(self) -> np.ndarray | None:
        """The preview pose's channel vector while its lease runs, else None (and the label goes)."""
        with self._lock:
            if self.vector is not None and time.monotonic() < self.until:
                return self.vector
            lapsed = self.vector is not None
            self.vector = None
        if lapsed:
            self.label.text = ""
            self._drop_ring()
        return None

    # --- the grab ring ------------------------------------------------------------------------------
    def click(self, link: str, client_id: int | None) -> str | None:
        """A click on `link`: the ring on its joint (only a trusted client's, while a preview shows);
        returns the DoF the ring turns, or None."""
        if client_id is None or client_id not in self.pv.trusted_clients or link not in self._link_dof:
            return None
        vector = self.current()
        if vector is None:
            return None
        dof, joint = self._link_dof[link]
        self.grab(dof, joint, vector)
        if self.on_grab is not None:  # the editor's pose panel marks the DoF the ring turns
            self.on_grab(dof, float(vector[self.emb.dof(dof).channels.start]))
        return dof

    def grab(self, dof: str, joint: str, vector: np.ndarray) -> str:
        urdf = self.pv._urdf
        cfg = self.pv._cfg(vector)
        urdf.update_cfg(cfg)
        model_joint = urdf.joint_map[joint]
        pose = urdf.get_transform(model_joint.child)
        axis = np.asarray(model_joint.axis if model_joint.axis is not None else [1.0, 0.0, 0.0], dtype=float)
        wxyz = _quat_from_matrix(pose[:3, :3] @ axis_frame(axis))
        self._drop_ring()
        self._ring = self.pv.server.scene.add_transform_controls(
            "/robot/pose_ring",
            scale=0.12,
            position=tuple(pose[:3, 3]),
            wxyz=tuple(wxyz),
            active_axes=(False, True, True),  # the ring about x lies in the y-z plane
            disable_axes=True,
            disable_sliders=True,
            depth_test=False,
        )
        value = float(vector[self.emb.dof(dof).channels.start])
        self._grab = (dof, wxyz, value)
        self._ring.on_update(
            lambda event: self.turn(np.asarray(self._ring.wxyz), getattr(event, "client_id", None))
        )
        return dof

    def turn(self, wxyz: np.ndarray, client_id: int | None) -> float | None:
        """The ring turned to orientation `wxyz`: the grabbed DoF's new value (sent to `on_grab`)."""
        grab = self._grab
        if grab is None or client_id is None or client_id not in self.pv.trusted_clients:
            return None
        dof, q0, value0 = grab
        d = self.emb.dof(dof)
        value = min(max(value0 + turn_about_x(q0, wxyz), d.min), d.max)
        with self._lock:
            if self.vector is not None:
                self.vector[d.channels] = value  # shown at once; the editor's next preview confirms it
        if self.on_grab is not None:
            self.on_grab(dof, value)
        return value

    def _drop_ring(self) -> None:
        ring, self._ring, self._grab = self._ring, None, None
        if ring is not None:
            ring.remove()
