"""The robot's visual meshes as one GLB (glTF 2.0 binary), for DCC tools (GET /api/robot/scene.glb).

Built from the URDF with yourdfpy and trimesh, with every joint at zero (the pose `joint_frames`
describes): one glTF node per URDF `<visual>`, all at the top level (no hierarchy), whose transform is
where the visual sits in the robot's base frame. Each node is named `<link>|<n>` (n counts the link's visuals)
and its mesh carries `{"nutty_link": "<link>"}` in its extras, so a rig can parent it to the bone of the
joint that moves that link. glTF is +Y up: the robot's +Z up / +X forward is converted the standard way
(x, y, z) -> (x, z, -y), nodes and vertices alike, which Blender's glTF importer turns back exactly:
each imported object's matrix is then the visual's transform in the robot's frame.
Colours come from the URDF's materials as PBR base colours. Units: metres.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from backend.engine.embodiment import Embodiment

# robot frame (+Z up) -> glTF frame (+Y up)
Z_UP_TO_Y_UP = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)

_cache: dict[tuple[str, float], bytes] = {}
_lock = threading.Lock()


class NoVisuals(ValueError):
    """The robot has no URDF, or its URDF has no visual geometry to show."""


def _material(mesh: Any) -> None:
    """Give a mesh coloured by the URDF (face colours) one PBR material of that colour instead, which
    every glTF reader shows (vertex colours are often ignored)."""
    # trimesh is heavy, imported only to build a GLB; its submodules by name (the package does not declare them)
    from trimesh.visual import TextureVisuals
    from trimesh.visual.material import PBRMaterial  # (the same)

    visual = mesh.visual
    if getattr(visual, "kind", None) in ("face", "vertex"):
        rgba = np.asarray(visual.main_color, dtype=float) / 255.0
        mesh.visual = TextureVisuals(
            material=PBRMaterial(
                baseColorFactor=[float(x) for x in rgba], metallicFactor=0.0, roughnessFactor=0.6
            )
        )


def _build(urdf_path: Path) -> bytes:
    # trimesh and yourdfpy load only when a client first asks for the robot's scene
    import trimesh
    import yourdfpy

    try:
        urdf = yourdfpy.URDF.load(
            str(urdf_path), build_scene_graph=True, load_meshes=True, build_collision_scene_graph=False
        )
    except Exception as exc:  # yourdfpy raises many types for malformed files
        raise NoVisuals(f"cannot read URDF '{urdf_path.name}': {exc}") from exc
    source = urdf.scene
    graph = source.graph
    out = trimesh.Scene()
    counts: dict[str, int] = {}
    for node in graph.nodes_geometry:
        transform, geometry_name = graph[node]
        geometry = source.geometry.get(geometry_name)
        if geometry is None or not hasattr(geometry, "faces"):
            continue
        link = graph.transforms.parents.get(node, graph.base_frame)
        n = counts.get(link, 0)
        counts[link] = n + 1
        mesh = geometry.copy()
        mesh.apply_transform(Z_UP_TO_Y_UP)  # vertices in glTF axes too: a reader's object frame = the URDF's
        _material(mesh)
        mesh.metadata = {"nutty_link": link}
        name = f"{link}|{n}"
        out.add_geometry(
            mesh, node_name=name, geom_name=name, transform=Z_UP_TO_Y_UP @ transform @ Z_UP_TO_Y_UP.T
        )
    if not counts:
        raise NoVisuals(f"the URDF '{urdf_path.name}' has no visual geometry")
    glb = out.export(file_type="glb")
    if not isinstance(glb, bytes):  # trimesh gives bytes for a binary format
        raise TypeError(f"trimesh exported {type(glb).__name__}, not bytes, as GLB")
    return glb


def scene_glb(emb: Embodiment) -> bytes:
    """The GLB of `emb`'s visuals (see the module doc), cached per URDF file and modification time.
    Raises NoVisuals when there is nothing to show."""
    if emb.urdf_path is None:
        raise NoVisuals(f"robot '{emb.name}' has no URDF")
    path = Path(emb.urdf_path).resolve()
    key = (str(path), path.stat().st_mtime)
    with _lock:
        if key not in _cache:
            _cache[key] = _build(path)
        return _cache[key]
