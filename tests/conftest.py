"""Shared fixtures: the default robot, and small helpers to build programs."""

from __future__ import annotations

import pytest

from backend.engine.embodiment import load_embodiment


@pytest.fixture(scope="session")
def desk():
    """The bundled default robot (nutty_desk)."""
    return load_embodiment("nutty_desk")
