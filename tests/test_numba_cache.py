"""numba's cache follows the compiled sources (backend/numba_cache.py): an edit to any file that defines
compiled code gives a new cache directory, so a kernel that inlines another file's kernel (the core's,
the frame tail's) is never loaded stale."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numba

from backend import numba_cache


def test_the_cache_directory_is_this_version_of_the_compiled_sources():
    assert os.environ["NUMBA_CACHE_DIR"] == numba.config.CACHE_DIR  # numba reads the one we set
    if os.environ.get("NUMBA_CACHE_DIR", "").startswith(str(numba_cache.CACHE_ROOT)):  # (not the user's own)
        assert Path(numba.config.CACHE_DIR) == numba_cache.CACHE_ROOT / numba_cache.sources_hash()


def test_an_edit_to_a_compiled_source_moves_the_cache(tmp_path, monkeypatch):
    tree = tmp_path / "backend"
    shutil.copytree(numba_cache.BACKEND / "engine" / "compiled", tree / "engine" / "compiled")
    (tree / "plain.py").write_text("x = 1\n")
    monkeypatch.setattr(numba_cache, "BACKEND", tree)
    before = numba_cache.sources_hash()
    (tree / "plain.py").write_text("x = 2\n")  # no compiled code: the same cache
    assert numba_cache.sources_hash() == before
    ik = tree / "engine" / "compiled" / "ik.py"
    ik.write_text(ik.read_text() + "\n# an edit\n")
    assert numba_cache.sources_hash() != before


def test_a_cache_directory_the_user_set_is_kept(monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", "/somewhere/else")
    assert numba_cache.configure() is None
    assert os.environ["NUMBA_CACHE_DIR"] == "/somewhere/else"
