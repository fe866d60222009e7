"""A robot's mesh files for Foxglove: the URDF text as the viewer gets it, and the asset handler that
answers the viewer's fetches from the robot folder and nowhere else.

Foxglove's URDF layer, fed the URDF from a topic, cannot resolve a mesh path relative to the URDF file
(it has no file), so `urdf_for_viewer` rewrites relative mesh paths to `package://<folder name>/<path
within the robot folder>`. When connected to a server with the `assets` capability, the viewer fetches
`package://` URIs from it; `RobotAssets` maps `package://<any package>/<path>` to `<robot folder>/<path>`
and serves only existing files with a mesh or texture suffix inside the robot folder.
"""

from __future__ import annotations

import logging
import re
from pathlib import Path, PurePosixPath
from urllib.parse import unquote, urlparse

from backend.engine.embodiment import Embodiment

log = logging.getLogger(__name__)

#: What a URDF's visuals refer to: meshes and the textures a mesh file names.
ASSET_SUFFIXES = frozenset(
    {".stl", ".dae", ".obj", ".mtl", ".glb", ".gltf", ".bin", ".ply", ".png", ".jpg", ".jpeg", ".ktx2"}
)

_MESH_FILENAME = re.compile(r'(<mesh\b[^>]*?\bfilename\s*=\s*)(["\'])(.*?)\2', re.DOTALL)


class AssetRefused(PermissionError):
    """A fetch for something that is not a mesh or texture file inside the robot folder."""


def robot_folder(emb: Embodiment) -> Path:
    """The robot's folder: the nearest folder above the URDF holding embodiment.yaml, else the URDF's."""
    if emb.urdf_path is None:
        raise ValueError(f"robot '{emb.name}' has no URDF")
    urdf = Path(emb.urdf_path).resolve()
    for folder in urdf.parents:
        if (folder / "embodiment.yaml").is_file():
            return folder
    return urdf.parent


def urdf_for_viewer(emb: Embodiment) -> str:
    """The URDF text with each relative mesh path (inside the robot folder) as a `package://` URI."""
    folder = robot_folder(emb)
    urdf_dir = Path(emb.urdf_path or folder).resolve().parent
    text = Path(emb.urdf_path or folder).read_text(encoding="utf-8")

    def rewrite(match: re.Match[str]) -> str:
        ref = match.group(3)
        if "://" in ref or ref.startswith("/"):
            return match.group(0)
        target = (urdf_dir / ref).resolve()
        if not target.is_relative_to(folder):
            return match.group(0)
        uri = f"package://{folder.name}/{target.relative_to(folder).as_posix()}"
        return f"{match.group(1)}{match.group(2)}{uri}{match.group(2)}"

    return _MESH_FILENAME.sub(rewrite, text)


class RobotAssets:
    """The SDK's asset handler: `handler(uri)` -> the file's bytes, None when there is no such file;
    raises `AssetRefused` (the viewer sees its message) for a path outside the robot folder or a file
    that is not a mesh or texture. Accepts `package://<package>/<path>` and `file://` URIs."""

    def __init__(self, folder: Path):
        self.folder = Path(folder).resolve()
        self.served = self.refused = 0

    def path(self, uri: str) -> Path:
        """The file a URI names inside the robot folder; raises AssetRefused otherwise."""
        parsed = urlparse(uri)
        if parsed.scheme == "package":
            # package://<package>/<path>: the package is the robot folder, whatever it is called
            relative = PurePosixPath(unquote(parsed.path).lstrip("/"))
            target = (self.folder / relative).resolve()
        elif parsed.scheme == "file":
            target = Path(unquote(parsed.path)).resolve()
        else:
            raise AssetRefused(f"asset URI '{uri}': only package:// and file:// URIs are served")
        if not target.is_relative_to(self.folder):
            raise AssetRefused(f"asset '{uri}' is outside the robot folder")
        if target.suffix.lower() not in ASSET_SUFFIXES:
            raise AssetRefused(
                f"asset '{uri}' is not a mesh or texture file ({', '.join(sorted(ASSET_SUFFIXES))})"
            )
        return target

    def __call__(self, uri: str) -> bytes | None:
        try:
            target = self.path(uri)
        except AssetRefused:
            self.refused += 1
            log.warning("foxglove: refused asset fetch %r", uri)
            raise
        if not target.is_file():
            return None
        self.served += 1
        return target.read_bytes()
