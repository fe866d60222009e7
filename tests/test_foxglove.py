"""The Foxglove driver (`--foxglove PORT`): a real Foxglove WebSocket server (foxglove SDK) talked to by
a real WebSocket client speaking the Foxglove protocol, its messages decoded with rosbags and checked
against the engine's frames and an independent forward kinematics; the link transforms' bytes against
rosbags' serialisation; mesh assets; the layout file."""

from __future__ import annotations

import json
import shutil
import struct
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("foxglove", reason="the 'foxglove' extra is not installed")
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

from backend.engine.embodiment import load_embodiment
from backend.engine.frames import AnimationFrame, FrameEvent
from backend.engine.kinematics import Chain
from backend.foxglove.cdr_templates import JointStateTemplate
from backend.foxglove.layout import layout_text
from backend.foxglove.server import FoxgloveServer, parse_address
from backend.foxglove.transforms import LinkTransforms
from backend.graph.builder import ProgramBuilder
from backend.ros2 import cdr
from backend.ros2.view import BasePose, FrameView, Stamp
from backend.session import EngineSession

ROOT = Path(__file__).resolve().parents[1]
DESK = ROOT / "robots" / "nutty_desk"
#: The protocol the SDK's server speaks (`foxglove.sdk.v1` since SDK 0.2x; the older name is offered too).
SUBPROTOCOLS = [Subprotocol("foxglove.sdk.v1"), Subprotocol("foxglove.websocket.v1")]


def wave_program():
    """A sine on head and body yaw (rad)."""
    b = ProgramBuilder("wave")
    b.chain(b.node("sine", "wave", dofs=["head_yaw", "body_yaw"], amplitude=0.4, frequency=1.0), b.output())
    return b.build()


class FoxgloveClient:
    """A minimal Foxglove WebSocket protocol client: serverInfo, advertise, subscribe, messageData,
    fetchAsset."""

    def __init__(self, url: str):
        self.ws: ClientConnection = connect(url, subprotocols=SUBPROTOCOLS, open_timeout=5)
        self.info: dict = {}
        self.channels: dict[str, dict] = {}
        self.topics: dict[int, str] = {}  # subscription id -> topic
        self.assets: dict[int, tuple[int, str, bytes]] = {}  # request id -> (status, error, data)
        self._next = 0
        deadline = time.monotonic() + 5
        while not (self.info and self.channels) and time.monotonic() < deadline:
            self._handle(self.ws.recv(timeout=5))

    def _handle(self, raw: str | bytes) -> tuple[str, int, bytes] | None:
        """A messageData as (topic, log time ns, payload); other messages are noted, giving None."""
        if isinstance(raw, str):
            msg = json.loads(raw)
            if msg["op"] == "serverInfo":
                self.info = msg
            elif msg["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in msg["channels"]})
            return None
        if raw[0] == 1:  # messageData: subscription id (u32), log time (u64 ns), payload
            sub, log_time = struct.unpack_from("<IQ", raw, 1)
            return self.topics[sub], log_time, bytes(raw[13:])
        if raw[0] == 4:  # fetchAsset response: request id (u32), status (u8), error (u32 + text), data
            request, status, n = struct.unpack_from("<IBI", raw, 1)
            self.assets[request] = (status, bytes(raw[10 : 10 + n]).decode(), bytes(raw[10 + n :]))
        return None

    def subscribe(self, *topics: str) -> None:
        subs = []
        for topic in topics:
            self._next += 1
            self.topics[self._next] = topic
            subs.append({"id": self._next, "channelId": self.channels[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def messages(self, seconds: float, until: int | None = None) -> list[tuple[str, int, bytes]]:
        """(topic, log time ns, payload) received within `seconds` (or once `until` have come)."""
        out: list[tuple[str, int, bytes]] = []
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline and (until is None or len(out) < until):
            try:
                got = self._handle(self.ws.recv(timeout=max(0.01, deadline - time.monotonic())))
            except TimeoutError:
                break
            if got is not None:
                out.append(got)
        return out

    def fetch(self, uri: str, request: int) -> tuple[int, str, bytes]:
        """(status 0 ok / 1 error, error text, data) of a fetchAsset."""
        self.ws.send(json.dumps({"op": "fetchAsset", "uri": uri, "requestId": request}))
        deadline = time.monotonic() + 5
        while request not in self.assets and time.monotonic() < deadline:
            self._handle(self.ws.recv(timeout=5))
        return self.assets[request]

    def close(self) -> None:
        self.messages(0.05)  # read what is pending: the close handshake waits behind it
        self.ws.close()


@pytest.fixture
def live(desk):
    """A ticking engine (100 Hz, a sine on head and body yaw) with a Foxglove server on a free port;
    yields (session, server, frames by seq)."""
    session = EngineSession.create(desk, rate=100, program=wave_program())
    frames: dict[int, AnimationFrame] = {}
    session.engine.add_frame_observer(lambda f: frames.__setitem__(f.seq, f))
    server = session.engine.add_sink(FoxgloveServer(desk, "127.0.0.1", 0))
    session.engine.start()
    yield session, server, frames
    session.engine.close()


def world_poses(transforms) -> dict[str, np.ndarray]:
    """Each frame's 4x4 pose in the tree's root frame, composed from decoded TransformStamped."""
    edges = {t.child_frame_id: t for t in transforms}

    def matrix(t) -> np.ndarray:
        x, y, z, w = (
            t.transform.rotation.x,
            t.transform.rotation.y,
            t.transform.rotation.z,
            t.transform.rotation.w,
        )
        m = np.eye(4)
        m[:3, :3] = [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
        m[:3, 3] = [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z]
        return m

    def pose(frame: str) -> np.ndarray:
        t = edges.get(frame)
        return np.eye(4) if t is None else pose(t.header.frame_id) @ matrix(t)

    return {name: pose(name) for name in edges}


def urdf_links(text: str) -> set[str]:
    return {link.attrib["name"] for link in ET.fromstring(text).iter("link")}


# --- transforms ------------------------------------------------------------------------------------


def test_transform_bytes_are_rosbags_tfmessage_and_pose_links_as_kinematics_does(desk):
    view = FrameView(desk)
    links = LinkTransforms(desk, view.base_link)
    assert links.links == urdf_links(DESK.joinpath("robot.urdf").read_text()) | {"odom"}
    q = np.random.default_rng(3).uniform(-0.4, 0.4, len(desk.joint_names))
    base = BasePose("odom", view.base_link, (0.5, -0.2, 0.0), (0.0, 0.0, 0.2588190, 0.9659258))
    stamp = Stamp(1_700_000_000, 987_654_321)
    message = links.message(stamp, q, base)
    poses = [
        BasePose(p, c, tuple(v[:3]), tuple(v[3:])) for (p, c), v in zip(links.frames, links.values(q, base))
    ]
    assert message == cdr.tf_message(stamp, poses)  # byte for byte what rosbags writes

    decoded = cdr.decode(message, cdr.TF_MESSAGE).transforms
    assert {(t.header.stamp.sec, t.header.stamp.nanosec) for t in decoded} == {(stamp.sec, stamp.nanosec)}
    world = world_poses(decoded)
    base_m = world[view.base_link]
    for tip in (
        "head",
        "ear_left_link",
        "eyelid_right_link",
        "mouth",
    ):  # an independent FK: backend/engine/kinematics.Chain
        chain = Chain(desk, view.base_link, tip)
        q_chain = np.array([q[desk.joint_names.index(n)] for n in chain.joint_names])
        np.testing.assert_allclose(np.linalg.inv(base_m) @ world[tip], chain.fk(q_chain), atol=1e-9)


def test_joint_state_bytes_are_rosbags_jointstate(desk):
    rng = np.random.default_rng(5)
    n = len(desk.joint_names)
    position, velocity = rng.normal(size=n), rng.normal(size=n)
    stamp = Stamp(1_800_000_000, 5)
    message = JointStateTemplate(desk.joint_names).message(stamp, position, velocity)
    assert message == cdr.joint_state(stamp, desk.joint_names, position, velocity)
    empty = JointStateTemplate([]).message(stamp, np.zeros(0), np.zeros(0))
    assert empty == cdr.joint_state(stamp, [], np.zeros(0), np.zeros(0))


def test_a_mimic_joint_follows_its_leader(tmp_path):
    urdf = tmp_path / "mimic.urdf"
    urdf.write_text(
        """<robot name="m"><link name="base"/><link name="a"/><link name="b"/>
        <joint name="lead" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
          <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
        <joint name="follow" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.1 0 0"/>
          <axis xyz="0 0 1"/><mimic joint="lead" multiplier="-2" offset="0.1"/>
          <limit lower="-3" upper="3" effort="1" velocity="1"/></joint></robot>"""
    )
    emb = load_embodiment(urdf)
    links = LinkTransforms(emb)
    lead = emb.joint_names.index("lead")
    q = np.zeros(len(emb.joint_names))
    q[lead] = 0.3
    values = dict(zip([c for _, c in links.frames], links.values(q)))
    angle = 2 * np.arctan2(values["b"][5], values["b"][6])  # rotation about z
    assert angle == pytest.approx(-2 * 0.3 + 0.1)
    np.testing.assert_allclose(values["b"][:3], [0.1, 0, 0])


# --- the live server ---------------------------------------------------------------------------------


def test_live_joint_states_transforms_and_events(live, desk):
    session, server, frames = live
    client = FoxgloveClient(server.url)
    try:
        assert client.ws.subprotocol == "foxglove.sdk.v1"
        expected = {
            "/robot_description": cdr.STRING,
            "/joint_states": cdr.JOINT_STATE,
            "/tf": cdr.TF_MESSAGE,
        }
        for topic, typename in expected.items():
            channel = client.channels[topic]
            assert (channel["encoding"], channel["schemaName"], channel["schemaEncoding"]) == (
                "cdr",
                typename,
                "ros2msg",
            )
            assert channel["schema"] == cdr.message_definition(typename)
        assert client.channels["/nutty/events"]["encoding"] == "json"
        client.subscribe("/joint_states", "/tf", "/nutty/events")
        time.sleep(0.3)
        session.engine.inject_event(FrameEvent("speech", "say", {"text": "hello foxglove"}))
        got = client.messages(1.5)
    finally:
        client.close()
    by_topic: dict[str, list[tuple[int, bytes]]] = {}
    for topic, log_time, payload in got:
        by_topic.setdefault(topic, []).append((log_time, payload))
    states = [cdr.decode(p, cdr.JOINT_STATE) for _, p in by_topic["/joint_states"]]
    assert len(states) > 50  # ~100 Hz for ~1.5 s, minus what a busy machine drops
    assert list(states[0].name) == list(desk.joint_names)
    by_t = {round(f.t, 6): f for f in frames.copy().values()}  # a copy: the clock thread still adds
    epoch = server.view.epoch
    matched = 0
    for state in states:
        t = round(state.header.stamp.sec + state.header.stamp.nanosec * 1e-9 - epoch, 6)
        frame = by_t.get(t) or by_t.get(round(t + 1e-6, 6)) or by_t.get(round(t - 1e-6, 6))
        if frame is not None:
            np.testing.assert_allclose(state.position, frame.joint_values(desk), atol=1e-12)
            matched += 1
    assert matched >= len(states) - 2  # frames the observer kept (all): each message is one of them
    yaw = np.array([s.position[desk.joint_names.index("head_yaw")] for s in states])
    assert np.ptp(yaw) > 0.2  # the sine moves it

    tf = cdr.decode(by_topic["/tf"][-1][1], cdr.TF_MESSAGE)
    assert {t.child_frame_id for t in tf.transforms} | {"odom"} == urdf_links(server.urdf) | {"odom"}
    events = [json.loads(p) for _, p in by_topic.get("/nutty/events", [])]
    assert any(e["kind"] == "say" and e["payload"]["text"] == "hello foxglove" for e in events)
    stats = server.stats()
    assert stats["published"] > 50 and stats["errors"] == 0
    print(f"\nfoxglove publish cost: {stats['publish_us']} us per frame ({stats['published']} frames)")


def test_a_late_subscriber_gets_the_robot_description(live):
    _, server, _ = live
    early = FoxgloveClient(server.url)
    early.subscribe("/joint_states")
    assert early.messages(1.0, until=5)  # frames are flowing before the late client comes
    late = FoxgloveClient(server.url)
    try:
        late.subscribe("/robot_description")
        got = late.messages(3.0, until=1)
    finally:
        late.close()
        early.close()
    assert got and got[0][0] == "/robot_description"
    text = cdr.decode(got[0][2], cdr.STRING).data
    assert urdf_links(text) == urdf_links(DESK.joinpath("robot.urdf").read_text())


# --- assets ----------------------------------------------------------------------------------------


@pytest.fixture
def meshed_robot(tmp_path):
    """nutty_desk with its head drawn by a mesh file at a path relative to the URDF."""
    robot = tmp_path / "meshed_desk"
    shutil.copytree(DESK, robot)
    (robot / "meshes").mkdir()
    mesh = b"solid head\nendsolid head\n"
    (robot / "meshes" / "head.stl").write_bytes(mesh)
    urdf = robot / "robot.urdf"
    text = urdf.read_text()
    start = text.index('<link name="head">')
    geometry = text.index("<geometry>", start)
    end = text.index("</geometry>", geometry)
    urdf.write_text(text[:geometry] + '<geometry><mesh filename="meshes/head.stl"/>' + text[end:])
    (tmp_path / "secret.stl").write_bytes(b"not the robot's")
    return robot, mesh


def test_meshes_are_served_from_the_robot_folder_only(meshed_robot):
    robot, mesh = meshed_robot
    emb = load_embodiment(robot)
    server = FoxgloveServer(emb, "127.0.0.1", 0)
    client = FoxgloveClient(server.url)
    try:
        assert "assets" in client.info["capabilities"]
        uri = "package://meshed_desk/meshes/head.stl"
        assert f'filename="{uri}"' in server.urdf
        assert client.fetch(uri, 1) == (0, "", mesh)
        assert client.fetch(f"file://{robot / 'meshes' / 'head.stl'}", 2) == (0, "", mesh)
        outside = [
            "package://meshed_desk/../secret.stl",
            "package://meshed_desk/%2e%2e/secret.stl",
            f"file://{robot.parent / 'secret.stl'}",
            "file:///etc/passwd",
            "package://meshed_desk/embodiment.yaml",
            "http://example.com/head.stl",
        ]
        for k, bad in enumerate(outside, start=10):
            status, error, data = client.fetch(bad, k)
            assert status == 1 and data == b"", bad
            assert "robot folder" in error or "not a mesh" in error or "only package" in error, error
        status, _, data = client.fetch("package://meshed_desk/meshes/missing.stl", 30)
        assert status == 1 and data == b""
    finally:
        client.close()
        server.close()
    assert server.assets is not None and server.assets.served == 2 and server.assets.refused == len(outside)


# --- rate, options, extras, the command line, the layout ----------------------------------------------


def test_joint_states_are_decimated_to_max_rate(desk):
    session = EngineSession.create(desk, rate=200, program=wave_program())
    server = FoxgloveServer(desk, "127.0.0.1", 0, max_rate=100)
    client = FoxgloveClient(server.url)
    try:
        frames = list(session.run_headless(200))
        server.consume(frames[0])
        assert server.published == 0  # no client subscribed: nothing built
        client.subscribe("/joint_states")
        deadline = time.monotonic() + 5
        while not server.joint_states.has_sinks() and time.monotonic() < deadline:
            time.sleep(0.01)
        for frame in frames:  # on this thread: every frame reaches consume
            server.consume(frame)
        assert server.published == 100  # 200 Hz engine, 100 Hz out: every other frame
        epoch = server.view.epoch
        for frame in frames[:10]:  # frame time going back (a replay looping): stamps start again from now
            server.consume(frame)
        assert server.published == 105 and server.view.epoch > epoch  # re-anchored to the wall clock
    finally:
        client.close()
        server.close()
        session.engine.close()


def test_address_option_and_registration():
    from backend.drivers.registry import DRIVER_OPTIONS, reload

    assert parse_address("8765") == ("127.0.0.1", 8765)
    assert parse_address("0.0.0.0:9001") == ("0.0.0.0", 9001)
    assert parse_address("[::1]:9001") == ("::1", 9001)
    for bad in ("", "host:", "99999", "0", "a:b"):
        with pytest.raises(Exception, match="1..65535"):
            parse_address(bad)
    reload()
    assert DRIVER_OPTIONS["foxglove"].metavar == "PORT"


def test_a_taken_port_is_a_clear_error(desk):
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with pytest.raises(OSError, match="cannot listen on 127.0.0.1"):
            FoxgloveServer(desk, "127.0.0.1", taken.getsockname()[1])


def test_missing_sdk_names_the_extra(desk, monkeypatch):
    monkeypatch.setitem(sys.modules, "foxglove", None)  # `import foxglove` now raises ImportError
    with pytest.raises(ImportError, match=r"'foxglove' extra"):
        FoxgloveServer(desk, "127.0.0.1", 0)


def test_nutty_serve_foxglove_subprocess():
    from tests.server_process import free_port, running_server

    port = free_port()
    with running_server("--no-previz", "--foxglove", str(port)):
        client = FoxgloveClient(f"ws://127.0.0.1:{port}")
        try:
            assert {"/robot_description", "/joint_states", "/tf", "/nutty/events"} <= set(client.channels)
            client.subscribe("/joint_states", "/robot_description")
            got = client.messages(5.0, until=5)
        finally:
            client.close()
    topics = {topic for topic, _, _ in got}
    assert {"/joint_states", "/robot_description"} <= topics
    state = cdr.decode(next(p for t, _, p in got if t == "/joint_states"), cdr.JOINT_STATE)
    assert len(state.position) == len(state.name) > 0


def test_layout_file_is_the_generated_one(desk):
    path = ROOT / "docs" / "foxglove" / "nutty-layout.json"
    assert path.read_text() == layout_text(desk), (
        "regenerate: python -m backend.foxglove.layout nutty_desk " + str(path)
    )
    layout = json.loads(path.read_text())
    three_d = layout["configById"]["3D!nutty"]
    urdf_layer = {"layerId": "foxglove.Urdf", "sourceType": "topic", "topic": "/robot_description"}
    assert urdf_layer.items() <= three_d["layers"]["urdf"].items()
    plotted = [p["value"] for p in layout["configById"]["Plot!nutty"]["paths"]]
    assert f"/joint_states.position[{desk.joint_names.index('head_yaw')}]" in plotted
    assert layout["configById"]["RawMessages!nutty"]["topicPath"] == "/nutty/events"
    split = layout["layout"]
    assert set(layout["configById"]) == {split["first"], split["second"]["first"], split["second"]["second"]}
