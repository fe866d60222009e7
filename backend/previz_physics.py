"""The Pre-Viz's *physics* ghost: the robot as the physics preview simulates it (`nutty serve --sim
mujoco`, backend/sim), beside the commanded one. Where the motors cannot follow — gravity, a weak
actuator, a collision — the two part; links in contact flash red.

Built on the first simulated pose, so a Pre-Viz without a simulation pays nothing. Called on the
Pre-Viz's own thread, inside the scene's `atomic()` block.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from backend.previz_pose import UrdfPoser, poser_for, set_if_changed

#: The physics ghost's colour (RGB 0..1) and opacity: warm, so it reads apart from the blue stage-1 ghost.
PHYSICS_COLOUR = (1.0, 0.62, 0.2)
PHYSICS_OPACITY = 0.45
#: A link in contact (RGB 0..255, as viser reports mesh colours).
CONTACT_COLOUR = (235, 40, 40)


def _rgb255(colour: tuple[float, float, float]) -> tuple[int, int, int]:
    r, g, b = (round(255 * c) for c in colour)
    return r, g, b


class PhysicsGhost:
    """A translucent URDF robot posed from simulated joints, with a GUI toggle."""

    def __init__(self, server: Any, urdf_path: str, order: np.ndarray | None):
        self._server = server
        self._urdf_path = urdf_path
        self._order = order  # emb.joint_names index per viser joint, or None when they agree
        self._robot: Any = None
        self._poser: UrdfPoser | None = None
        self._base: Any = None
        self._meshes: list[tuple[Any, str]] = []  # (handle, link)
        self._touching: frozenset[str] = frozenset()
        self._toggle: Any = None

    @property
    def built(self) -> bool:
        return self._robot is not None

    @property
    def visible(self) -> bool:
        return self._base is not None and bool(self._base.visible)

    @property
    def touching(self) -> tuple[str, ...]:
        """The links flashed now (in contact in the simulation)."""
        return tuple(sorted(self._touching))

    def set_visible(self, visible: bool) -> None:
        if self._base is not None:
            self._base.visible = bool(visible)
        if self._toggle is not None and self._toggle.value != bool(visible):
            self._toggle.value = bool(visible)

    def _build(self) -> Any:
        import yourdfpy  # heavy: only where used
        from viser.extras import ViserUrdf  # heavy: only where used

        urdf = yourdfpy.URDF.load(self._urdf_path, build_scene_graph=True, load_meshes=True)
        self._base = self._server.scene.add_frame("/physics", show_axes=False)
        self._robot = ViserUrdf(
            self._server,
            urdf,
            root_node_name="/physics/body",
            mesh_color_override=(*PHYSICS_COLOUR, PHYSICS_OPACITY),
        )
        self._poser = poser_for(self._robot)  # ViserUrdf's own update_cfg costs ~14 ms a frame
        # ViserUrdf names a link's mesh node after the link's frame: ".../<link>/<geometry>"
        self._meshes = [(mesh, mesh.name.rsplit("/", 2)[-2]) for mesh in self._robot._meshes]
        self._toggle = self._server.gui.add_checkbox("Show physics (simulated)", initial_value=True)
        self._toggle.on_update(lambda _: self.set_visible(self._toggle.value))
        return self._robot

    def show(self, joints: np.ndarray, touching: tuple[str, ...], base: Any = None) -> None:
        """Pose the ghost at `joints` (emb.joint_names order, rad or m); flash the links in `touching`;
        `base`: the solid robot's base (position, wxyz), which the simulation's base follows."""
        robot = self._robot if self._robot is not None else self._build()
        if not self.visible:
            return
        q = np.asarray(joints, dtype=float)
        cfg = q[self._order] if self._order is not None else q
        if self._poser is not None:
            self._poser.update(cfg)
        else:
            robot.update_cfg(cfg)
        if base is not None:
            set_if_changed(self._base, "position", base[0])
            set_if_changed(self._base, "wxyz", base[1])
        now = frozenset(touching)
        if now != self._touching:
            calm = _rgb255(PHYSICS_COLOUR)
            for mesh, link in self._meshes:
                mesh.color = CONTACT_COLOUR if link in now else calm
            self._touching = now
