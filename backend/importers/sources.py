"""Reading animation files into source channels: the importer for the file's suffix (or --format),
then its reader; malformed structures become one short ClipImportError.

An importer is an `Importer` class: its format's name, how messages name it, the file suffixes it reads,
which format-specific options apply, and `read(path, options)`. It is registered by an entry point named
after it, in the pyproject.toml of its distribution (this project's, or a plugin package's; see
backend.plugins):

    [project.entry-points."nutty.importers"]
    bvh = "backend.importers.bvh:BvhImporter"

then `pip install -e .`. IMPORTERS (name -> class) and FORMATS (suffix -> name) are filled when
`backend.importers` is imported; `reload()` reads the entry points again.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

from backend.importers.mapping import ClipImportError, SourceChannel
from backend.plugins import load


@dataclass(frozen=True)
class ReadOptions:
    """The reading options of `nutty import`; an importer uses those that apply to its format."""

    animation: str | int | None = None  # which animation of a file holding several (name or index)
    rest_frame: int | None = None  # the frame that is the rest pose (default: the file's own rest pose)
    fill: str | None = None  # "hold" or "linear": repair gaps of non-finite samples (default: error)
    max_gap: int = 10  # samples: the longest gap `fill` repairs
    # the source names the mapping file names: an importer of files holding several animations may take
    # those channels from another animation when the chosen one lacks them (glTF does)
    wanted: frozenset[str] = frozenset()


class Importer:
    """One animation file format.

    name: what --format and the clip's `source.format` say (the entry point's name).
    label: how messages name it ("glTF", "BVH").
    suffixes: the file suffixes it reads, lower case with the dot (".glb").
    options: the format-specific options that apply to it, of "animation", "rest_frame" and "interp"
      (the keys' interpolation, for sources that are keys of DoF values); others are noted as ignored.
    axes: its rotations and translations are in the source's spatial axes, so --up/--forward apply
      (False for columns of DoF values).
    read(path, options) -> (channels, source info, notes): raise ClipImportError for a file it cannot
      read; any other error of a malformed structure is reported as a malformed file.
    """

    name: ClassVar[str] = ""
    label: ClassVar[str] = ""
    suffixes: ClassVar[tuple[str, ...]] = ()
    options: ClassVar[frozenset[str]] = frozenset()
    axes: ClassVar[bool] = True

    @classmethod
    def read(cls, path: Path, options: ReadOptions) -> tuple[list[SourceChannel], dict[str, Any], list[str]]:
        raise NotImplementedError


IMPORTERS: dict[str, type[Importer]] = {}
FORMATS: dict[str, str] = {}  # file suffix -> importer name


def register_importer(
    cls: type[Importer], registry: dict[str, type[Importer]] | None = None
) -> type[Importer]:
    """Add an importer to `registry` (default IMPORTERS; names and suffixes are unique). The plugin loader
    calls it for every `nutty.importers` entry point (`reload`)."""
    importers = IMPORTERS if registry is None else registry
    if not (isinstance(cls, type) and issubclass(cls, Importer)):
        raise TypeError(f"{cls!r} is not an Importer subclass")
    if not cls.name or not cls.suffixes:
        raise TypeError(f"{cls.__qualname__} declares no name or no suffixes")
    if cls.name in importers and importers[cls.name] is not cls:
        raise ValueError(f"importer '{cls.name}' is declared twice ({importers[cls.name]!r}, {cls!r})")
    for suffix in cls.suffixes:
        if not (suffix.startswith(".") and suffix == suffix.lower()):
            raise ValueError(
                f"{cls.__qualname__}: a suffix is lower case and starts with '.', got '{suffix}'"
            )
        other = next((i for i in importers.values() if suffix in i.suffixes and i is not cls), None)
        if other is not None:
            raise ValueError(
                f"suffix '{suffix}' of importer '{cls.name}' is already importer '{other.name}''s"
            )
    importers[cls.name] = cls
    return cls


def reload() -> None:
    """Fill IMPORTERS and FORMATS (in place) from the `nutty.importers` entry points; on a PluginError
    they are left as they were."""
    found: dict[str, type[Importer]] = {}
    load("nutty.importers", lambda cls: cls.name, lambda cls: register_importer(cls, found))
    IMPORTERS.clear()
    IMPORTERS.update(found)
    FORMATS.clear()
    FORMATS.update({suffix: cls.name for cls in found.values() for suffix in cls.suffixes})


def detect_format(path: str | Path, fmt: str | None = None) -> str:
    """The name of the importer for `path`: `fmt` when given, else the one reading its suffix."""
    if fmt:
        fmt = fmt.lower()
        if fmt not in IMPORTERS:
            raise ClipImportError(f"unknown format '{fmt}' (one of {sorted(IMPORTERS)})")
        return fmt
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise ClipImportError(
            f"unknown format for '{path}': '{suffix or '(no extension)'}' "
            f"(supported: {', '.join(sorted(FORMATS))})"
        )
    return FORMATS[suffix]


def _applies_to(option: str) -> str:
    """The formats an option applies to, as messages name them ("glTF", "BVH or CSV")."""
    return " or ".join(i.label for i in IMPORTERS.values() if option in i.options) or "no"


def read_channels(
    path: str | Path,
    fmt: str | None = None,
    animation: str | int | None = None,
    *,
    rest_frame: int | None = None,
    fill: str | None = None,
    max_gap: int = 10,
    wanted: frozenset[str] = frozenset(),
) -> tuple[str, list[SourceChannel], dict[str, Any], list[str]]:
    """(format, channels, source info, notes) of a file, read by the importer for its suffix (or `fmt`)."""
    path = Path(path)
    kind = detect_format(path, fmt)
    if not path.is_file():
        raise ClipImportError(f"no such file: '{path}'")
    importer = IMPORTERS[kind]
    options = ReadOptions(
        animation=animation, rest_frame=rest_frame, fill=fill, max_gap=max_gap, wanted=wanted
    )
    try:
        channels, info, notes = importer.read(path, options)
    except ClipImportError:
        raise
    except (AttributeError, TypeError, IndexError, KeyError, ValueError, OverflowError) as exc:
        # a structure no check above expected (e.g. a glTF object where the schema wants a number)
        raise ClipImportError(
            f"{kind} '{path.name}': malformed file ({type(exc).__name__}: "
            f"{str(exc).splitlines()[0][:160] if str(exc) else ''})"
        ) from None
    if animation not in (None, "") and "animation" not in importer.options:
        notes.append(f"--animation only applies to {_applies_to('animation')} files; ignored")
    if rest_frame is not None and "rest_frame" not in importer.options:
        notes.append(f"--rest-frame only applies to {_applies_to('rest_frame')} files; ignored")
    return kind, channels, info, notes
