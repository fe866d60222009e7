"""The core knows nothing of its edges: no module of the engine, the graph, the commands, the session or
the hub imports FastAPI, Starlette or the HTTP routes. It raises `DomainError`s with codes; HTTP and
Zenoh map them to their own answers (backend/routes/errors.py)."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

from backend.control.errors import CommandError
from backend.errors import DomainError
from backend.routes.errors import http_status
from backend.session import SessionError

ROOT = Path(__file__).resolve().parents[1]
BACKEND = ROOT / "backend"
CORE_PACKAGES = ("engine", "graph", "control")
CORE_MODULES = ("session.py", "hub.py", "errors.py")
EDGES = ("fastapi", "starlette", "backend.routes", "uvicorn")


def core_files() -> list[Path]:
    files = [p for pkg in CORE_PACKAGES for p in sorted((BACKEND / pkg).rglob("*.py"))]
    return files + [BACKEND / name for name in CORE_MODULES]


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_names(path: Path) -> set[str]:
    """Every module an import statement of `path` names, at any depth (lazy imports in functions too)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def is_edge(name: str) -> bool:
    return any(name == edge or name.startswith(edge + ".") for edge in EDGES)


def test_the_core_is_found():
    files = core_files()
    assert len(files) > 30 and all(f.exists() for f in files)


@pytest.mark.parametrize("path", core_files(), ids=lambda p: str(p.relative_to(BACKEND)))
def test_no_core_source_imports_an_edge(path):
    assert not sorted(filter(is_edge, imported_names(path)))


def test_importing_the_core_loads_no_edge():
    """What the imports pull in, transitively, in a fresh interpreter."""
    modules = [module_name(p) for p in core_files()]
    code = (
        "import importlib, json, sys\n"
        f"for m in {modules!r}:\n"
        "    importlib.import_module(m)\n"
        "print(json.dumps(sorted(sys.modules)))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 0, done.stderr
    loaded = json.loads(done.stdout.strip().splitlines()[-1])
    assert not [m for m in loaded if is_edge(m)]


def test_domain_errors_carry_their_code_and_map_to_the_http_status():
    assert http_status(CommandError("x", code="no_target")) == 404
    assert http_status(CommandError("x", code="busy")) == 409
    assert http_status(DomainError("x", code="duplicate_id", field="id", id="a")) == 409
    assert http_status(SessionError("x", code="unknown_node")) == 404
    assert http_status(CommandError("x")) == 422
    assert CommandError("bad", code="invalid_command").detail == {
        "code": "invalid_command",
        "message": "bad",
        "field": None,
    }
    assert DomainError("gone", code="unknown_command").detail == {
        "code": "unknown_command",
        "message": "gone",
    }
    assert SessionError("no", code="no_program").detail["report"] is None
    assert isinstance(CommandError("x"), ValueError)  # callers that catch ValueError still do
