"""Build the installable add-on: `python blender/build_addon.py [OUT_DIR]` (what `make blender-addon` runs).

Writes OUT_DIR/nutty_blender-<version>.zip (default OUT_DIR: dist/) in the layout of a Blender 4.2+
extension: blender_manifest.toml and the package's modules at the root of the archive. The version is
the project's (pyproject.toml [project] version): it is written into the archive's manifest, whatever
the source manifest says (Blender reads that one when the add-on runs from the source tree). Install it in
Blender with Edit > Preferences > Get Extensions > Install from Disk (docs/blender.md). Standard
library only (the same archive `blender --command extension build` makes, without needing Blender).
"""

from __future__ import annotations

import re
import sys
import tomllib
import zipfile
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent / "nutty_blender"
PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"
MANIFEST = "blender_manifest.toml"
_VERSION_LINE = re.compile(r'^version = "[^"]*"$', re.MULTILINE)


def project_version(pyproject: Path = PYPROJECT) -> str:
    """The one version of the project: pyproject.toml's [project] version."""
    return str(tomllib.loads(pyproject.read_text())["project"]["version"])


def stamped_manifest(text: str, version: str) -> str:
    """The manifest `text` with its top-level `version = "..."` set to `version`."""
    stamped, n = _VERSION_LINE.subn(f'version = "{version}"', text, count=1)
    if n != 1:
        raise ValueError(f"{MANIFEST} has no top-level version line to set")
    return stamped


def build(out_dir: Path) -> Path:
    version = project_version()
    text = stamped_manifest((PACKAGE / MANIFEST).read_text(), version)
    manifest = tomllib.loads(text)
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / f"{manifest['id']}-{version}.zip"
    files = sorted(
        p for p in PACKAGE.rglob("*") if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"
    )
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in files:
            name = path.relative_to(PACKAGE).as_posix()
            if name == MANIFEST:
                zf.writestr(name, text)
            else:
                zf.write(path, name)
    return target


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else Path(__file__).resolve().parents[1] / "dist"
    print(build(out))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
