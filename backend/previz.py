"""The 3D Pre-Viz (viser): the URDF robot posed live from the engine's Animation Frames.

- Symbolic DoFs are resolved to joints (`Embodiment.joint_positions`); spatial DoFs move the base.
- Display DoFs are visible: LED colours as lit spheres at their links, the face expression as a label.
- Speech and sounds appear as captions for a few seconds.
- The paper's *ghost*: a translucent second robot shows the stage-1 (unfiltered) pose; switchable.
- A draggable gaze target sets the program's `gaze_target` input when the program declares one.
- Updates run on the Pre-Viz sink's own thread at <= 60 Hz; a stale frame is dropped, never queued,
  so the engine clock never waits for viser.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any

import numpy as np

from backend.engine.embodiment import DofType
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink

MAX_RATE = 60.0
CAPTION_SECONDS = 4.0
GHOST_COLOUR = (0.45, 0.75, 1.0, 0.35)


def _yaw_pitch_roll_to_wxyz(yaw: float, pitch: float, roll: float) -> tuple[float, float, float, float]:
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)


class PreViz:
    """A viser server showing a session's robot. `start()` attaches it to the engine as a sink."""

    def __init__(self, session: Any, host: str = "127.0.0.1", port: int = 8080):
        import viser
        import yourdfpy
        from viser.extras import ViserUrdf

        self.session = session
        self.emb = session.embodiment
        self.host, self.port = host, port
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.server.scene.set_up_direction("+z")
        self.server.scene.add_grid("/grid", width=2.0, height=2.0, cell_size=0.1, plane="xy", position=(0, 0, 0))
        urdf = yourdfpy.URDF.load(str(self.emb.urdf_path), build_scene_graph=True, load_meshes=True)
        self._urdf = urdf
        self.base = self.server.scene.add_frame("/robot", show_axes=False)
        self.robot = ViserUrdf(self.server, urdf, root_node_name="/robot/body")
        ghost_urdf = yourdfpy.URDF.load(str(self.emb.urdf_path), build_scene_graph=True, load_meshes=True)
        self.ghost_base = self.server.scene.add_frame("/ghost", show_axes=False)
        self.ghost = ViserUrdf(self.server, ghost_urdf, root_node_name="/ghost/body", mesh_color_override=GHOST_COLOUR)
        names = self.robot.get_actuated_joint_names()
        index = {n: i for i, n in enumerate(self.emb.joint_names)}
        self._order = np.array([index[n] for n in names], dtype=int) if all(n in index for n in names) else None
        self._leds = self._add_leds()
        self._face = self._add_face_label()
        self._caption = self.server.scene.add_label("/caption", "", position=(0.0, 0.0, 0.62), anchor="bottom-center",
                                                    font_screen_scale=1.1)
        self._caption_until = 0.0
        gui = self.server.gui
        self.ghost_toggle = gui.add_checkbox("Show ghost (stage 1)", initial_value=True)
        self.ghost_toggle.on_update(lambda _: self.set_ghost(self.ghost_toggle.value))
        self.status = gui.add_markdown("")
        self.gaze = self.server.scene.add_transform_controls("/gaze_target", scale=0.12, position=(0.6, 0.0, 0.35),
                                                             disable_rotations=True)
        self.server.scene.add_icosphere("/gaze_target/ball", radius=0.02, color=(255, 200, 40))
        self.gaze.on_update(lambda _: self._on_gaze_drag())
        self._sink: Sink | None = None
        self.frames_shown = 0
        self._lock = threading.Lock()
        self._set_camera_on_connect()

    # --- scene pieces ---------------------------------------------------------------------------
    def _link_node(self, link: str, root: str = "/robot/body") -> str | None:
        from viser.extras._urdf import _viser_name_from_frame  # the node names ViserUrdf gives links

        scene = self._urdf.scene
        if scene is None or link not in scene.graph.nodes:
            return None
        return _viser_name_from_frame(scene, link, f"{root}/visual")

    def _add_leds(self) -> list[tuple[slice, list[Any]]]:
        leds = []
        for d in self.emb.dofs:
            if d.type is not DofType.colour:
                continue
            handles = []
            for link in d.links:
                node = self._link_node(link)
                if node is None:
                    continue
                handles.append(self.server.scene.add_icosphere(f"{node}/led_{d.name}", radius=0.0225,
                                                               color=(255, 255, 255), material="toon3",
                                                               cast_shadow=False))
            if handles:
                leds.append((d.channels, handles))
        return leds

    def _add_face_label(self) -> tuple[slice, tuple[str, ...], Any] | None:
        for d in self.emb.dofs:
            if d.type is DofType.enum and d.options:
                node = self._link_node(d.links[0]) if d.links else None
                parent = node or "/robot"
                label = self.server.scene.add_label(f"{parent}/face_{d.name}", "", position=(0.03, 0.0, -0.03),
                                                    anchor="top-center", font_screen_scale=0.8)
                return d.channels, d.options, label
        return None

    def _set_camera_on_connect(self) -> None:
        @self.server.on_client_connect
        def _(client) -> None:  # a three-quarter view that frames the desk robot
            client.camera.position = (0.62, 0.42, 0.48)
            client.camera.look_at = (0.0, 0.0, 0.27)

    # --- live updates -----------------------------------------------------------------------------
    def set_ghost(self, visible: bool) -> None:
        self.ghost_base.visible = bool(visible)
        if self.ghost_toggle.value != bool(visible):
            self.ghost_toggle.value = bool(visible)

    @property
    def ghost_visible(self) -> bool:
        return bool(self.ghost_base.visible)

    def _on_gaze_drag(self) -> None:
        prog = self.session.program
        if prog is None or prog.input("gaze_target") is None:
            return
        try:
            self.session.set_input("gaze_target", [float(v) for v in self.gaze.position])
        except ValueError:
            pass

    def _cfg(self, values: np.ndarray) -> np.ndarray:
        q = self.emb.joint_positions(values)
        return q[self._order] if self._order is not None else q

    def show(self, frame: AnimationFrame) -> None:
        """Pose both robots and the displays from one frame (called on the sink thread)."""
        with self._lock, self.server.atomic():
            self.robot.update_cfg(self._cfg(frame.position))
            base = self.emb.base_pose(frame.position)
            self.base.position = (base["x"], base["y"], base["z"])
            self.base.wxyz = _yaw_pitch_roll_to_wxyz(base["yaw"], base["pitch"], base["roll"])
            if self.ghost_visible and frame.stage1 is not None:
                self.ghost.update_cfg(self._cfg(frame.stage1))
                gb = self.emb.base_pose(frame.stage1)
                self.ghost_base.position = (gb["x"], gb["y"], gb["z"])
            for channels, handles in self._leds:
                rgb = tuple(int(round(255 * min(max(c, 0.0), 1.0))) for c in frame.position[channels])
                for h in handles:
                    h.color = rgb
            if self._face is not None:
                channels, options, label = self._face
                k = int(round(float(frame.position[channels.start])))
                label.text = options[min(max(k, 0), len(options) - 1)]
            now = time.monotonic()
            for ev in frame.events:
                text = ev.payload.get("text") or ev.payload.get("clip") or ev.kind
                self._caption.text = f"🔊 {text}" if ev.kind != "say" else f"“{text}”"
                self._caption_until = now + CAPTION_SECONDS
            if self._caption_until and now > self._caption_until:
                self._caption.text = ""
                self._caption_until = 0.0
            self.frames_shown += 1

    def start(self) -> "PreViz":
        rate = self.session.engine.rate
        decimate = max(1, int(math.ceil(rate / MAX_RATE)))
        self._sink = self.session.engine.add_sink(Sink("previz", self.show, max_queue=1, decimate=decimate))
        return self

    def url(self, host: str | None = None) -> str:
        return f"http://{host or self.host}:{self.port}"

    def stop(self) -> None:
        if self._sink is not None:
            self.session.engine.remove_sink(self._sink)
            self._sink = None
        self.server.stop()
