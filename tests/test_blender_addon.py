"""The Blender add-on (blender/nutty_blender) in a real, headless Blender (bpy) against a real `nutty serve`:
load the robot, animate it, export the clip and play it in the engine (<= 0.1 deg from Blender's own
evaluated bone matrices), check limits, bake the ghost, puppeteer the live robot, and the reports a
user sees when something is wrong.

One Blender process (tests/blender_rpc.py) and one server (on a copy of the robot, so saved clips stay
out of the repository) serve the module. Skipped when bpy cannot be imported (`make test` installs it).
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import bpy_paths
import httpx
import numpy as np
import pytest
from blender_rpc import Blender, BlenderError, joint_map, load_rig
from server_process import free_port, running_app, server_process

from backend.engine.embodiment import load_embodiment

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("bpy") is None,
    reason="bpy (Blender as a Python module) is not installed: `make deps-python`",
)

ROOT = Path(__file__).resolve().parents[1]
FPS = 24
RATE = 100.0


@pytest.fixture(scope="module")
def robot_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("robot") / "nutty_desk"
    shutil.copytree(ROOT / "robots" / "nutty_desk", folder)
    return folder


@pytest.fixture(scope="module")
def blender():
    b = Blender()  # bpy starts while the server does
    yield b
    b.close()


@pytest.fixture(scope="module")
def server(robot_dir, blender):
    with server_process("--robot", str(robot_dir), "--no-previz") as s:
        yield s


@pytest.fixture(scope="module")
def emb(robot_dir):
    return load_embodiment(robot_dir)


# --- 1. the rig ---------------------------------------------------------------------------------------


def test_load_robot_rigs_every_joint_and_moves_the_meshes_like_the_urdf(blender, server, emb):
    """Pose DoFs and a symbolic DoF in Blender; every mesh must sit where yourdfpy's forward kinematics
    of the engine's joint positions (`Embodiment.joint_positions`) puts that visual."""
    import yourdfpy

    robot = server.client.robot()
    rig = load_rig(blender, server.url)
    assert rig["name"] == "nutty_desk"
    assert set(rig["joint_bones"]) == set(robot["joint_frames"])  # one bone per moving joint
    assert rig["dof_bones"] == {
        j: j
        for j in (
            "body_yaw",
            "neck_pitch",
            "head_yaw",
            "head_pitch",
            "head_roll",
            "ear_left",
            "ear_right",
            "eyelid_left",
            "eyelid_right",
        )
    }
    assert len(rig["meshes"]) == 17
    pose = {
        "body_yaw": 0.4,
        "neck_pitch": 0.2,
        "head_yaw": -0.5,
        "head_pitch": 0.1,
        "head_roll": 0.3,
        "ear_left": 0.6,
        "ear_right": -0.7,
        "eyelid_left": 0.9,
        "eyelid_right": 0.2,
    }
    symbolic = {"gaze_yaw": 0.5, "gaze_pitch": -0.2, "blink": 0.3}
    got = blender.run(
        """
        rig = bpy.data.objects["nutty_desk"]
        for dof, v in args["pose"].items():
            rig.pose.bones[dof].rotation_euler[1] = v
        for name, v in args["symbolic"].items():
            rig[name] = v
        bpy.context.view_layer.update()
        ev = bpy.context.evaluated_depsgraph_get()
        result = {}
        for c in rig.children:
            m = c.evaluated_get(ev).matrix_world
            result[c.name] = [list(row) for row in m]
        limits = {b.name: [c.min_y, c.max_y] for b in rig.pose.bones for c in b.constraints}
        locks = {b.name: list(b.lock_rotation) for b in rig.pose.bones}
        result = {"meshes": result, "limits": limits, "locks": locks}
    """,
        pose=pose,
        symbolic=symbolic,
    )
    assert got["limits"]["head_yaw"] == pytest.approx([-1.2, 1.2])
    assert got["limits"]["ear_left"] == pytest.approx([-0.9, 0.7])
    assert got["locks"]["head_yaw"] == [True, False, True] and got["locks"]["head_yaw.drive"] == [
        True,
        True,
        True,
    ]
    values = emb.rest.copy()
    for name, v in {**pose, **symbolic}.items():
        values[emb.dof(name).channels.start] = v
    q = dict(zip(emb.joint_names, emb.joint_positions(values)))
    urdf = yourdfpy.URDF.load(str(emb.urdf_path))
    urdf.update_cfg({j: q.get(j, 0.0) for j in urdf.actuated_joint_names})
    graph = urdf.scene.graph
    count: dict[str, int] = {}
    for node in graph.nodes_geometry:  # scene.glb names visuals "<link>|<n>" in this order
        link = graph.transforms.parents[node]
        name = f"{link}|{count.get(link, 0)}"
        count[link] = count.get(link, 0) + 1
        expected = graph.get(node)[0]
        assert np.allclose(np.array(got["meshes"][name]), expected, atol=2e-6), name


# --- 2. export: the engine plays what Blender shows ----------------------------------------------------

WAVE = """
    rig = bpy.data.objects["nutty_desk"]
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 97
    # a wave: Bezier keys (Blender's default auto-clamped handles), gentle enough for the robot's limits
    key(rig, "head_yaw", [(1, 0.0), (25, 0.15), (49, -0.1), (73, 0.1), (97, 0.0)])
    key(rig, "ear_left", [(1, 0.0), (13, 0.3), (37, -0.3), (61, 0.3), (85, 0.0), (97, 0.0)])
    key(rig, "ear_right", [(1, 0.0), (40, 0.3), (70, 0.33), (97, 0.3)])
    key(rig, "neck_pitch", [(1, 0.0), (30, 0.1), (50, 0.1), (97, 0.0)])
    key(rig, "head_roll", [(1, 0.0), (30, 0.06), (70, 0.0), (97, 0.0)])
    key(rig, "gaze_yaw", [(1, 0.0), (49, 0.2), (97, 0.0)])
    key(rig, "mouth", [(1, 0), (20, 1), (80, 0)])
    key(rig, "eye_leds", [(30, [1.0, 0.5, 0.0])])
    key(rig, "sound", [(10, 1)])
    curves = {(fc.data_path, fc.array_index): fc for fc in nutty_blender.rig.fcurves(rig)}
    def points(path, index=1):
        return sorted(curves[(path, index)].keyframe_points, key=lambda k: k.co[0])
    ear_r = points('pose.bones["ear_right"].rotation_euler')
    ear_r[0].interpolation, ear_r[0].easing = "SINE", "EASE_IN_OUT"   # an easing the engine has
    ear_r[1].interpolation = "LINEAR"                                  # a slow linear segment
    ear_r[2].interpolation, ear_r[2].easing = "EXPO", "EASE_IN_OUT"   # baked (the engine's expo differs)
    neck = points('pose.bones["neck_pitch"].rotation_euler')
    neck[1].interpolation = "CONSTANT"                                 # a hold
    roll = points('pose.bones["head_roll"].rotation_euler')[1]
    roll.handle_left_type = roll.handle_right_type = "FREE"  # long free handles (in line: no velocity jump):
    roll.handle_left = (roll.co[0] - 25.0, roll.co[1] - 0.02)     # the left one overlaps the handle of the key
    roll.handle_right = (roll.co[0] + 45.0, roll.co[1] + 0.036)   # before, the right one reaches past the next
                                                                   # key (Blender shortens it to the segment)
    for fc in curves.values():
        fc.update()
    for name, frame in (("anchor:up", 25), ("say:hello there", 5), ("sound:beep", 60), ("nutty:ignored", 3)):
        scene.timeline_markers.new(name, frame=frame)
"""


def clip_program(clip: str) -> dict:
    return {
        "format": "nutty-program/1",
        "name": "play",
        "robot": "nutty_desk",
        "rate": RATE,
        "nodes": [
            {
                "id": "clip",
                "type": "clip_player",
                "params": {"clip": clip, "autoplay": True, "crossfade": 0.0, "release": 0.0, "hold": True},
            },
            {"id": "out", "type": "output", "params": {}},
        ],
        "edges": [{"from": {"node": "clip", "port": "out"}, "to": {"node": "out", "port": "in"}}],
    }


def test_exported_clip_played_by_the_engine_matches_blender_within_0_1_deg(
    blender, server, emb, robot_dir, tmp_path
):
    from backend.engine.clips import validate_clip_doc
    from backend.session import EngineSession

    robot = server.client.robot()
    rig = load_rig(blender, server.url)
    blender.run(
        WAVE
        + """
        scene.nutty.clip_name = "blender_wave"
        bpy.ops.nutty.export_clip()
    """
    )
    doc = httpx.get(f"{server.url}/api/clips/blender_wave").json()  # saved through PUT /api/clips/{name}
    assert (robot_dir / "clips" / "blender_wave.json").exists()
    path = tmp_path / "wave.json"
    blender.run('bpy.ops.nutty.export_clip(target="FILE", filepath=args["path"])', path=str(path))
    assert validate_clip_doc(json.loads(path.read_text())) == doc  # the same clip, written to a file
    assert doc["duration"] == pytest.approx(4.0) and doc["anchors"] == {"up": 1.0}
    assert [(e["kind"], round(e["t"] * FPS, 6)) for e in doc["events"]] == [
        ("say", 4),
        ("sound", 9),
        ("sound", 59),
    ]
    first_sound = emb.dof("sound").sounds[0]  # the sound DoF keyed to 1: the robot's first sound
    assert [e["payload"] for e in doc["events"]] == [
        {"text": "hello there"},
        {"clip": first_sound},
        {"clip": "beep"},
    ]
    mouth = doc["tracks"]["mouth"][1]
    assert (mouth["t"], mouth["v"], mouth["interp"]) == (pytest.approx(19 / 24), "smile", "constant")
    head = doc["tracks"]["head_yaw"]
    assert [k["interp"] for k in head] == ["bezier"] * 4 + ["linear"]  # keys kept, not resampled
    assert len(head) == 5 and head[1]["right_type"] == "free"
    assert [k.get("interp") for k in doc["tracks"]["neck_pitch"]][:2] == ["bezier", "constant"]
    assert doc["tracks"]["ear_right"][0]["interp"] == "sine"
    assert (
        len(doc["tracks"]["ear_right"]) == 4 + 26
    )  # the 4 keys, and the expo segment (70-97) baked per frame

    # the engine plays the saved clip (from the robot's library on disk, as the server stored it)
    session = EngineSession.create(emb, rate=RATE, program=clip_program("blender_wave"))
    times, joints = [], []
    for _ in range(int(4.0 * RATE)):
        frame = next(iter(session.run_headless(1, [])))
        assert frame.corrected is None or not frame.corrected.any()  # the safety net left the clip alone
        times.append(float(session.engine.apu.signal_value("clip", "time")))
        joints.append(emb.joint_positions(frame.position))
    compared = ["body_yaw", "neck_pitch", "head_yaw", "head_roll", "ear_left", "ear_right"]
    angles = blender.run(
        """
        rig = bpy.data.objects["nutty_desk"]
        result = joint_angles(rig, args["joints"], [1 + t * 24 for t in args["times"]])
    """,
        joints={j: v for j, v in joint_map(robot, rig).items() if j in compared},
        times=times,
    )
    index = {j: emb.joint_names.index(j) for j in compared}
    errors = {
        j: float(np.degrees(np.abs(np.array(angles[j]) - np.array(joints)[:, index[j]])).max())
        for j in compared
    }
    print("max |engine - Blender| per joint (deg):", {j: round(e, 5) for j, e in errors.items()})
    assert max(errors.values()) <= 0.1, errors
    assert max(abs(a) for a in angles["body_yaw"]) > 0.05  # gaze_yaw moved the body through its driver


# --- 3. check limits ----------------------------------------------------------------------------------


def test_check_limits_marks_the_frames_where_the_clip_breaks_a_limit_at_the_engines_rate(
    blender, server, tmp_path
):
    """Check limits posts the exported clip; the server judges it at the engine's rate and answers at
    the scene's frames. The add-on shows exactly that answer: a marker per range (the limit that
    breaks), the list with every limit broken, the bone and curve colours, the suggestion."""
    load_rig(blender, server.url)
    path = tmp_path / "whip.json"
    got = blender.run(
        """
        rig = bpy.data.objects["nutty_desk"]
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = 1, 48
        # a whip to the side at frame 10, then a fast sweep (linear, 2.6 rad/s); the ear within every limit
        key(rig, "head_yaw", [(1, 0.0), (10, 0.0), (14, 1.0), (24, 1.1), (44, -1.1), (48, -1.1)])
        fc = nutty_blender.rig.fcurves(rig)[0]
        sorted(fc.keyframe_points, key=lambda k: k.co[0])[3].interpolation = "LINEAR"
        key(rig, "ear_left", [(1, 0.0), (48, 0.1)])
        bpy.ops.nutty.export_clip(target="FILE", filepath=args["path"])
        bpy.ops.nutty.check_limits()
        s = scene.nutty
        curves = {fc.data_path: (fc.color_mode, list(fc.color)) for fc in nutty_blender.rig.fcurves(rig)}
        result = {"ranges": [[r.dof, r.bone, r.kind, r.frame_start, r.frame_end, r.worst_ratio, r.limits]
                             for r in s.ranges],
                  "markers": sorted([m.name, m.frame] for m in scene.timeline_markers),
                  "summary": s.check_summary, "suggestion": s.suggestion, "curves": curves,
                  "colours": {b.name: [b.color.palette, list(b.color.custom.normal)] for b in rig.pose.bones}}
    """,
        path=str(path),
    )
    clip = json.loads(path.read_text())
    answer = httpx.post(f"{server.url}/api/analyze", json={"rate": FPS, "clip": clip}).json()
    assert answer["engine_rate"] == RATE and answer["rate"] == FPS  # judged at the engine's rate
    expected = [
        [r["dof"], r["kind"], 1 + r["start"], 1 + r["end"], pytest.approx(r["worst_ratio"], rel=1e-6)]
        for r in answer["ranges"]
    ]
    assert [[r[0], r[2], r[3], r[4], r[5]] for r in got["ranges"]] == expected and expected
    for shown, r in zip(got["ranges"], answer["ranges"]):  # every limit broken: "velocity 2.1x, jerk 5x"
        assert shown[6] == ", ".join(f"{k} {v:.1f}x" for k, v in r["limits"].items())
        assert r["kind"] in r["limits"]
    assert all(r[0] == r[1] == "head_yaw" for r in got["ranges"])  # only the whip, on the head_yaw bone
    assert min(r[3] for r in got["ranges"]) in (10, 11)  # where the whip starts
    assert {"velocity"} <= {r[2] for r in got["ranges"]}  # the sweep is too fast
    markers = [m for m in got["markers"] if m[0].startswith("nutty:")]
    assert sorted(m[1] for m in markers) == sorted(r[3] for r in got["ranges"])
    assert all(m[0].split()[0] in ("nutty:velocity", "nutty:acceleration", "nutty:jerk") for m in markers)
    severity = ("velocity", "acceleration", "jerk", "position")
    worst = severity[max(severity.index(r[2]) for r in got["ranges"])]
    hex_colour = answer["colours"][worst].lstrip("#")  # the bone in its worst range's colour
    rgb = [int(hex_colour[k : k + 2], 16) / 255 for k in (0, 2, 4)]
    assert got["colours"]["head_yaw"] == ["CUSTOM", pytest.approx(rgb, abs=1e-3)]
    assert got["colours"]["ear_left"][0] == "DEFAULT"
    assert got["curves"]['pose.bones["head_yaw"].rotation_euler'][0] == "CUSTOM"
    assert got["summary"].startswith(f"{len(got['ranges'])} ranges over the limits on 1 DoF")
    # the linear sweep jumps in velocity (an acceleration step at any speed): no slow-down fits, and
    # the panel says so in the server's words
    assert got["suggestion"] == answer["suggestion"] and got["suggestion"]
    assert answer["fit_scale"] is None


def test_check_limits_with_physics_says_what_the_motors_make_of_the_clip(blender, server):
    """With the Physics switch, the same check also asks the server for the clip in MuJoCo; the panel
    says it in the add-on's words, from the server's own answer."""
    load_rig(blender, server.url)
    got = blender.run(
        """
        rig = bpy.data.objects["nutty_desk"]
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = 1, 36
        key(rig, "neck_pitch", [(1, 0.0), (12, 0.35), (24, -0.2), (36, 0.0)])
        scene.nutty.check_physics = True
        bpy.ops.nutty.check_limits()
        summary = scene.nutty.physics_summary
        clip, _ = nutty_blender.clip.export_clip(rig, nutty_blender.rig.plan_of(rig), scene, "probe")
        scene.nutty.check_physics = False
        bpy.ops.nutty.check_limits()
        result = {"summary": summary, "after": scene.nutty.physics_summary, "clip": clip}
    """
    )
    answer = httpx.post(
        f"{server.url}/api/analyze", json={"rate": FPS, "clip": got["clip"], "fit": False, "physics": True}
    ).json()["physics"]
    worst = answer["filtered"]["worst_joint"]
    assert worst == "neck_pitch" and answer["filtered"]["joints"][worst]["peak_error"] > 0
    assert got["summary"].startswith(f"physics: {worst} off by ") and "filtered" in got["summary"]
    assert f"{answer['filtered']['joints'][worst]['peak_error']:.3f} filtered" in got["summary"]
    assert got["after"] == ""  # switched off: no physics asked, the last verdict cleared


# --- 4. the ghost -------------------------------------------------------------------------------------


def test_ghost_keys_equal_the_servers_filter_of_the_exported_clip(blender, server, tmp_path):
    load_rig(blender, server.url)
    got = blender.run("""
        rig = bpy.data.objects["nutty_desk"]
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = 1, 36
        key(rig, "head_yaw", [(1, 0.0), (6, 0.9), (20, -0.5), (36, 0.0)])   # faster than the robot can follow
        key(rig, "gaze_pitch", [(1, 0.0), (8, 0.3)])
        scene.nutty.ghost_preset = "PROGRAM"
        bpy.ops.nutty.ghost()
        g = bpy.data.objects["nutty_desk.ghost"]
        keys = {fc.data_path: [list(k.co) for k in fc.keyframe_points] for fc in nutty_blender.rig.fcurves(g)}
        interps = {k.interpolation for fc in nutty_blender.rig.fcurves(g) for k in fc.keyframe_points}
        mats = {s.material.name for c in g.children for s in c.material_slots}
        alpha = [c.color[3] for c in g.children]
        scene.frame_set(1)  # both at rest: each ghost mesh stands where its original does, shifted beside it
        shift = g.matrix_world @ rig.matrix_world.inverted()
        originals = {c.data.name: c for c in rig.children}
        placed = max(max(abs(x) for row in (c.matrix_world - shift @ originals[c.data.name].matrix_world) for x in row)
                     for c in g.children)
        result = {"keys": keys, "interps": sorted(interps), "mats": sorted(mats), "alpha": max(alpha),
                  "meshes": len(g.children), "ghost_of": g["_nutty_ghost_of"], "placed": placed,
                  "beside": list(shift.translation)}
    """)
    assert got["ghost_of"] == "nutty_desk" and got["meshes"] == 17 and got["mats"] == ["Nutty ghost"]
    assert got["alpha"] < 1.0 and got["interps"] == ["LINEAR"]
    assert (
        got["placed"] < 1e-6 and got["beside"][0] == 0 and 0.2 < got["beside"][1] < 0.4
    )  # one robot width left
    # the reference: the exported clip, posted to the server by this test (filtered at the engine's rate)
    path = tmp_path / "ghost.json"
    angles = blender.run(
        """
        rig = bpy.data.objects["nutty_desk"]
        bpy.ops.nutty.export_clip(target="FILE", filepath=args["path"])
        values = {"head_yaw": [], "gaze_pitch": []}
        for f in range(1, 37):
            bpy.context.scene.frame_set(f)
            values["head_yaw"].append(rig.pose.bones["head_yaw"].rotation_euler[1])
            values["gaze_pitch"].append(rig["gaze_pitch"])
        result = values
    """,
        path=str(path),
    )
    clip = json.loads(path.read_text())
    answer = httpx.post(f"{server.url}/api/filter", json={"rate": FPS, "clip": clip}).json()
    assert answer["engine_rate"] == RATE and answer["rate"] == FPS
    filtered = answer["tracks"]
    head = np.array(got["keys"]['pose.bones["head_yaw"].rotation_euler'])
    gaze = np.array(got["keys"]['["gaze_pitch"]'])
    assert np.array_equal(head[:, 0], np.arange(1, 37)) and np.array_equal(gaze[:, 0], np.arange(1, 37))
    assert np.allclose(head[:, 1], filtered["head_yaw"], atol=1e-6)  # Blender keeps float32
    assert np.allclose(gaze[:, 1], filtered["gaze_pitch"], atol=1e-6)
    assert np.abs(head[:, 1] - np.array(angles["head_yaw"])).max() > 0.1  # the ghost really lags behind


# --- 5. the live link ---------------------------------------------------------------------------------


class Watch:
    """/ws/telemetry in a thread: every message's head_yaw, classes, corrected channels and puppet weight."""

    def __init__(self, ws_url: str):
        self.samples: list[dict] = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, args=(ws_url,), daemon=True)
        self.thread.start()

    def _run(self, ws_url: str) -> None:
        from websockets.sync.client import connect

        with connect(ws_url + "/ws/telemetry") as ws:
            ws.send(
                json.dumps(
                    {
                        "type": "subscribe",
                        "signals": [{"node": "puppet", "port": "weight"}],
                        "frames": True,
                        "rate": 60,
                    }
                )
            )
            while not self.stop.is_set():
                try:
                    msg = json.loads(ws.recv(timeout=0.5))
                except TimeoutError:
                    continue
                if msg.get("type") == "telemetry" and "puppet.weight" in msg.get("signals", {}):
                    self.samples.append(
                        {
                            "t": time.monotonic(),
                            "weight": msg["signals"]["puppet.weight"],
                            "position": msg["frame"]["position"],
                            "classes": msg["frame"]["classes"],
                            "corrected": msg["frame"]["corrected"],
                        }
                    )

    def wait(self, condition, timeout: float = 30.0) -> dict:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.samples and condition(self.samples[-1]):
                return self.samples[-1]
            time.sleep(0.05)
        raise AssertionError(
            f"not reached within {timeout} s; last: {self.samples[-1] if self.samples else None}"
        )

    def close(self) -> None:
        self.stop.set()
        self.thread.join(5)


def pump(blender, stop_file: Path) -> threading.Thread:
    """Blender's timer, driven by hand (bpy has no event loop headless): until `stop_file` exists."""

    def run() -> None:
        with contextlib.suppress(BlenderError):  # a failing test reports its own error
            blender.run(
                """
                import time, os
                deadline = time.monotonic() + 60
                while not os.path.exists(args["stop"]) and time.monotonic() < deadline:
                    nutty_blender.live.LINK.tick()
                    time.sleep(0.05)
            """,
                timeout=90,
                stop=str(stop_file),
            )

    t = threading.Thread(target=run, daemon=True)
    t.start()
    return t


def test_live_link_puppeteers_the_robot_within_its_limits(blender, server, emb, tmp_path):
    load_rig(blender, server.url)
    watch = Watch(server.ws_url)
    stops = [tmp_path / "stop-1", tmp_path / "stop-2"]
    try:
        watch.wait(lambda s: s["weight"] == 0.0)  # the puppet layer is off
        started = blender.run("""
            rig = bpy.data.objects["nutty_desk"]
            rig.pose.bones["head_yaw"].rotation_euler[1] = 0.6
            rig.pose.bones["ear_left"].rotation_euler[1] = 5.0   # beyond its limit: the link sends 0.7
            bpy.ops.nutty.live_link(action="START")
            rig.pose.bones["head_yaw"].rotation_euler[1] = 0.7   # posing sends the new pose (depsgraph handler)
            bpy.context.view_layer.update()
            link = nutty_blender.live.LINK
            result = {"running": link.running, "sent": link.sent, "last": link.last}
        """)
        assert started["running"] and started["sent"] == 2
        assert started["last"]["head_yaw"] == pytest.approx(0.7) and started["last"][
            "ear_left"
        ] == pytest.approx(0.7)
        stop = stops[0]
        pumping = pump(blender, stop)
        watch.wait(lambda s: abs(s["position"]["head_yaw"] - 0.7) < 0.01 and s["weight"] == 1.0)
        watch.wait(lambda s: abs(s["position"]["ear_left"] - 0.7) < 0.01)  # at its limit, not beyond
        stop.touch()
        pumping.join(60)
        # the link drops (no release, no more messages): the server's watchdog fades the layer out
        blender.run("""
            import time
            link = nutty_blender.live.LINK
            link.ws.sock.close()  # the connection dies under the link
            deadline = time.monotonic() + 10
            while link.running and time.monotonic() < deadline:
                link.tick()  # the timer notices and stops the link
                time.sleep(0.05)
        """)
        watch.wait(lambda s: s["weight"] == 0.0)
        assert blender.run("result = nutty_blender.live.LINK.status").startswith("dropped")
        watch.wait(lambda s: abs(s["position"]["head_yaw"]) < 0.2)  # back to the program's own pose
        # again, then an orderly stop: `release` fades it out at once
        blender.run('bpy.ops.nutty.live_link(action="START")')
        stop = stops[1]
        pumping = pump(blender, stop)
        watch.wait(lambda s: abs(s["position"]["head_yaw"] - 0.7) < 0.01)
        stop.touch()
        pumping.join(60)
        blender.run('bpy.ops.nutty.live_link(action="STOP")')
        watch.wait(lambda s: s["weight"] == 0.0)
    finally:
        for stop in stops:  # a failing wait leaves no pump behind
            stop.touch()
        watch.close()
    assert max(s["weight"] for s in watch.samples) == 1.0
    lo, hi = emb.min, emb.max
    for s in watch.samples:  # every frame sent to the robot within every limit, none corrected by the net
        assert s["classes"] == {} and s["corrected"] == []
        for name, v in s["position"].items():
            i = emb.channel_index[name]
            assert lo[i] - 1e-6 <= v <= hi[i] + 1e-6, name


# --- 6. what a user sees when something is wrong ------------------------------------------------------


def test_clear_reports_never_tracebacks(blender, server, tmp_path):
    down = f"http://127.0.0.1:{free_port()}"
    load_rig(blender, server.url)
    errors = blender.run(
        """
        s = bpy.context.scene.nutty
        rig = bpy.data.objects["nutty_desk"]
        result = {"no_keys": {name: operator_error(op) for name, op in (
            ("export", bpy.ops.nutty.export_clip), ("check", bpy.ops.nutty.check_limits),
            ("ghost", bpy.ops.nutty.ghost))}}
        key(rig, "head_yaw", [(1, 0.0), (10, 0.2)])
        s.server_url = args["down"]
        result["down"] = {name: operator_error(op) for name, op in (
            ("load", bpy.ops.nutty.load_robot), ("export", bpy.ops.nutty.export_clip),
            ("check", bpy.ops.nutty.check_limits), ("ghost", bpy.ops.nutty.ghost),
            ("live", bpy.ops.nutty.live_link))}
        s.server_url = "ftp://nowhere"
        result["bad_url"] = operator_error(bpy.ops.nutty.load_robot)
        s.server_url = args["up"]
        bpy.context.scene.timeline_markers.new("sound:trumpet", frame=3)
        result["bad_marker"] = operator_error(bpy.ops.nutty.export_clip)
        bpy.context.scene.timeline_markers.clear()
        s.clip_name = "../escape"
        result["bad_name"] = operator_error(bpy.ops.nutty.export_clip)
        s.clip_name = ""
        bpy.context.scene.frame_start = 5
        result["before_start"] = operator_error(bpy.ops.nutty.export_clip)
    """,
        down=down,
        up=server.url,
    )
    for message in [
        *errors["no_keys"].values(),
        *errors["down"].values(),
        errors["bad_url"],
        errors["bad_marker"],
        errors["bad_name"],
        errors["before_start"],
    ]:
        assert message and "Traceback" not in message and "unexpected" not in message, message
    assert all("has no key" in m for m in errors["no_keys"].values()), errors["no_keys"]
    assert all(f"cannot reach nutty serve at {down}" in m for m in errors["down"].values()), errors["down"]
    assert "not an http:// URL" in errors["bad_url"]
    assert "'trumpet' is not one of the robot's sounds" in errors["bad_marker"]
    assert "invalid clip name '../escape'" in errors["bad_name"]
    assert "before the scene's start frame 5" in errors["before_start"]


def test_a_robot_with_unsupported_joints_is_refused_by_name(blender, tmp_path):
    """A real server (create_app under uvicorn) whose robot has a prismatic lift the add-on cannot rig."""
    from backend.api import create_app
    from backend.commands.serve import builtin_idle
    from backend.session import EngineSession

    urdf = tmp_path / "lift.urdf"
    urdf.write_text("""<?xml version="1.0"?>
<robot name="lift">
  <link name="base"><visual><geometry><box size="0.2 0.2 0.1"/></geometry></visual></link>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.3" velocity="0.2" effort="10"/></joint>
  <link name="arm"><visual><geometry><box size="0.05 0.05 0.3"/></geometry></visual></link>
  <joint name="wrist" type="revolute"><parent link="arm"/><child link="hand"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <link name="hand"/>
</robot>""")
    emb = load_embodiment(urdf)
    session = EngineSession.create(emb, rate=50, program=builtin_idle(emb.name))
    with running_app(create_app(session, frontend_dir=None)) as (_, _, port):
        message = blender.run(
            """
            reset_scene()
            bpy.context.scene.nutty.server_url = args["url"]
            result = operator_error(bpy.ops.nutty.load_robot)
        """,
            url=f"http://127.0.0.1:{port}",
        )
    assert message is not None and "Traceback" not in message
    assert "'lift' (prismatic)" in message and "revolute and continuous" in message
    assert blender.run("result = [o.name for o in bpy.data.objects]") == []  # nothing half-built


# --- 7. the installable zip ---------------------------------------------------------------------------


def test_make_blender_addon_zip_installs_and_enables_in_blender(tmp_path):
    """`make blender-addon`'s zip passes Blender's own extension validation and installs into a fresh
    Blender (its own user folders in tmp_path), which registers the Nutty operators and menu."""
    # --no-print-directory: under `make test` this make is a sub-make, which would print its directory.
    done = subprocess.run(
        ["make", "-s", "--no-print-directory", "blender-addon", f"DIST={tmp_path}"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    zip_path = Path(next(line for line in reversed(done.stdout.splitlines()) if line.endswith(".zip")))
    assert zip_path.parent == tmp_path and zip_path.name.startswith("nutty_blender-"), done.stdout
    checked = subprocess.run(
        [sys.executable, str(bpy_paths.blender_ext()), "validate", str(zip_path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert checked.returncode == 0 and "Success" in checked.stdout, checked.stdout + checked.stderr
    script = f"""
import bpy
bpy.ops.extensions.package_install_files(filepath={str(zip_path)!r}, repo="user_default", enable_on_install=True)
print("ENABLED", [k for k in bpy.context.preferences.addons.keys() if k.endswith("nutty_blender")])
names = ("load_robot", "export_clip", "import_clip", "check_limits", "ghost", "live_link")
print("OPERATORS", all(hasattr(bpy.ops.nutty, n) for n in names))
print("MENU", bpy.types.NUTTY_MT_menu.bl_label)
"""
    env = {**os.environ, "HOME": str(tmp_path), "BLENDER_USER_RESOURCES": str(tmp_path / "blender")}
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, env=env)
    assert "ENABLED ['bl_ext.user_default.nutty_blender']" in run.stdout, (
        run.stdout[-3000:] + run.stderr[-3000:]
    )
    assert "OPERATORS True" in run.stdout and "MENU Nutty" in run.stdout


def test_live_link_to_a_program_without_a_puppet_layer_says_so(blender):
    """A real server (create_app under uvicorn) running the built-in idle program, which has no puppet
    block: Live link is refused at once, in the report, and nothing keeps running."""
    from backend.api import create_app
    from backend.commands.serve import builtin_idle
    from backend.session import EngineSession

    desk = load_embodiment("nutty_desk")
    session = EngineSession.create(desk, rate=50, program=builtin_idle(desk.name))
    with running_app(create_app(session, frontend_dir=None)) as (_, _, port):
        got = blender.run(
            """
            reset_scene()
            bpy.context.scene.nutty.server_url = args["url"]
            bpy.ops.nutty.load_robot()
            message = operator_error(bpy.ops.nutty.live_link, action="START")
            link = nutty_blender.live.LINK
            result = {"message": message, "running": link.running,
                      "handlers": nutty_blender.live._on_change in bpy.app.handlers.frame_change_post}
        """,
            url=f"http://127.0.0.1:{port}",
        )
    assert got["message"] and "Traceback" not in got["message"]
    assert "refused the live link" in got["message"] and "no puppet block" in got["message"]
    assert got["running"] is False and got["handlers"] is False


def test_the_add_on_sends_the_token_when_the_server_has_one(blender, tmp_path):
    """A real server with a token (create_app under uvicorn, the interactive program): reading needs none;
    saving a clip and the live link are refused without it, with a message that says so, and work with it."""
    from backend.api import create_app
    from backend.session import EngineSession

    desk = load_embodiment("nutty_desk")
    program = (ROOT / "robots" / "nutty_desk" / "programs" / "interactive.json").read_text()
    session = EngineSession.create(desk, rate=50, program_text=program)
    session.library.folder = tmp_path  # the clip lands here, not in the repository
    with running_app(create_app(session, token="s3cret", frontend_dir=None)) as (_, _, port):
        got = blender.run(
            """
            reset_scene()
            s = bpy.context.scene.nutty
            s.server_url, s.clip_name = args["url"], "token_test"
            wm = bpy.context.window_manager
            wm.nutty_token = ""
            result = {"load": operator_error(bpy.ops.nutty.load_robot)}   # reading is open
            key(bpy.data.objects["nutty_desk"], "head_yaw", [(1, 0.0), (20, 0.1)])
            result["export"] = operator_error(bpy.ops.nutty.export_clip)
            result["live"] = operator_error(bpy.ops.nutty.live_link, action="START")
            wm.nutty_token = "s3cret"
            result["export_with"] = operator_error(bpy.ops.nutty.export_clip)
            result["live_with"] = operator_error(bpy.ops.nutty.live_link, action="START")
            result["running"] = nutty_blender.live.LINK.running
            bpy.ops.nutty.live_link(action="STOP")
            wm.nutty_token = ""
        """,
            url=f"http://127.0.0.1:{port}",
        )
    assert got["load"] is None and got["export_with"] is None and got["live_with"] is None and got["running"]
    assert "needs its token" in got["export"]
    assert "needs its token" in got["live"]
    assert (tmp_path / "clips" / "token_test.json").exists()
