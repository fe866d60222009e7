"""Render docs/blender.png with Blender's own renderer (Workbench, headless): the rig loaded from a running
`nutty serve`, a wave that is too fast in places, the Check limits verdict (coloured bones, coloured frame
ranges on the curve) and the ghost beside the rig.

    python blender/screenshot.py [--out docs/blender.png] [--url http://127.0.0.1:8000]

Needs a Python that can `import bpy` (the project's virtualenv after `make deps-python`). Without --url it
starts `nutty serve` itself on a copy of the bundled robot (so nothing is saved into robots/). The picture
is two renders stacked: the 3D view (X-ray shading, so the bones show through the shell; each bone drawn
as a stick in its Check limits colour) and the head's F-curve as the Graph Editor would show it: the
authored curve (white), the ghost's (blue), the offending frames in the editor's colours and the frame
shown above (the white line).
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "blender"), str(ROOT)]

import bpy  # noqa: E402 (after sys.path is set up for Blender)
import nutty_blender  # noqa: E402 (after sys.path is set up for Blender)
from mathutils import Matrix, Vector  # noqa: E402 (after sys.path is set up for Blender)

WIDTH, VIEW_HEIGHT, GRAPH_HEIGHT = 1280, 720, 300
FRAME = 14  # the frame shown: the head whips right while the ghost still lags behind
WAVE = {  # bone -> (frame, angle rad): a greeting with a whip of the head that breaks its limits
    "head_yaw": [(1, 0.0), (8, 0.0), (12, 0.7), (24, -0.5), (36, 0.4), (52, 0.0), (72, 0.0)],
    "neck_pitch": [(1, 0.0), (20, -0.15), (48, 0.15), (72, 0.0)],
    "head_roll": [(1, 0.0), (24, 0.2), (48, -0.2), (72, 0.0)],
    "ear_left": [(1, 0.0), (10, 0.6), (20, -0.6), (30, 0.6), (40, -0.6), (50, 0.4), (72, 0.0)],
    "ear_right": [(1, 0.0), (16, 0.5), (40, -0.3), (72, 0.0)],
    "body_yaw": [(1, 0.0), (36, 0.35), (72, 0.0)],
}


def start_server() -> tuple[subprocess.Popen, str, Path]:
    folder = Path(tempfile.mkdtemp(prefix="nutty-shot-"))
    shutil.copytree(ROOT / "robots" / "nutty_desk", folder / "nutty_desk")
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "backend.cli",
            "serve",
            "--robot",
            str(folder / "nutty_desk"),
            "--no-previz",
            "--port",
            str(port),
        ],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    url = f"http://127.0.0.1:{port}"
    deadline = time.time() + 180
    while time.time() < deadline:
        try:
            urllib.request.urlopen(url + "/api/status", timeout=2)
            return proc, url, folder
        except OSError:
            time.sleep(0.5)
    proc.kill()
    raise SystemExit("nutty serve did not start")


def material(name: str, rgba: tuple[float, float, float, float]) -> bpy.types.Material:
    """A material showing `rgba` (sRGB, as the editor's colours are written) in the render."""
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    linear = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in rgba[:3]]
    mat.diffuse_color = (*linear, rgba[3])
    return mat


def add_mesh(name: str, verts: list, faces: list, mat: bpy.types.Material, collection) -> bpy.types.Object:
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.materials.append(mat)
    ob = bpy.data.objects.new(name, mesh)
    collection.objects.link(ob)
    return ob


def bone_sticks(rig) -> None:
    """Each visible bone as an octahedral stick (Blender's bone shape) in its Check limits colour."""
    for pb in rig.pose.bones:
        if pb.bone.hide:
            continue
        colour = tuple(pb.color.custom.normal) if pb.color.palette == "CUSTOM" else (0.55, 0.6, 0.65)
        length = pb.bone.length
        w = 0.2 * length
        verts = [
            (0, 0, 0),
            (w, 0.2 * length, 0),
            (0, 0.2 * length, w),
            (-w, 0.2 * length, 0),
            (0, 0.2 * length, -w),
            (0, length, 0),
        ]
        faces = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 1), (5, 2, 1), (5, 3, 2), (5, 4, 3), (5, 1, 4)]
        ob = add_mesh(
            f"stick {pb.name}",
            verts,
            faces,
            material(f"stick {colour}", (*colour, 1.0)),
            rig.users_collection[0],
        )
        ob.parent, ob.parent_type, ob.parent_bone = rig, "BONE", pb.name
        tail = rig.matrix_world @ pb.bone.matrix_local @ Matrix.Translation((0, length, 0))
        ob.matrix_parent_inverse = tail.inverted()
        ob.matrix_basis = rig.matrix_world @ pb.bone.matrix_local


def render(scene, path: str, height: int) -> None:
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.render.filepath = path
    with bpy.context.temp_override(scene=scene):
        bpy.ops.render.render(write_still=True, scene=scene.name)


def view_3d(scene, rig) -> None:
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(cam)
    cam.location = (1.15, -0.45, 0.6)
    target = Vector((0.0, 0.16, 0.24))
    cam.rotation_euler = (target - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 38
    scene.camera = cam
    shading = scene.display.shading
    shading.light, shading.color_type = "STUDIO", "MATERIAL"
    shading.show_xray, shading.xray_alpha = True, 0.5  # as in the viewport's X-ray: the bones show through
    shading.show_shadows = False
    scene.view_settings.view_transform = "Standard"
    scene.world = scene.world or bpy.data.worlds.new("world")
    for ob, text in ((rig, "authored"), (bpy.data.objects["nutty_desk.ghost"], "ghost (stage-2 filter)")):
        label = bpy.data.objects.new(f"label {text}", bpy.data.curves.new(text, "FONT"))
        label.data.body, label.data.size, label.data.align_x = text, 0.03, "CENTER"
        label.data.materials.append(material("label", (0.95, 0.95, 0.95, 1)))
        label.location = ob.matrix_world.translation + Vector((0.12, 0.0, 0.0))  # on the floor, in front
        label.rotation_euler = (cam.location - label.location).to_track_quat("Z", "Y").to_euler()
        scene.collection.objects.link(label)


def graph(curves: dict[str, list[float]], ranges: list, frames: list[int], colours: dict) -> bpy.types.Scene:
    """A scene drawing the head's curves as the Graph Editor would, for an orthographic render."""
    scene = bpy.data.scenes.new("graph")
    col = scene.collection
    n = len(frames)
    lo = min(min(v) for v in curves.values()) - 0.05
    hi = max(max(v) for v in curves.values()) + 0.05
    top, bottom = 0.95, -1.35  # the curves' area; the label sits above it (the view is 12.4 x 2.9)
    sx, sy = 12.0 / (n - 1), (top - bottom) / (hi - lo)

    def xy(frame: float, value: float) -> tuple[float, float]:
        return (frame - frames[0]) * sx - 6.0, (value - lo) * sy + bottom

    for r in ranges:  # the offending frames, as bands behind the curves
        (x0, _), (x1, _) = xy(r.frame_start - 0.5, 0), xy(r.frame_end + 0.5, 0)
        add_mesh(
            f"band {r.frame_start}",
            [(x0, bottom, -0.1), (x1, bottom, -0.1), (x1, top, -0.1), (x0, top, -0.1)],
            [(0, 1, 2, 3)],
            material(f"band {r.kind}", (*colours[r.kind], 1.0)),
            col,
        )
    for name, (values, rgba, width) in {
        "authored": (curves["authored"], (0.95, 0.95, 0.95, 1), 0.05),
        "ghost": (curves["ghost"], (0.35, 0.7, 1.0, 1), 0.05),
    }.items():
        pts = [xy(f, v) for f, v in zip(frames, values)]
        verts, faces = [], []
        for (ax, ay), (bx, by) in zip(pts, pts[1:]):
            dx, dy = bx - ax, by - ay
            norm = math.hypot(dx, dy) or 1.0
            ox, oy = -dy / norm * width / 2, dx / norm * width / 2
            k = len(verts)
            verts += [
                (ax + ox, ay + oy, 0),
                (bx + ox, by + oy, 0),
                (bx - ox, by - oy, 0),
                (ax - ox, ay - oy, 0),
            ]
            faces.append((k, k + 1, k + 2, k + 3))
        add_mesh(name, verts, faces, material(name, rgba), col)
    zero = xy(frames[0], 0.0)[1]
    add_mesh(
        "zero",
        [
            (-6, zero - 0.01, -0.05),
            (6, zero - 0.01, -0.05),
            (6, zero + 0.01, -0.05),
            (-6, zero + 0.01, -0.05),
        ],
        [(0, 1, 2, 3)],
        material("axis", (0.35, 0.35, 0.35, 1)),
        col,
    )
    x = xy(FRAME, 0)[0]
    add_mesh(
        "now",
        [(x - 0.02, bottom, 0.05), (x + 0.02, bottom, 0.05), (x + 0.02, top, 0.05), (x - 0.02, top, 0.05)],
        [(0, 1, 2, 3)],
        material("now", (1, 1, 1, 1)),
        col,
    )
    label = bpy.data.curves.new("label", "FONT")
    label.body = (
        "head_yaw, frames 1-72: authored (white) and ghost (blue); frames over the velocity (orange), "
        "acceleration (pink) and jerk (red) limits"
    )
    label.size = 0.2
    text = bpy.data.objects.new("label", label)
    text.location = (-6.0, 1.1, 0.1)
    text.data.materials.append(material("text", (0.9, 0.9, 0.9, 1)))
    col.objects.link(text)
    cam = bpy.data.objects.new("graph camera", bpy.data.cameras.new("graph camera"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 12.4
    cam.location = (0, 0, 10)
    col.objects.link(cam)
    scene.camera = cam
    scene.display.shading.light, scene.display.shading.color_type = "FLAT", "MATERIAL"
    scene.world = bpy.data.worlds.new("graph world")
    scene.world.color = (0.11, 0.11, 0.11)
    scene.view_settings.view_transform = "Standard"  # the editor's colours as they are
    return scene


def stack(top: str, bottom: str, out: str) -> None:
    """One PNG: `top` above `bottom` (same width), with Blender's image API."""
    a, b = bpy.data.images.load(top), bpy.data.images.load(bottom)
    w, ha, hb = a.size[0], a.size[1], b.size[1]
    image = bpy.data.images.new("blender.png", w, ha + hb)
    image.pixels = list(b.pixels) + list(a.pixels)  # rows bottom first
    settings = bpy.context.scene.render.image_settings
    settings.file_format, settings.color_mode, settings.compression = "PNG", "RGB", 100
    image.save_render(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "blender.png"))
    ap.add_argument("--url", default=None, help="a running nutty serve (default: start one on a robot copy)")
    args = ap.parse_args()
    server = folder = None
    url = args.url
    if url is None:
        server, url, folder = start_server()
    try:
        nutty_blender.register()
        for ob in list(bpy.data.objects):
            bpy.data.objects.remove(ob)
        scene = bpy.context.scene
        scene.nutty.server_url = url
        scene.render.fps = 24
        bpy.ops.nutty.load_robot()
        rig = bpy.data.objects["nutty_desk"]
        scene.frame_start, scene.frame_end = 1, 72
        for bone, keys in WAVE.items():
            pb = rig.pose.bones[bone]
            for frame, value in keys:
                pb.rotation_euler[1] = value
                pb.keyframe_insert("rotation_euler", index=1, frame=frame)
        bpy.ops.nutty.check_limits()
        bpy.ops.nutty.ghost()
        ghost = bpy.data.objects["nutty_desk.ghost"]
        bone_sticks(rig)
        frames = list(range(1, 73))
        curves = {"authored": [], "ghost": []}
        for f in frames:
            scene.frame_set(f)
            curves["authored"].append(rig.pose.bones["head_yaw"].rotation_euler[1])
            curves["ghost"].append(ghost.pose.bones["head_yaw"].rotation_euler[1])
        scene.frame_set(FRAME)
        view_3d(scene, rig)
        from backend.engine.trajectory import CLASS_COLOURS  # the editor's colours

        colours = {k: nutty_blender.limits.hex_colour(v) for k, v in CLASS_COLOURS.items()}
        ranges = [r for r in scene.nutty.ranges if r.dof == "head_yaw"]
        tmp = Path(tempfile.mkdtemp(prefix="nutty-render-"))
        render(scene, str(tmp / "view.png"), VIEW_HEIGHT)
        render(graph(curves, ranges, frames, colours), str(tmp / "graph.png"), GRAPH_HEIGHT)
        stack(str(tmp / "view.png"), str(tmp / "graph.png"), args.out)
        print(f"wrote {args.out}: {scene.nutty.check_summary}")
    finally:
        if server is not None:
            server.terminate()
            server.wait(20)
            shutil.rmtree(folder, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
