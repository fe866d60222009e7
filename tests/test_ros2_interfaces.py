"""tf2_msgs built from the rosidl toolchain of the ROS 2 wheels (backend/ros2/interfaces.py): the build
installs into this virtualenv, a second build does nothing, the type hash is the standard one, the
bytes are what rosbags (an independent CDR implementation) reads and writes, and a talker and a
listener in two processes exchange TFMessages on /tf over rmw_fastrtps_cpp.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from tests.ros_env import ros_domain, ros_environ

pytest.importorskip("rclpy", reason="needs the [ros2] extra")
# The rosidl parser (used when a test builds in-process) imports lark, which uses deprecated re modules.
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning:lark")
interfaces = pytest.importorskip("backend.ros2.interfaces")


@pytest.fixture(scope="module")
def built() -> None:
    """tf2_msgs installed (builds it the first time; afterwards this only checks it is current)."""
    layout = interfaces.venv_layout()
    missing = interfaces.missing_prerequisites(interfaces.TF2_MSGS, layout)
    if missing:
        pytest.skip("cannot build tf2_msgs here: " + "; ".join(missing))
    result = interfaces.build()
    print(f"tf2_msgs {result.status} in {result.seconds:.2f} s")


def _run(code: str, **kwargs) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        cwd=Path(__file__).resolve().parents[1],
        **kwargs,
    )


def test_build_cli_is_idempotent_and_quick(built: None) -> None:
    start = time.perf_counter()
    done = _run("from backend.ros2.interfaces import main; raise SystemExit(main(['build']))")
    seconds = time.perf_counter() - start
    assert done.returncode == 0, done.stderr
    assert "tf2_msgs: up to date" in done.stdout
    assert done.stderr == ""
    print(f"second build: {seconds:.2f} s including interpreter start")


def test_installed_files_are_recorded(built: None) -> None:
    layout = interfaces.venv_layout()
    files = interfaces.installed_files(interfaces.TF2_MSGS, layout)
    assert files is not None
    names = {f.name for f in files}
    for layer in ("generator_c", "typesupport_c", "typesupport_fastrtps_c", "typesupport_introspection_c"):
        assert f"libtf2_msgs__rosidl_{layer}.so" in names
    assert {"tf2_msgs_s__rosidl_typesupport_c.so", "_tf_message.py", "TFMessage.msg", "RECORD"} <= names
    assert all(f.exists() for f in files)
    assert all(layout.prefix in f.parents for f in files), "everything stays inside the virtualenv"


def test_type_hash_is_the_standard_one(built: None) -> None:
    from rosbags.typesys import Stores, get_typestore

    standard = get_typestore(Stores.ROS2_KILTED).hash_rihs01("tf2_msgs/msg/TFMessage")
    assert standard == interfaces.TFMESSAGE_TYPE_HASH
    described = Path(interfaces.venv_layout().prefix) / "share/tf2_msgs/msg/TFMessage.json"
    hashes = {h["type_name"]: h["hash_string"] for h in json.loads(described.read_text())["type_hashes"]}
    assert hashes["tf2_msgs/msg/TFMessage"] == standard


def test_bytes_agree_with_rosbags(built: None) -> None:
    done = _run(
        """
        from geometry_msgs.msg import TransformStamped
        from rclpy.serialization import deserialize_message, serialize_message
        from tf2_msgs.msg import TFMessage

        from backend.ros2.cdr import decode, tf_message
        from backend.ros2.view import BasePose, Stamp

        pose = BasePose("odom", "base_link", (0.5, -0.25, 0.0), (0.0, 0.0, 0.6, 0.8))
        theirs = tf_message(Stamp(12, 345), [pose])
        ours = deserialize_message(theirs, TFMessage)
        t = ours.transforms[0]
        assert (t.header.frame_id, t.child_frame_id, t.header.stamp.nanosec) == ("odom", "base_link", 345)
        assert (t.transform.translation.y, t.transform.rotation.w) == (-0.25, 0.8)
        # Same layout and values; the alignment padding is not compared (Fast CDR leaves it unset).
        mine = serialize_message(ours)
        assert len(mine) == len(theirs)
        again = decode(mine, "tf2_msgs/msg/TFMessage").transforms[0]
        assert (again.child_frame_id, again.header.stamp.sec, again.transform.rotation.z) == ("base_link", 12, 0.6)
        back = decode(serialize_message(TFMessage(transforms=[TransformStamped(child_frame_id="x")] * 2)),
                      "tf2_msgs/msg/TFMessage")
        assert [t.child_frame_id for t in back.transforms] == ["x", "x"]
        print("ok", len(mine))
        """
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("ok")


TALKER = """
import rclpy
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage

rclpy.init()
node = rclpy.create_node("nutty_tf_talker")
pub = node.create_publisher(TFMessage, "/tf", 10)
count = 0

def tick():
    global count
    count += 1
    t = TransformStamped(child_frame_id="base_link")
    t.header.frame_id = "odom"
    t.header.stamp = node.get_clock().now().to_msg()
    t.transform.translation.x = 0.01 * count
    t.transform.rotation.z, t.transform.rotation.w = 0.6, 0.8
    pub.publish(TFMessage(transforms=[t]))

node.create_timer(0.05, tick)
try:
    rclpy.spin(node)
except BaseException:
    pass
"""

LISTENER = """
import json, time
import rclpy
from tf2_msgs.msg import TFMessage

rclpy.init()
node = rclpy.create_node("nutty_tf_listener")
got = []
node.create_subscription(TFMessage, "/tf", got.append, 10)
start = time.monotonic()
while len(got) < 3 and time.monotonic() - start < 30:
    rclpy.spin_once(node, timeout_sec=0.1)
first = time.monotonic() - start
infos = node.get_publishers_info_by_topic("/tf")
out = {
    "count": len(got),
    "seconds": round(first, 2),
    "frames": [[m.transforms[0].header.frame_id, m.transforms[0].child_frame_id] for m in got],
    "x": [m.transforms[0].transform.translation.x for m in got],
    "w": got[-1].transforms[0].transform.rotation.w if got else None,
    "types": [i.topic_type for i in infos],
    "hashes": [str(i.topic_type_hash) for i in infos],
}
print(json.dumps(out))
node.destroy_node()
rclpy.shutdown()
"""


def test_talker_and_listener_exchange_tf_messages(built: None) -> None:
    env = ros_environ(ros_domain())
    talker = subprocess.Popen(
        [sys.executable, "-c", TALKER], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )
    try:
        done = _run(LISTENER, env=env)
    finally:
        talker.terminate()
        try:
            talker.wait(timeout=10)
        except subprocess.TimeoutExpired:
            talker.kill()
            talker.wait()
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["count"] >= 3, (out, talker.stderr.read() if talker.stderr else "")
    assert out["frames"][0] == ["odom", "base_link"]
    assert out["x"] == sorted(out["x"]) and out["x"][0] > 0
    assert out["w"] == pytest.approx(0.8)
    # Kilted exchanges type hashes in discovery: the talker announces the standard one.
    assert out["types"] == ["tf2_msgs/msg/TFMessage"]
    assert out["hashes"] == [interfaces.TFMESSAGE_TYPE_HASH]
    print(f"3 TFMessages received within {out['seconds']} s of the listener starting")


def test_missing_prerequisites_are_named_and_nothing_is_written(tmp_path: Path) -> None:
    layout = interfaces._Layout(tmp_path, tmp_path / "lib/python3.11/site-packages")
    with pytest.raises(interfaces.InterfaceBuildError) as caught:
        interfaces.build(layout=layout)
    message = str(caught.value)
    assert "missing" in message
    assert f"{tmp_path}/include/rosidl_runtime_c" in message
    assert f"{tmp_path}/lib/librosidl_typesupport_fastrtps_c.so" in message
    assert f"{tmp_path}/share/geometry_msgs/msg" in message
    assert list(tmp_path.iterdir()) == []


def test_missing_compiler_is_named(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CXX", "no-such-c++-compiler")
    missing = interfaces.missing_prerequisites(interfaces.TF2_MSGS, interfaces.venv_layout())
    assert any("C++ compiler" in line and "$CXX" in line for line in missing)


def test_a_definition_with_another_hash_is_refused_and_the_install_kept(built: None) -> None:
    layout = interfaces.venv_layout()
    before = {f: f.stat().st_mtime_ns for f in interfaces.installed_files(interfaces.TF2_MSGS, layout) or []}
    wrong = interfaces.InterfacePackage(
        name="tf2_msgs",
        messages=("TFMessage",),
        dependencies=("geometry_msgs", "std_msgs", "builtin_interfaces"),
        type_hashes={"tf2_msgs/msg/TFMessage": "RIHS01_" + "0" * 64},
    )
    with pytest.raises(interfaces.InterfaceBuildError, match="type hash"):
        interfaces.build(wrong, force=True)
    after = {f: f.stat().st_mtime_ns for f in interfaces.installed_files(interfaces.TF2_MSGS, layout) or []}
    assert before and after == before
