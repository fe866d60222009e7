"""The viser Pre-Viz posed from frames: joints resolved, ghost toggle, LEDs, captions, gaze input."""

from __future__ import annotations

import numpy as np
import pytest
from server_process import free_port

from backend.engine.frames import FrameEvent
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession


@pytest.fixture()
def previz(desk):
    from backend.previz import PreViz

    b = ProgramBuilder("gaze")
    b.expose("gaze_target", type="vec3", default=[1.0, 0.0, 0.3])
    b.chain(b.node("sine", "s", dofs=["head_yaw"], amplitude=0.3), b.node("nmf_stage2", "nmf"), b.output())
    session = EngineSession.create(desk, rate=100, program=b.build())
    pv = PreViz(session, port=free_port())
    yield pv
    pv.stop()
    session.engine.close()


def test_frames_pose_robot_leds_face_and_captions(previz, desk):
    session = previz.session
    frame = list(session.run_headless(30))[-1]
    frame.position[desk.dof("eye_leds").channels] = [1.0, 0.0, 0.5]
    frame.position[desk.dof("mouth").channels] = 1
    frame.events = [FrameEvent("speech", "say", {"text": "hello there"})]
    previz.show(frame)
    shown = previz.shown()
    assert shown["joints"]["head_yaw"] == pytest.approx(frame.position[desk.channel_index["head_yaw"]])
    assert shown["leds"]["eye_leds"] == (255, 0, 128)
    assert shown["face"] == "smile"
    assert "hello there" in shown["caption"]


def test_ghost_toggle_and_sink_decimation(previz):
    previz.set_ghost(False)
    assert not previz.ghost_visible and previz.ghost_toggle.value is False and not previz.shown()["ghost"]
    previz.set_ghost(True)
    assert previz.ghost_visible
    previz.start()
    sink = next(s for s in previz.session.engine.sinks if s.name == "previz")
    assert sink.decimate == 2  # 100 Hz engine -> at most 60 Hz to viser
    previz.session.engine.run_ticks(40)
    previz.session.engine.close()
    assert previz.frames_shown >= 1


def test_dragging_the_gaze_target_sets_the_input(previz):
    assert previz.drag_gaze([0.5, 0.2, 0.4])  # from this process: always counts
    previz.session.engine.tick()
    assert previz.session.inputs()["gaze_target"] == pytest.approx([0.5, 0.2, 0.4])
    assert np.allclose(previz.gaze.position, [0.5, 0.2, 0.4])  # the gizmo moved with it


def test_previz_listens_on_loopback_only(desk):
    from backend.previz import PreViz

    session = EngineSession.create(desk, rate=100)
    with pytest.raises(ValueError, match="loopback"):
        PreViz(session, host="0.0.0.0", port=free_port())
    session.engine.close()


def test_gaze_drags_count_only_from_trusted_clients(previz):
    import viser
    from websockets.sync.client import connect

    assert not previz.drag_gaze([0.4, -0.2, 0.3], client_id=12345)  # a client that never passed the checks
    previz.session.engine.tick()
    assert previz.session.inputs()["gaze_target"] == pytest.approx([1.0, 0.0, 0.3])
    url = f"ws://127.0.0.1:{previz.port}"
    with connect(
        url,
        subprotocols=[f"viser-v{viser.__version__}"],
        origin=f"http://localhost:{previz.port}",
        max_size=None,
        open_timeout=30,
    ) as ws:
        ws.recv(timeout=30)  # connected and checked: its drags count
        (client_id,) = previz.trusted_clients
        assert previz.drag_gaze([0.4, -0.2, 0.3], client_id=client_id)
    previz.session.engine.tick()
    assert previz.session.inputs()["gaze_target"] == pytest.approx([0.4, -0.2, 0.3])


def test_viser_port_refuses_foreign_pages_and_trusts_its_own(previz):
    import viser
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    sub = [f"viser-v{viser.__version__}"]
    url = f"ws://127.0.0.1:{previz.port}"
    with connect(url, subprotocols=sub, origin="http://evil.example", max_size=None, open_timeout=30) as ws:
        with pytest.raises(ConnectionClosed) as closed:
            while True:
                ws.recv(timeout=30)
        assert closed.value.rcvd.code == 4403
    assert not previz.trusted_clients
    for origin in (f"http://localhost:{previz.port}", None):  # its own page, or a local non-browser client
        with connect(url, subprotocols=sub, origin=origin, max_size=None, open_timeout=30) as ws:
            assert isinstance(ws.recv(timeout=30), bytes)
            assert previz.trusted_clients  # its gaze drags count


def test_the_proxy_fetches_viser_pages(previz):
    import asyncio

    from backend.previz import fetch_page

    status, headers, body = asyncio.run(fetch_page(previz.port, ""))
    assert (
        status == 200 and headers["content-type"].startswith("text/html") and b"<html" in body[:500].lower()
    )
    status, _, _ = asyncio.run(fetch_page(previz.port, "../../etc/passwd"))
    assert status == 404


def test_only_moved_joint_frames_are_sent_and_poses_match_viser(previz):
    """The Pre-Viz poses joint frames itself (backend.previz_pose): the same poses as viser's own
    `ViserUrdf.update_cfg`, and a frame whose joint did not move is not sent again."""
    from backend.previz_pose import UrdfPoser

    poser = previz._posers[id(previz.robot)]
    assert isinstance(poser, UrdfPoser)
    rng = np.random.default_rng(4)
    names = previz.robot.get_actuated_joint_names()
    for _ in range(5):
        cfg = rng.uniform(-0.6, 0.6, len(names))
        previz._pose(previz.robot, cfg)
        previz.ghost.update_cfg(cfg)  # viser's own posing of the same URDF
        for mine, theirs in zip(previz.robot._joint_frames, previz.ghost._joint_frames):
            q, r = np.asarray(mine.wxyz), np.asarray(theirs.wxyz)
            assert min(np.abs(q - r).max(), np.abs(q + r).max()) < 1e-12  # q and -q are one rotation
            np.testing.assert_allclose(mine.position, theirs.position, atol=1e-12)
    assert poser.update(cfg) == 0  # nothing moved: nothing sent
    cfg[0] += 0.1
    assert poser.update(cfg) == 1


def test_the_editor_embeds_the_page_without_viser_panel_and_notices(previz):
    from fastapi.testclient import TestClient

    from backend.api import create_app

    with TestClient(create_app(previz.session, previz=previz, frontend_dir=None)) as c:
        embedded, alone = c.get("/previz/?embed=1"), c.get("/previz/")
    assert embedded.status_code == alone.status_code == 200
    style = embedded.text.split('<style id="nutty-embed">', 1)[1].split("</style>", 1)[0]
    assert (
        "[data-floating-window]" in style
        and ".mantine-Notifications-root" in style
        and "display: none" in style
    )
    assert embedded.text.index("nutty-embed") < embedded.text.index("</head>")
    assert "nutty-embed" not in alone.text  # popped out, the page keeps viser's own panel


def test_the_camera_frames_the_robot():
    import math

    from backend.previz import CAMERA_FOV, framing

    bounds = [[-0.13, -0.14, 0.0], [0.13, 0.14, 0.53]]
    position, look_at = framing(bounds)
    assert look_at == pytest.approx((0.0, 0.0, 0.265))
    radius = float(np.linalg.norm(np.subtract(bounds[1], bounds[0]))) / 2
    distance = float(np.linalg.norm(np.subtract(position, look_at)))
    assert radius / distance < math.sin(CAMERA_FOV / 2)  # the whole bounding sphere is in view
    assert radius / distance > 0.8 * math.sin(CAMERA_FOV / 2)  # and fills it (not a speck far away)
    assert position[0] > 0 and position[1] > 0 and position[2] > look_at[2]  # front-left, from above
    far, _ = framing([[-1, -1, 0], [1, 1, 2]])
    assert np.linalg.norm(far) > np.linalg.norm(position)  # a bigger robot, a farther camera
