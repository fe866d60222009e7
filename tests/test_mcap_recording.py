"""`--record FILE.mcap`: a rosbag2-compatible MCAP of an engine's frames, read back with two independent
readers (the `mcap` reader with `mcap_ros2`'s decoder, and rosbags' own MCAP storage reader)."""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import pytest
import yaml

from backend.drivers import FrameRecorder, add_driver_options
from backend.engine.frames import FrameEvent
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession

pytest.importorskip("mcap")
pytest.importorskip("rosbags")

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from backend.recording.mcap_recorder import ChannelsEncoder, McapRecorder
from tests.server_process import running_server

RATE = 100
WARM, TICKS = 20, 150  # frames before the recorder is attached, frames recorded


def moving_program():
    """The head turns and the base drives a circle, so joints and the base pose both change."""
    b = ProgramBuilder("moving")
    wave = b.node(
        "sine", "wave", dofs=["head_yaw", "neck_pitch", "base_x", "base_y"], amplitude=0.12, frequency=0.3
    )
    b.chain(wave, b.output())
    return b.build()


@pytest.fixture(scope="module")
def recorded(desk, tmp_path_factory):
    """(path, frames recorded, the recorder) of a headless engine recorded to .mcap mid-animation."""
    path = tmp_path_factory.mktemp("mcap") / "take.mcap"
    session = EngineSession.create(desk, rate=RATE, program=moving_program())
    list(session.run_headless(WARM))  # the recorder joins a running engine: frame times do not start at 0
    rec = session.engine.add_sink(McapRecorder(desk, path))
    session.engine.inject_event(FrameEvent("speech", "say", {"text": "hello"}))
    frames = list(session.run_headless(TICKS))
    session.engine.close()
    return path, frames, rec


def decoded(path):
    """Every message as (topic, log_time, publish_time, decoded) with the mcap + mcap_ros2 readers."""
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        return [
            (ch.topic, m.log_time, m.publish_time, msg)
            for _s, ch, m, msg in reader.iter_decoded_messages(log_time_order=False)
        ]


def test_the_file_is_a_ros2_mcap_with_schemas_qos_and_a_summary(recorded):
    path, _frames, rec = recorded
    assert rec.frames == TICKS and rec.errors == 0 and rec.dropped == 0
    with path.open("rb") as fh:
        reader = make_reader(fh)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.chunk_indexes and {c.compression for c in summary.chunk_indexes} == {"zstd"}
        channels = {c.topic: c for c in summary.channels.values()}
        assert set(channels) == {
            "/robot_description",
            "/joint_states",
            "/tf",
            "/nutty/events",
            "/nutty/channels",
        }
        for topic, c in channels.items():
            schema = summary.schemas[c.schema_id]
            assert c.message_encoding == "cdr" and schema.encoding == "ros2msg"
            qos = yaml.safe_load(c.metadata["offered_qos_profiles"])
            assert isinstance(qos, list) and len(qos) == 1
            assert qos[0]["durability"] == (
                "transient_local" if topic == "/robot_description" else "volatile"
            )
            assert qos[0]["reliability"] == "reliable" and qos[0]["history"] == "keep_last"
        assert summary.schemas[channels["/joint_states"].schema_id].name == "sensor_msgs/msg/JointState"
        assert b"builtin_interfaces/Time" in summary.schemas[channels["/joint_states"].schema_id].data
        counts = summary.statistics.channel_message_counts
        assert counts[channels["/joint_states"].id] == TICKS and counts[channels["/tf"].id] == TICKS
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        assert meta["nutty"]["embodiment"] == "nutty_desk" and float(meta["nutty"]["rate"]) == RATE


def test_mcap_reader_sees_the_urdf_first_then_the_frames(desk, recorded):
    path, frames, _rec = recorded
    messages = decoded(path)
    topic, t0, _, first = messages[0]
    assert topic == "/robot_description" and first.data == desk.urdf_path.read_text()
    assert sum(1 for m in messages if m[0] == "/robot_description") == 1
    assert all(m[1] >= t0 for m in messages)
    states = [m for m in messages if m[0] == "/joint_states"]
    assert len(states) == len(frames)
    stamps = []
    for (_t, log_time, publish_time, msg), frame in zip(states, frames, strict=True):
        assert list(msg.name) == list(desk.joint_names)
        np.testing.assert_array_equal(np.array(msg.position), frame.joint_values(desk))
        assert len(msg.velocity) == len(desk.joint_names) and not msg.effort
        ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        assert ns == log_time == publish_time
        stamps.append(ns)
    steps = np.diff(stamps) / 1e9
    np.testing.assert_allclose(steps, 1.0 / RATE, atol=1e-6)  # float seconds since 1970: ~0.2 us grain
    # the epoch is the engine's start as the recorder saw it: stamps are now-ish wall times
    assert abs(stamps[0] / 1e9 - frames[0].t - time.time()) < 60


def test_tf_is_the_base_pose_and_events_carry_their_json(desk, recorded):
    path, frames, _rec = recorded
    messages = decoded(path)
    tfs = [m[3] for m in messages if m[0] == "/tf"]
    ix, iy = desk.channel_index["base_x"], desk.channel_index["base_y"]
    moved = 0.0
    for msg, frame in zip(tfs, frames, strict=True):
        (tr,) = msg.transforms
        assert tr.header.frame_id == "odom" and tr.child_frame_id
        assert (tr.transform.translation.x, tr.transform.translation.y) == (
            frame.position[ix],
            frame.position[iy],
        )
        assert tr.transform.translation.z == 0.0 and tr.transform.rotation.w == 1.0
        moved = max(moved, abs(frame.position[ix]))
    assert moved > 0.05  # the base really moved in this take
    events = [(m[1], json.loads(m[3].data)) for m in messages if m[0] == "/nutty/events"]
    with_events = [f for f in frames if f.events]
    assert len(events) == sum(len(f.events) for f in with_events) >= 1
    (_ns, said), frame = events[0], with_events[0]
    assert said["kind"] == "say" and said["dof"] == "speech" and said["payload"]["text"] == "hello"
    assert said == {"type": "frame_event", "t": frame.t, **frame.events[0].to_dict()}
    channels = [m[3] for m in messages if m[0] == "/nutty/channels"]
    assert [d.label for d in channels[0].layout.dim] == list(desk.channel_names)
    np.testing.assert_array_equal(
        np.array([c.data for c in channels]), np.array([f.position for f in frames])
    )


def test_rosbags_reads_the_same_file(desk, recorded):
    from rosbags.rosbag2.metadata import QosDurability
    from rosbags.rosbag2.storage_mcap import McapReader
    from rosbags.typesys import Stores, get_typestore

    path, frames, _rec = recorded
    store = get_typestore(Stores.ROS2_KILTED)
    reader = McapReader(path)
    reader.open()
    try:
        conns = {c.topic: c for c in reader.connections}
        assert conns["/joint_states"].msgtype == "sensor_msgs/msg/JointState"
        qos = {t: c.ext.offered_qos_profiles[0].durability for t, c in conns.items()}
        assert qos["/robot_description"] == QosDurability.TRANSIENT_LOCAL
        assert qos["/joint_states"] == QosDurability.VOLATILE
        got = [(c.topic, ts, raw) for c, ts, raw in reader.messages(list(conns.values()))]
    finally:
        reader.close()
    assert got[0][0] == "/robot_description"
    assert store.deserialize_cdr(got[0][2], "std_msgs/msg/String").data == desk.urdf_path.read_text()
    states = [
        store.deserialize_cdr(raw, "sensor_msgs/msg/JointState") for t, _, raw in got if t == "/joint_states"
    ]
    np.testing.assert_array_equal(
        np.stack([s.position for s in states]), np.stack([f.joint_values(desk) for f in frames])
    )
    tf = [store.deserialize_cdr(raw, "tf2_msgs/msg/TFMessage") for t, _, raw in got if t == "/tf"]
    assert tf[-1].transforms[0].transform.translation.y == frames[-1].position[desk.channel_index["base_y"]]


def test_the_channels_encoder_matches_a_full_encoding(desk):
    from backend.ros2 import cdr

    enc = ChannelsEncoder(list(desk.channel_names))
    values = np.random.default_rng(3).normal(size=desk.n_channels)
    assert enc.encode(values) == cdr.float64_multi_array(values, labels=list(desk.channel_names))
    with pytest.raises(ValueError, match="channels"):
        enc.encode(values[:-1])


def test_the_record_option_takes_jsonl_or_mcap_only(desk, tmp_path, capsys):
    parser = argparse.ArgumentParser(prog="nutty serve")
    add_driver_options(parser)
    for name in ("take.txt", "take", "take.bag"):
        with pytest.raises(SystemExit) as exc:
            parser.parse_args(["--record", str(tmp_path / name)])
        assert exc.value.code == 2
        assert "FILE.jsonl (JSON lines) or FILE.mcap" in capsys.readouterr().err
    for name, cls in (("a.jsonl", FrameRecorder), ("a.MCAP", McapRecorder)):
        value = parser.parse_args(["--record", str(tmp_path / name)]).record
        sink = FrameRecorder.from_option(desk, value)
        sink.close()
        assert type(sink) is cls
    assert "FILE.jsonl|FILE.mcap" in parser.format_help()
    with (tmp_path / "a.MCAP").open("rb") as fh:
        first = next(make_reader(fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
        assert first[1].topic == "/robot_description"  # a recording without frames still has the robot


def test_a_served_engine_records_to_mcap(desk, tmp_path):
    path = tmp_path / "served.mcap"
    with running_server("--record", str(path), "--rate", "50") as (_url, _port, client):
        deadline = time.time() + 20
        while (status := client.status())["t"] < 1.0 and time.time() < deadline:
            time.sleep(0.1)
    messages = decoded(path)  # complete: the server closed the recorder on SIGTERM
    assert messages[0][0] == "/robot_description"
    states = [m for m in messages if m[0] == "/joint_states"]
    assert len(states) >= 40
    stamps = np.array([m[1] for m in states])
    steps = np.diff(stamps) / 1e9
    assert np.median(steps) == pytest.approx(1 / 50, abs=1e-6)
    # wall-clock stamps from the engine's start: the recorder was made just before the clock started
    meta = {}
    with path.open("rb") as fh:
        meta = {m.name: m.metadata for m in make_reader(fh).iter_metadata()}
    assert abs(float(meta["nutty"]["epoch"]) - status["started_at"]) < 1.0
    assert stamps[0] / 1e9 >= status["started_at"] - 1.0
