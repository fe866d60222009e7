"""glTF times and animations without Blender (tests/test_import_blender_scenes.py has Blender's own):
the first key is the clip's t = 0 and the report says by how much the times moved; a channel the
mapping file names is taken from the one other animation that animates it; a bare name split between
several DoFs means the node's rotation even when its translation and scale are animated too."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_import import G, GltfBuilder, qa
from test_import_hints import gltf_animations

from backend.cli import main
from backend.engine.clips import compile_clip
from backend.importers import ClipImportError, import_clip
from backend.importers.rotations import quat_mul


def value(doc: dict, emb, dof: str, t: float) -> float:
    comp = compile_clip(doc, emb)
    out = np.zeros(emb.n_channels)
    comp.sample(t, np.asarray(emb.rest), out)
    return float(out[emb.dof(dof).channels.start])


def yaw_file(path, times, angles, interp: str = "LINEAR"):
    b = GltfBuilder()
    node = b.node("head_yaw")
    b.channel(node, "rotation", times, qa(G([0, 0, 1]), angles), "VEC4", interp=interp)
    return b.save(path)


def test_blender_frames_from_1_start_at_0(tmp_path, desk):
    """Blender's default export of a scene starting at frame 1, sampled at 24 fps: t = frame / 24."""
    frames = np.arange(1, 26)
    angles = 0.6 * np.sin((frames - 1) / 24 * np.pi)
    doc, report = import_clip(yaw_file(tmp_path / "a.gltf", frames / 24, angles), desk)
    assert report["time_shift"] == pytest.approx(-1 / 24, abs=1e-7)
    assert doc["source"]["time_shift"] == report["time_shift"]
    assert doc["duration"] == pytest.approx(1.0, abs=1e-6)
    (note,) = [n for n in report["notes"] if "first key" in n]
    assert "(frame 1 at 24 fps)" in note and "shifted by -0.0416667 s" in note
    for k in (0, 6, 12, 24):  # frame 1 + k is t = k / 24
        assert value(doc, desk, "head_yaw", k / 24) == pytest.approx(angles[k], abs=1e-3)


def test_sparse_keys_are_shifted_and_said_so(tmp_path, desk):
    doc, report = import_clip(yaw_file(tmp_path / "a.gltf", [0.5, 1.0, 2.0], [0.0, 0.4, 0.0]), desk)
    assert report["time_shift"] == -0.5 and doc["tracks"]["head_yaw"][0]["t"] == 0.0
    assert doc["tracks"]["head_yaw"][1]["t"] == pytest.approx(0.5)
    (note,) = [n for n in report["notes"] if "first key" in n]
    assert (
        note
        == "the animation's first key is at 0.5 s in the file; shifted by -0.5 s so it is the clip's t = 0"
    )


def test_keys_from_0_are_not_moved(tmp_path, desk):
    doc, report = import_clip(yaw_file(tmp_path / "a.gltf", [0.0, 1.0], [0.0, 0.4]), desk)
    assert "time_shift" not in report and "time_shift" not in doc["source"]
    assert not any("first key" in n for n in report["notes"])


def test_a_mapped_channel_of_another_animation_is_taken_from_it(tmp_path, desk, capsys):
    """Blender exports a shape-key action as an animation of its own; the mapping names its channel."""
    src = gltf_animations(tmp_path / "a.gltf", {"wave": [("head_yaw", "yaw")], "face": [("Tail", "tilt")]})
    doc, report = import_clip(src, desk, {"joints": {"Tail": "head_roll"}})
    assert {"head_yaw", "head_roll"} <= set(doc["tracks"])
    assert any("'Tail' is not in animation #0 'wave'; taken from #1 'face'" in n for n in report["notes"])
    assert value(doc, desk, "head_roll", 0.5) == pytest.approx(0.3, abs=1e-3)
    # without the mapping naming it, only the first animation is imported
    doc, _ = import_clip(src, desk)
    assert set(doc["tracks"]) == {"head_yaw"}


def test_a_mapped_channel_of_two_other_animations_is_an_error(tmp_path, desk):
    anims = {"wave": [("head_yaw", "yaw")], "a": [("Tail", "tilt")], "b": [("Tail", "yaw")]}
    src = gltf_animations(tmp_path / "a.gltf", anims)
    with pytest.raises(ClipImportError, match=r"2 others do \('a', 'b'\).*--animation a or --animation b"):
        import_clip(src, desk, {"joints": {"Tail": "head_roll"}})
    doc, _ = import_clip(src, desk, {"joints": {"Tail": "head_roll"}}, animation="b")
    assert set(doc["tracks"]) == {"head_roll"}


def test_bare_name_split_ignores_translation_and_scale(tmp_path, desk, capsys):
    """Blender animates every bone's translation, rotation and scale: `"Head": [..]` is the rotation."""
    b = GltfBuilder()
    head = b.node("Head")
    t = [0.0, 0.5, 1.0]
    yaw, pitch = np.array([0.0, 0.4, -0.2]), np.array([0.0, 0.2, 0.1])
    b.channel(head, "translation", t, np.zeros((3, 3)), "VEC3")
    # the robot-frame product R_z(yaw) R_y(pitch)
    b.channel(head, "rotation", t, quat_mul(qa(G([0, 0, 1]), yaw), qa(G([0, 1, 0]), pitch)), "VEC4")
    b.channel(head, "scale", t, np.ones((3, 3)), "VEC3")
    src = b.save(tmp_path / "head.gltf")
    doc, _ = import_clip(src, desk, {"joints": {"Head": ["head_yaw", "head_pitch"]}})
    for k, tk in enumerate(t):
        assert value(doc, desk, "head_yaw", tk) == pytest.approx(yaw[k], abs=1e-3)
        assert value(doc, desk, "head_pitch", tk) == pytest.approx(pitch[k], abs=1e-3)
    # a translation still cannot be split, and says which channel it is
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps({"joints": {"Head.translation": ["base_x", "base_y"]}}))
    assert main(["import", str(src), "--map", str(mp), "--out", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err
    assert "'Head.translation' is a translation channel; only a rotation can drive several DoFs" in err
