"""Whether MuJoCo, the physics preview's optional extra, is installed."""

from __future__ import annotations

import importlib
from typing import Any


class SimUnavailable(RuntimeError):
    """MuJoCo is not installed."""


def require_mujoco() -> None:
    """Raise SimUnavailable (saying how to install it) when MuJoCo cannot be imported."""
    try:
        import mujoco  # noqa: F401 (lazy: only checks that the optional extra is there)
    except ImportError as exc:
        raise SimUnavailable(
            "the physics preview needs MuJoCo: pip install -e '.[sim]' (make run and make test install it)"
        ) from exc


def mujoco_module() -> Any:
    """The `mujoco` module. Its bindings are compiled and ship no type stubs, so the type checker cannot
    see their names: typed as Any here rather than waived in every module that steps the physics."""
    return importlib.import_module("mujoco")
