"""Habits the linters do not check by themselves: every waiver says why, and a function imports inside
itself only for a reason it states (a cycle, an optional or heavy dependency, a fast `nutty --help`)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PYTHON_TREES = ("backend", "benchmarks", "blender", "tests")
# A waiver, then its codes; what follows the codes (in parentheses or after another `#`) is the reason.
WAIVER = re.compile(
    r"#\s*(noqa|type:\s*ignore|pyright:\s*ignore)(?P<codes>(:\s*[A-Z0-9, ]+|\[[^\]]*\]))?(?P<rest>.*)$"
)


def _python_files(*trees: str) -> list[Path]:
    return sorted(p for tree in trees for p in (ROOT / tree).rglob("*.py") if "node_modules" not in p.parts)


def _has_reason(rest: str) -> bool:
    return bool(re.search(r"[A-Za-z]{3,}", rest))


def test_every_waiver_gives_its_reason():
    bare = []
    for path in _python_files(*PYTHON_TREES):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            m = WAIVER.search(line)
            if m and not _has_reason(m.group("rest")):
                bare.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not bare, "a waiver without its reason (add it after the codes):\n" + "\n".join(bare)


def test_function_local_imports_say_why():
    """An import inside a function is there for a reason the line (or the one above) gives."""
    silent = []
    for path in _python_files("backend"):
        lines = path.read_text(encoding="utf-8").splitlines()
        for node in ast.walk(ast.parse("\n".join(lines))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            covered: set[int] = set()  # import lines that carry a reason, or follow one that does
            imports = [n for n in ast.walk(node) if isinstance(n, (ast.Import, ast.ImportFrom))]
            for inner in sorted(imports, key=lambda n: n.lineno):
                first, last = inner.lineno, inner.end_lineno or inner.lineno
                span = lines[first - 1 : last]
                above = lines[first - 2].strip() if first > 1 else ""
                if any("#" in text for text in span) or above.startswith("#") or (first - 1) in covered:
                    covered.update(range(first, last + 1))
                else:
                    silent.append(f"{path.relative_to(ROOT)}:{first}: {lines[first - 1].strip()}")
    assert not silent, "a function-local import without its reason:\n" + "\n".join(sorted(set(silent)))
