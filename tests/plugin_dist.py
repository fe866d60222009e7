"""A throwaway installed distribution for tests: its modules and `<name>-0.1.dist-info/` (METADATA and
entry_points.txt) written into a folder that is put on sys.path, where importlib.metadata finds it as
it finds any installed package. The four plugin registries are read again on the way in and out."""

from __future__ import annotations

import contextlib
import importlib
import sys
from collections.abc import Iterator
from pathlib import Path

from backend import control, drivers, importers
from backend.engine import blocks


def reload_registries() -> None:
    """Every registry reads its entry-point group again."""
    blocks.reload()
    control.REGISTRY.reload()
    drivers.reload()
    importers.reload()


def write_distribution(
    root: Path, name: str, entry_points: dict[str, dict[str, str]], files: dict[str, str] | None = None
) -> Path:
    """Write distribution `name` 0.1 into `root`: `files` (relative path -> text) and its metadata, with
    `entry_points` (group -> {entry name -> "module:Class"})."""
    root.mkdir(parents=True, exist_ok=True)
    for rel, text in (files or {}).items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    info = root / f"{name.replace('-', '_')}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "".join(
            f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items()) + "\n"
            for group, entries in entry_points.items()
        )
    )
    return root


@contextlib.contextmanager
def installed(
    root: Path,
    name: str,
    entry_points: dict[str, dict[str, str]],
    files: dict[str, str] | None = None,
    *,
    reload: bool = True,
) -> Iterator[Path]:
    """Distribution `name` installed (on sys.path) for the block; then gone, with its modules, and the
    registries as before. `reload=False` leaves reading the registries to the caller."""
    write_distribution(root, name, entry_points, files)
    sys.path.insert(0, str(root))
    importlib.invalidate_caches()
    before = set(sys.modules)
    try:
        if reload:
            reload_registries()
        yield root
    finally:
        sys.path.remove(str(root))
        for module in set(sys.modules) - before:
            if getattr(sys.modules[module], "__file__", None) and str(root) in sys.modules[module].__file__:
                del sys.modules[module]
        importlib.invalidate_caches()
        reload_registries()
