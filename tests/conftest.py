"""Shared fixtures (the default robot) and the markers `make test-fast` selects on.

A test is marked `server` when it, or a fixture it uses, starts a process or a server (a real
`nutty serve`, uvicorn, a Zenoh session, MCP, the Pre-Viz child), and `blender` when it runs Blender.
The marks are found from the source of the test and its fixtures, so a new test is sorted without
anyone remembering to mark it; `make test-fast` leaves both out (and `browser`, which files declare).
"""

from __future__ import annotations

import functools
import inspect
import os
import re
from pathlib import Path

import pytest

from backend.engine.embodiment import load_embodiment

# ROS 2 in any test (and any process a test starts) discovers on this machine only; the ROS tests also
# take a domain of their own (tests/ros_env.py).
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"

# What in a test's (or its fixtures') source says it starts a process or a server.
_SERVER = re.compile(
    r"running_server|server_process|running_app|subprocess|Popen|zenoh\.open|open_session|uvicorn|"
    r"PreVizProcess|PreVizServer|start_previz|Fleet\(|EngineLink|NuttyProcess|mcp_server|stdio_client|"
    r"serve\("
)
TESTS = Path(__file__).resolve().parent
_HELPER_DEPTH = 3  # how far into the test's own helpers (functions and classes of tests/) to read
_BLENDER = re.compile(r"\bbpy\b|blender_rpc|run_blender|BLENDER")


@pytest.fixture(scope="session")
def desk():
    """The bundled default robot (nutty_desk)."""
    return load_embodiment("nutty_desk")


@functools.cache
def _source(fn) -> str:
    try:
        return inspect.getsource(fn)
    except (OSError, TypeError):  # built-in or generated: nothing to read
        return ""


def _with_helpers(fn, seen: set) -> list[str]:
    """The source of `fn` and of the tests' own functions and classes it names, a few calls deep."""
    texts, frontier = [], [(fn, 0)]
    while frontier:
        obj, depth = frontier.pop()
        if obj in seen:
            continue
        seen.add(obj)
        text = _source(obj)
        texts.append(text)
        if depth >= _HELPER_DEPTH:
            continue
        module = inspect.getmodule(obj)
        scope = getattr(obj, "__globals__", None) or (vars(module) if module is not None else {})
        for name in set(re.findall(r"[A-Za-z_]\w*", text)):
            found = scope.get(name)
            if (inspect.isfunction(found) or inspect.isclass(found)) and _in_tests(found):
                frontier.append((found, depth + 1))
    return texts


def _in_tests(obj) -> bool:
    try:
        path = inspect.getsourcefile(obj) or ""
    except TypeError:  # a built-in class
        return False
    return TESTS in Path(path).resolve().parents


def pytest_collection_modifyitems(config, items):
    for item in items:
        func = getattr(item, "function", None)
        if func is None:
            continue
        seen: set = set()
        texts = _with_helpers(func, seen)
        info = getattr(item, "_fixtureinfo", None)
        for defs in info.name2fixturedefs.values() if info is not None else ():
            for d in defs:
                texts.extend(_with_helpers(d.func, seen))
        text = "\n".join(texts)
        if _SERVER.search(text):
            item.add_marker(pytest.mark.server)
        if _BLENDER.search(text):
            item.add_marker(pytest.mark.blender)
