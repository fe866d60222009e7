"""A URDF's joints and links as plain data, read by yourdfpy once per file content and cached on disk.

The embodiment (`kinematronics.read_urdf_joints`) and the kinematic chains (`kinematics`) both read
their joints from here. Importing yourdfpy pulls in trimesh, scipy and networkx (~0.8 s), which used to
come before a served robot's first frame; with the table cached, `nutty serve` reads a small JSON file
instead, and the Pre-Viz (its own process) is the only one to import yourdfpy.

The cache is keyed by the URDF's bytes, this format's version and yourdfpy's version, so an edited
file or a new yourdfpy is read again. It lives in `$NUTTY_CACHE_DIR/urdf` (default
`$XDG_CACHE_HOME/nutty/urdf`, else `~/.cache/nutty/urdf`); a cache that cannot be written is skipped.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from dataclasses import dataclass
from functools import lru_cache
from importlib import metadata
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

#: Bumped whenever the cached fields change.
FORMAT = 1

#: Environment variable naming the folder of Nutty's caches.
CACHE_ENV = "NUTTY_CACHE_DIR"


class UrdfReadError(ValueError):
    """A URDF yourdfpy cannot read; the message says why."""


@dataclass(frozen=True)
class JointRow:
    """One joint as the URDF gives it (angles in rad, lengths in m; None where the file says nothing)."""

    name: str
    type: str  # revolute, continuous, prismatic, fixed, floating, planar
    parent: str
    child: str
    origin: tuple[float, ...] | None  # the 4x4 transform, row-major (16 values)
    axis: tuple[float, float, float] | None
    lower: float | None
    upper: float | None
    velocity: float | None
    has_limit: bool
    mimic: tuple[str, float | None, float | None] | None  # (leader, multiplier, offset)


@dataclass(frozen=True)
class UrdfTable:
    """The URDF's joints (file order) and link names (file order)."""

    joints: tuple[JointRow, ...]
    links: tuple[str, ...]


def cache_dir() -> Path:
    """The folder of Nutty's caches (see the module's doc)."""
    given = os.environ.get(CACHE_ENV)
    if given:
        return Path(given)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "nutty"


def urdf_table(path: str | Path) -> UrdfTable:
    """The joints and links of the URDF at `path`; UrdfReadError when it cannot be read."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise UrdfReadError(f"cannot read URDF '{path}': {exc}") from exc
    return _table(str(path), hashlib.sha256(data).hexdigest())


@lru_cache(maxsize=32)
def _table(path: str, digest: str) -> UrdfTable:
    key = f"{digest[:32]}-f{FORMAT}-y{_yourdfpy_version()}.json"
    cached = cache_dir() / "urdf" / key
    try:
        return _from_json(json.loads(cached.read_text()))
    except (OSError, ValueError, KeyError, TypeError):
        pass  # not cached yet (or unreadable): read the URDF
    table = _read(path)
    _store(cached, table)
    return table


def _yourdfpy_version() -> str:
    try:
        return metadata.version("yourdfpy")
    except metadata.PackageNotFoundError:
        return "none"


def _read(path: str) -> UrdfTable:
    import yourdfpy  # lazy: slow to import (trimesh, scipy), and not needed once the table is cached

    try:
        urdf = yourdfpy.URDF.load(
            path, build_scene_graph=False, load_meshes=False, build_collision_scene_graph=False
        )
    except Exception as exc:  # yourdfpy raises many types for malformed files
        raise UrdfReadError(f"cannot read URDF '{path}': {exc}") from exc
    return table_of_robot(urdf.robot)


def table_of_robot(robot: Any) -> UrdfTable:
    """The table of a yourdfpy `URDF.robot` already loaded."""
    return UrdfTable(tuple(_row(j) for j in robot.joints), tuple(link.name for link in robot.links))


def _number(value: Any) -> float | None:
    return None if value is None else float(value)


def _row(j: Any) -> JointRow:
    lim, mimic = j.limit, j.mimic
    return JointRow(
        name=j.name,
        type=j.type,
        parent=j.parent,
        child=j.child,
        origin=None if j.origin is None else tuple(float(x) for x in j.origin.reshape(-1)),
        axis=None if j.axis is None else (float(j.axis[0]), float(j.axis[1]), float(j.axis[2])),
        lower=None if lim is None else _number(lim.lower),
        upper=None if lim is None else _number(lim.upper),
        velocity=None if lim is None else _number(lim.velocity),
        has_limit=lim is not None,
        mimic=None if mimic is None else (mimic.joint, _number(mimic.multiplier), _number(mimic.offset)),
    )


def _store(path: Path, table: UrdfTable) -> None:
    """Write the table atomically (a reader never sees half a file); a failure only costs speed."""
    doc = {
        "links": list(table.links),
        "joints": [{**row.__dict__} for row in table.joints],
    }
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=path.parent, suffix=".tmp", delete=False) as f:
            json.dump(doc, f)
        os.replace(f.name, path)
    except OSError as exc:
        log.debug("URDF cache not written (%s): %s", path, exc)


def _from_json(doc: dict[str, Any]) -> UrdfTable:
    joints = []
    for j in doc["joints"]:
        mimic = j["mimic"]
        joints.append(
            JointRow(
                name=str(j["name"]),
                type=str(j["type"]),
                parent=str(j["parent"]),
                child=str(j["child"]),
                origin=None if j["origin"] is None else tuple(float(x) for x in j["origin"]),
                axis=None
                if j["axis"] is None
                else (float(j["axis"][0]), float(j["axis"][1]), float(j["axis"][2])),
                lower=_number(j["lower"]),
                upper=_number(j["upper"]),
                velocity=_number(j["velocity"]),
                has_limit=bool(j["has_limit"]),
                mimic=None if mimic is None else (str(mimic[0]), _number(mimic[1]), _number(mimic[2])),
            )
        )
    return UrdfTable(tuple(joints), tuple(str(name) for name in doc["links"]))
