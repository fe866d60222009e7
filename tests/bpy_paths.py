"""Where the pip-installed Blender module keeps its own tools (for tests that use them)."""

from __future__ import annotations

import importlib.util
from pathlib import Path


def blender_ext() -> Path:
    """Blender's extension command-line tool (`blender --command extension` runs it): validate, build."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        raise FileNotFoundError("bpy is not installed")
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        raise FileNotFoundError("bpy has no bl_pkg/cli/blender_ext.py")
    return found[-1]
