"""Build the installable add-on: `python blender/build_addon.py [OUT_DIR]` (what `make blender-addon` runs).

Writes OUT_DIR/nutty_blender-<version>.zip (default OUT_DIR: dist/) in the layout of a Blender 4.2+
extension: blender_manifest.toml and the package's modules at the root of the archive. Install it in
Blender with Edit > Preferences > Get Extensions > Install from Disk (docs/blender.md). Standard
library only (the same archive `blender --command extension build` makes, without needing Blender).
"""

from __future__ import annotations

import sys
import tomllib
import zipfile
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent / "nutty_blender"


def build(out_dir: Path) -> Path:
    manifest = tomllib.loads((PACKAGE / "blender_manifest.toml").read_text())
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / f"{manifest['id']}-{manifest['version']}.zip"
    files = sorted(
        p for p in PACKAGE.rglob("*") if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"
    )
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in files:
            zf.write(path, path.relative_to(PACKAGE).as_posix())
    return target


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else Path(__file__).resolve().parents[1] / "dist"
    print(build(out))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
