"""Reading animation files into source channels: the format from the extension (or --format), then
the glTF, BVH or CSV reader; malformed structures become one short ClipImportError.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from backend.importers.mapping import ClipImportError, SourceChannel

FORMATS = {".gltf": "gltf", ".glb": "gltf", ".bvh": "bvh", ".csv": "csv"}


def detect_format(path: str | Path, fmt: str | None = None) -> str:
    if fmt:
        fmt = fmt.lower()
        if fmt not in set(FORMATS.values()):
            raise ClipImportError(f"unknown format '{fmt}' (one of {sorted(set(FORMATS.values()))})")
        return fmt
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise ClipImportError(
            f"unknown format for '{path}': '{suffix or '(no extension)'}' "
            f"(supported: {', '.join(sorted(FORMATS))})"
        )
    return FORMATS[suffix]


def read_channels(
    path: str | Path,
    fmt: str | None = None,
    animation: str | int | None = None,
    *,
    rest_frame: int | None = None,
    fill: str | None = None,
    max_gap: int = 10,
) -> tuple[str, list[SourceChannel], dict[str, Any], list[str]]:
    """(format, channels, source info, notes) of a file."""
    path = Path(path)
    kind = detect_format(path, fmt)
    if not path.is_file():
        raise ClipImportError(f"no such file: '{path}'")
    notes: list[str]
    try:
        if kind == "gltf":
            from backend.importers.gltf import read_gltf

            channels, info, notes = read_gltf(path, animation)
        elif kind == "bvh":
            from backend.importers.bvh import read_bvh

            channels, info, notes = read_bvh(path, rest_frame=rest_frame, fill=fill, max_gap=max_gap)
        else:
            from backend.importers.csv_clip import read_csv

            channels, info, notes = read_csv(path, fill=fill)
    except ClipImportError:
        raise
    except (AttributeError, TypeError, IndexError, KeyError, ValueError, OverflowError) as exc:
        # a structure no check above expected (e.g. a glTF object where the schema wants a number)
        raise ClipImportError(
            f"{kind} '{path.name}': malformed file ({type(exc).__name__}: "
            f"{str(exc).splitlines()[0][:160] if str(exc) else ''})"
        ) from None
    if animation not in (None, "") and kind != "gltf":
        notes.append("--animation only applies to glTF files; ignored")
    if rest_frame is not None and kind != "bvh":
        notes.append("--rest-frame only applies to BVH files; ignored")
    return kind, channels, info, notes
