"""The 3D Pre-Viz (viser): the URDF robot posed live from the engine's Animation Frames.

- The solid robot shows the joints the motors get (the frame's `joints`: symbolic DoFs resolved and
  limited by the safety net's joint stage); spatial DoFs move the base.
- Display DoFs are visible: LED colours as lit spheres at their links, the face expression as a label.
- Speech and sounds appear as captions for a few seconds.
- The paper's *ghost*: a translucent second robot shows the stage-1 (unfiltered) pose; switchable.
- With a physics preview (`--sim mujoco`), a warm *physics* ghost shows the simulated robot and flashes
  links in contact (`backend.previz_physics`); switchable.
- The clip editor's preview pose takes the solid robot while its lease runs (the ghost then shows the
  live robot), and a link can be turned about its joint to pose it (`backend.previz_posing`).
- A draggable gaze target sets the program's `gaze_target` input when the program declares one.
- Updates run on the Pre-Viz sink's own thread at <= 60 Hz; a stale frame is dropped, never queued,
  so the engine clock never waits for viser. Only the joint frames that moved are sent to viser
  (`backend.previz_pose.UrdfPoser`, ~5x cheaper than re-posing the whole URDF each frame).

Safety: viser itself has no authentication and its gaze gizmo moves the robot, so it only ever
listens on 127.0.0.1. Browsers reach it through the API port (`/previz/`: `fetch_page` and
`relay_socket` in backend/previz_proxy.py), behind the API's Origin/Host checks and token. Its own
loopback port refuses WebSocket clients whose Origin or Host is foreign (a web page the user happens
to visit could otherwise connect to ws://127.0.0.1:8080 and drag the gaze), and gaze drags count only
from clients that passed that check or came through the proxy. When the server has a token
(`proxy_only`), the loopback port serves nobody but the proxy: every other WebSocket is closed, so
the token cannot be walked around through this port. A drag travels the server's command path
(`set_gaze`, via `run_command`): authorised and logged like REST.
"""

from __future__ import annotations

import contextlib
import logging
import math
import secrets
import threading
import time
from typing import Any

import numpy as np

from backend.drivers.readings import physics_source
from backend.engine.embodiment import DofType
from backend.engine.frames import AnimationFrame
from backend.engine.kinematics import yaw_pitch_roll_quat
from backend.engine.runtime import Sink
from backend.errors import DomainError
from backend.previz_physics import PhysicsGhost
from backend.previz_pose import poser_for, set_if_changed
from backend.previz_posing import PreviewPosing

# The API's /previz/ proxy lives in backend.previz_proxy; its names stay importable from here.
from backend.previz_proxy import (  # noqa: F401 (re-exported: callers import them from here)
    EMBED_STYLE,
    MAX_PAGE,
    MAX_PREVIZ_MESSAGE,
    PROXY_HEADER,
    embed_page,
    fetch_page,
    relay_socket,
)
from backend.security import LOOPBACK_NAMES, AccessPolicy
from backend.session import EngineSession

log = logging.getLogger(__name__)


# The camera looks at the robot from its front-left, a little above (a three-quarter view).
CAMERA_DIRECTION = (0.62, 0.42, 0.21)
CAMERA_FOV = 75.0 * math.pi / 180.0  # viser's default (vertical) field of view
CAMERA_MARGIN = 1.1

MAX_RATE = 60.0
CAPTION_SECONDS = 4.0
GHOST_COLOUR = (0.45, 0.75, 1.0, 0.35)
# The Pre-Viz background per editor theme: the editor's page background (--bg) in each (RGB, 0..255).
THEME_BACKGROUNDS = {"dark": (20, 23, 28), "light": (243, 244, 246)}


def framing(
    bounds: Any,
    direction: tuple[float, float, float] = CAMERA_DIRECTION,
    fov: float = CAMERA_FOV,
    margin: float = CAMERA_MARGIN,
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """(camera position, look-at point) that frame a box `bounds` ([[x0, y0, z0], [x1, y1, z1]], metres):
    from `direction`, far enough that the box's bounding sphere fits the field of view with `margin`."""
    lo, hi = np.asarray(bounds, dtype=float)
    centre = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 0.05)
    d = np.asarray(direction, dtype=float)
    d /= np.linalg.norm(d)
    distance = margin * radius / math.sin(fov / 2)
    position = centre + d * distance
    px, py, pz = (round(float(v), 4) for v in position)
    cx, cy, cz = (round(float(v), 4) for v in centre)
    return (px, py, pz), (cx, cy, cz)


def check_loopback(host: str) -> None:
    """Raise ValueError unless `host` is a loopback name (viser has no authentication)."""
    if host not in LOOPBACK_NAMES:
        raise ValueError(
            f"the Pre-Viz listens on loopback only, not {host!r}: "
            "it is served to the network through the API's /previz/ (behind its token)"
        )


def attach_previz_sink(session: EngineSession, show: Any) -> Sink:
    """The Pre-Viz sink: `show(frame)` on its own thread, at most MAX_RATE frames per second, a stale
    frame dropped (never queued)."""
    decimate = max(1, math.ceil(session.engine.rate / MAX_RATE))
    return session.engine.add_sink(Sink("previz", show, max_queue=1, decimate=decimate))


def gaze_from_drag(session: EngineSession, run_command: Any, target: list[float]) -> bool:
    """A gizmo drag's target, as a `set_gaze` command through `run_command` (the server's command path:
    validated, logged, evented like REST) when there is one, else straight to the input. Whether the
    gaze was set (a refused command is logged by the command path, and changes nothing)."""
    if run_command is None:
        return set_gaze_input(session, target)
    try:
        run_command({"type": "set_gaze", "target": [float(v) for v in target]})
    except Exception as exc:  # nothing moved, and the Pre-Viz's link to the server must go on
        if isinstance(exc, DomainError):  # the command path refused it: no gaze input, out of reach
            log.info("Pre-Viz gaze drag refused: %s", exc.detail)
        else:
            log.warning("Pre-Viz gaze drag failed: %s", exc, exc_info=True)
        return False
    return True


def set_gaze_input(session: EngineSession, target: list[float]) -> bool:
    """Set `session`'s `gaze_target` input to a dragged target; False when its program has none or
    refuses the value."""
    prog = session.program
    if prog is None or prog.input("gaze_target") is None:
        return False
    try:
        session.set_input("gaze_target", target)
    except ValueError:
        return False
    return True


class PreViz:
    """A viser server showing a session's robot. `start()` attaches it to the engine as a sink."""

    def __init__(
        self,
        session: Any,  # an EngineSession, or the child process's stand-in for one
        host: str = "127.0.0.1",
        port: int = 8080,
        allowed_origins: list[str] | None = None,
        proxy_secret: str | None = None,
        proxy_only: bool = False,
    ):
        import viser  # heavy: only where used
        import yourdfpy  # heavy: only where used
        from viser.extras import ViserUrdf  # heavy: only where used

        check_loopback(host)
        self.session = session
        self.emb = session.embodiment
        self.host = host
        # marks connections that came through the API's proxy
        self.proxy_secret = proxy_secret or secrets.token_urlsafe(24)
        self._trusted: set[int] = set()  # viser client ids whose gaze drags count
        self._allowed_origins = list(allowed_origins or [])
        #: Only connections through the API's proxy are served (the server has a token: its /previz/
        #: checks it; a direct connection to this port would walk around it).
        self.proxy_only = bool(proxy_only)
        #: Runs a gizmo drag as a command ({"type": "set_gaze", ...}) on the server's command path, when
        #: the server sets it (backend.api): authorised and logged like REST. None: the input directly.
        self.run_command: Any = None
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.port = self.server.get_port()  # viser moves to the next free port when this one is taken
        self._guard_direct_clients()
        self.server.scene.set_up_direction("+z")
        self.server.scene.add_grid(
            "/grid", width=2.0, height=2.0, cell_size=0.1, plane="xy", position=(0, 0, 0)
        )
        urdf = yourdfpy.URDF.load(str(self.emb.urdf_path), build_scene_graph=True, load_meshes=True)
        self._urdf = urdf
        self.base = self.server.scene.add_frame("/robot", show_axes=False)
        self.robot = ViserUrdf(self.server, urdf, root_node_name="/robot/body")
        ghost_urdf = yourdfpy.URDF.load(str(self.emb.urdf_path), build_scene_graph=True, load_meshes=True)
        self.ghost_base = self.server.scene.add_frame("/ghost", show_axes=False)
        self.ghost = ViserUrdf(
            self.server, ghost_urdf, root_node_name="/ghost/body", mesh_color_override=GHOST_COLOUR
        )
        names = self.robot.get_actuated_joint_names()
        index = {n: i for i, n in enumerate(self.emb.joint_names)}
        self._order = (
            np.array([index[n] for n in names], dtype=int) if all(n in index for n in names) else None
        )
        self._posers = {id(vu): poser_for(vu) for vu in (self.robot, self.ghost)}
        #: The simulated robot (`nutty serve --sim`): built on the first simulated pose it is given.
        self.physics = PhysicsGhost(self.server, str(self.emb.urdf_path), self._order)
        #: Where an in-process Pre-Viz reads the simulated pose: () -> (joints, touching links) | None.
        self.physics_source: Any = physics_source(getattr(getattr(session, "engine", None), "sinks", ()))
        self._leds = self._add_leds()
        self._face = self._add_face_label()
        self._caption = self.server.scene.add_label(
            "/caption", "", position=(0.0, 0.0, 0.62), anchor="bottom-center", font_screen_scale=1.1
        )
        self._caption_until = 0.0
        gui = self.server.gui
        self.ghost_toggle = gui.add_checkbox("Show ghost (stage 1)", initial_value=True)
        self.ghost_toggle.on_update(lambda _: self.set_ghost(self.ghost_toggle.value))
        self.status = gui.add_markdown("")
        self.gaze = self.server.scene.add_transform_controls(
            "/gaze_target", scale=0.12, position=(0.6, 0.0, 0.35), disable_rotations=True
        )
        self.server.scene.add_icosphere("/gaze_target/ball", radius=0.02, color=(255, 200, 40))
        self.gaze.on_update(lambda event: self._on_gaze_drag(event))
        self._cfg_now: np.ndarray | None = None  # the joint configuration last shown
        self._sink: Sink | None = None
        self.frames_shown = 0
        self._lock = threading.Lock()
        self._set_camera_on_connect()
        self.posing = PreviewPosing(self)  # the clip editor's preview pose and the link grab ring

    def set_preview(self, vector: Any, label: str = "", lease: float = 0.0) -> None:
        """Show a pose (a channel vector) instead of the robot's for `lease` s; None stops at once."""
        self.posing.set(vector, label, lease)

    @property
    def on_pose_grab(self) -> Any:
        """Called with (dof, value) when a trusted client turns a link in the preview."""
        return self.posing.on_grab

    @on_pose_grab.setter
    def on_pose_grab(self, callback: Any) -> None:
        self.posing.on_grab = callback

    # --- who may connect ------------------------------------------------------------------------
    def _guard_direct_clients(self) -> None:
        """Close viser WebSockets from foreign pages; remember the clients that may drag the gaze.

        Uses viser's connection hook (`_websock_server.on_client_connect`, which runs before any
        scene data is sent) to read the handshake's headers. Fails closed: without the hook no
        client is trusted and the gizmo is inert.
        """
        policy = AccessPolicy(port=self.port, bind_host=self.host, allowed_origins=self._allowed_origins)
        ws_server = getattr(self.server, "_websock_server", None)
        if ws_server is None or not hasattr(ws_server, "on_client_connect"):
            return

        async def check(conn: Any) -> None:
            connection = getattr(ws_server, "_live_connections", {}).get(conn.client_id)
            request = getattr(connection, "request", None)
            if connection is None or request is None:
                return
            headers = request.headers
            proxied = headers.get(PROXY_HEADER)
            if proxied is not None and secrets.compare_digest(proxied.encode(), self.proxy_secret.encode()):
                self._trusted.add(conn.client_id)
                return
            problem = (
                "this server has a token: open the Pre-Viz through the API's /previz/"
                if self.proxy_only
                else None
            )
            problem = (
                problem
                or policy.host_problem(headers.get("Host"))
                or policy.origin_problem(headers.get("Origin"), headers.get("Host"))
            )
            if problem is None:
                self._trusted.add(conn.client_id)
                return
            with contextlib.suppress(Exception):  # refused either way: a client that left needs no close
                await connection.close(4403, "forbidden: " + problem[:100])

        async def forget(conn: Any) -> None:
            self._trusted.discard(conn.client_id)

        ws_server.on_client_connect(check)
        ws_server.on_client_disconnect(forget)

    # --- scene pieces ---------------------------------------------------------------------------
    def _link_node(self, link: str, root: str = "/robot/body") -> str | None:
        from viser.extras._urdf import _viser_name_from_frame  # the node names ViserUrdf gives links

        scene = self._urdf.scene
        if scene is None or link not in scene.graph.nodes:
            return None
        return _viser_name_from_frame(scene, link, f"{root}/visual")

    def _add_leds(self) -> list[tuple[str, slice, list[Any]]]:
        leds = []
        for d in self.emb.dofs:
            if d.type is not DofType.colour:
                continue
            handles = []
            for link in d.links:
                node = self._link_node(link)
                if node is None:
                    continue
                handles.append(
                    self.server.scene.add_icosphere(
                        f"{node}/led_{d.name}",
                        radius=0.0225,
                        color=(255, 255, 255),
                        material="toon3",
                        cast_shadow=False,
                    )
                )
            if handles:
                leds.append((d.name, d.channels, handles))
        return leds

    def _add_face_label(self) -> tuple[slice, tuple[str, ...], Any] | None:
        for d in self.emb.dofs:
            if d.type is DofType.enum and d.options:
                node = self._link_node(d.links[0]) if d.links else None
                parent = node or "/robot"
                label = self.server.scene.add_label(
                    f"{parent}/face_{d.name}",
                    "",
                    position=(0.03, 0.0, -0.03),
                    anchor="top-center",
                    font_screen_scale=0.8,
                )
                return d.channels, d.options, label
        return None

    def _set_camera_on_connect(self) -> None:
        # a three-quarter view that frames the robot (its bounding box at the rest configuration)
        try:
            bounds = self._urdf.scene.bounds if self._urdf.scene is not None else None
        except Exception:  # a URDF without meshes has no bounds: the default framing will do
            log.debug("no bounds for the robot's scene", exc_info=True)
            bounds = None
        position, look_at = framing(bounds) if bounds is not None else ((0.62, 0.42, 0.48), (0.0, 0.0, 0.27))
        self.camera = {"position": position, "look_at": look_at}

        @self.server.on_client_connect
        def _(client) -> None:
            client.camera.position = position
            client.camera.look_at = look_at

    # --- live updates -----------------------------------------------------------------------------
    def set_ghost(self, visible: bool) -> None:
        self.ghost_base.visible = bool(visible)
        if self.ghost_toggle.value != bool(visible):
            self.ghost_toggle.value = bool(visible)

    @property
    def ghost_visible(self) -> bool:
        return bool(self.ghost_base.visible)

    def set_theme(self, theme: str) -> None:
        """Light or dark panels and background, as the editor beside it (`THEME_BACKGROUNDS`)."""
        colour = THEME_BACKGROUNDS[theme]
        self.server.gui.configure_theme(dark_mode=theme == "dark")
        # a solid image: viser's own background is white in either mode
        self.server.scene.set_background_image(np.full((4, 4, 3), colour, dtype=np.uint8), format="png")

    @property
    def trusted_clients(self) -> frozenset[int]:
        """Ids of the viser clients connected now whose gaze drags count (passed the Origin/Host
        checks or came through the API's proxy)."""
        return frozenset(self._trusted)

    def drag_gaze(self, position: Any, client_id: int | None = None) -> bool:
        """Move the gaze gizmo to `position` (x, y, z in metres, robot frame) as a drag would, and set
        the program's `gaze_target` input. A drag by viser client `client_id` counts only when that
        client is trusted; None is this process, which always counts. Returns whether the input was
        set (False also when the program declares no `gaze_target`)."""
        target = self.move_gaze(position, client_id)
        return target is not None and gaze_from_drag(self.session, self.run_command, target)

    def move_gaze(self, position: Any, client_id: int | None = None) -> list[float] | None:
        """The gizmo part of `drag_gaze`: the target [x, y, z] when the drag counts (the gizmo is
        then there), else None."""
        if client_id is not None and client_id not in self._trusted:
            return None
        target = [float(v) for v in position]
        if not np.allclose(self.gaze.position, target):  # a client's own drag is already there
            self.gaze.position = (target[0], target[1], target[2])
        return target

    def _on_gaze_drag(self, event: Any) -> None:
        """viser's gizmo callback. A drag that names no client is nobody's and never counts."""
        client_id = getattr(event, "client_id", None)
        if client_id is not None:
            self.drag_gaze(self.gaze.position, client_id)

    def _cfg(self, values: np.ndarray, joints: np.ndarray | None = None) -> np.ndarray:
        """viser's configuration: the given joints, or a pose's joints (within range: the ghost is a
        program's raw pose, which the motors would never take beyond a limit)."""
        q = joints if joints is not None else self.emb.joint_positions_in_range(values)
        return q[self._order] if self._order is not None else q

    def shown(self) -> dict[str, Any]:
        """What the Pre-Viz displays now, read back from its scene: {"joints": {joint: position (rad
        or m)} of the solid robot, "leds": {colour DoF: (r, g, b), 0..255}, "face": the expression
        label or None, "caption": the caption text ("" when none), "ghost": whether the ghost shows,
        "physics": whether the physics ghost shows, "touching": the links it flashes}."""
        with self._lock:
            cfg = self._cfg_now
            names = self.robot.get_actuated_joint_names()
            return {
                "joints": {} if cfg is None else {n: float(q) for n, q in zip(names, cfg)},
                "leds": {name: tuple(handles[0].color) for name, _, handles in self._leds},
                "face": self._face[2].text if self._face is not None else None,
                "caption": self._caption.text,
                "ghost": self.ghost_visible,
                "physics": self.physics.visible,
                "touching": list(self.physics.touching),
            }

    def show(self, frame: AnimationFrame) -> None:
        """Pose both robots and the displays from one frame (called on the sink thread)."""
        preview = self.posing.current()
        # a preview takes the solid robot; the ghost then shows the live robot beside it
        position = frame.position if preview is None else preview
        ghost = frame.stage1 if preview is None else frame.position
        with self._lock, self.server.atomic():
            self._cfg_now = self._cfg(position, frame.joints if preview is None else None)
            self._pose(self.robot, self._cfg_now)
            base = self.emb.base_pose(position)
            set_if_changed(self.base, "position", (base["x"], base["y"], base["z"]))
            set_if_changed(self.base, "wxyz", yaw_pitch_roll_quat(base["yaw"], base["pitch"], base["roll"]))
            physics = getattr(frame, "physics", None)
            if physics is None and self.physics_source is not None:
                physics = self.physics_source()
            if physics is not None:
                wxyz = yaw_pitch_roll_quat(base["yaw"], base["pitch"], base["roll"])
                self.physics.show(physics[0], physics[1], ((base["x"], base["y"], base["z"]), wxyz))
            if self.ghost_visible and ghost is not None:
                self._pose(self.ghost, self._cfg(ghost, frame.joints if preview is not None else None))
                gb = self.emb.base_pose(ghost)
                set_if_changed(self.ghost_base, "position", (gb["x"], gb["y"], gb["z"]))
            position = position.tolist()
            for _, channels, handles in self._leds:
                rgb = tuple(round(255 * min(max(c, 0.0), 1.0)) for c in position[channels])
                for h in handles:
                    set_if_changed(h, "color", rgb)
            if self._face is not None:
                channels, options, label = self._face
                k = round(position[channels.start])
                set_if_changed(label, "text", options[min(max(k, 0), len(options) - 1)])
            now = time.monotonic()
            for ev in frame.events:
                text = ev.payload.get("text") or ev.payload.get("clip") or ev.kind
                self._caption.text = f"🔊 {text}" if ev.kind != "say" else f"“{text}”"
                self._caption_until = now + CAPTION_SECONDS
            if self._caption_until and now > self._caption_until:
                self._caption.text = ""
                self._caption_until = 0.0
            self.frames_shown += 1

    def _pose(self, robot: Any, cfg: np.ndarray) -> None:
        poser = self._posers.get(id(robot))
        if poser is not None:
            poser.update(cfg)
        else:
            robot.update_cfg(cfg)

    def start(self) -> PreViz:
        self._sink = attach_previz_sink(self.session, self.show)
        return self

    def url(self, host: str | None = None) -> str:
        return f"http://{host or self.host}:{self.port}"

    def stop(self) -> None:
        if self._sink is not None:
            self.session.engine.remove_sink(self._sink)
            self._sink = None
        self.server.stop()
