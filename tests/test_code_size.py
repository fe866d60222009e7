"""Size limits of the back end's code (issue #27): files of at most 500 lines, functions of at most 80.

A long file or function is split by responsibility, so each part can be read at once. Numba kernels
(functions decorated with numba's jit, njit, vectorize or guvectorize) are exempt: a compiled tick is
one loop nest whose parts would cost a call each if split, and their numpy references keep the limit.
"""

from __future__ import annotations

import ast
from pathlib import Path

BACKEND = Path(__file__).resolve().parent.parent / "backend"
MAX_FILE_LINES = 500
MAX_FUNCTION_LINES = 80
NUMBA_DECORATORS = {"jit", "njit", "vectorize", "guvectorize"}


def _decorator_name(node: ast.expr) -> str:
    """The last name of a decorator: `njit` for `@njit`, `@njit(cache=True)` and `@numba.njit(...)`."""
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Attribute):
        return node.attr
    return node.id if isinstance(node, ast.Name) else ""


def _sources() -> list[Path]:
    return sorted(p for p in BACKEND.rglob("*.py") if "__pycache__" not in p.parts)


def test_files_are_at_most_500_lines():
    long = []
    for path in _sources():
        n = len(path.read_text(encoding="utf-8").splitlines())
        if n > MAX_FILE_LINES:
            long.append(f"{path.relative_to(BACKEND.parent)}: {n} lines")
    assert not long, f"files over {MAX_FILE_LINES} lines (split them by responsibility): " + "; ".join(long)


def test_functions_are_at_most_80_lines():
    long = []
    for path in _sources():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            if any(_decorator_name(d) in NUMBA_DECORATORS for d in node.decorator_list):
                continue
            n = node.end_lineno - node.lineno + 1
            if n > MAX_FUNCTION_LINES:
                long.append(f"{path.relative_to(BACKEND.parent)}:{node.lineno} {node.name}(): {n} lines")
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines: " + "; ".join(long)


def test_the_numba_exemption_is_recognised():
    """`@njit`, `@njit(...)` and `@numba.njit(...)` are all seen as numba; another decorator is not."""
    tree = ast.parse("@njit\ndef a(): pass\n@numba.njit(cache=True)\ndef b(): pass\n@other\ndef c(): pass\n")
    names = [_decorator_name(f.decorator_list[0]) for f in tree.body]
    assert [n in NUMBA_DECORATORS for n in names] == [True, True, False]
