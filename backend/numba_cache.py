"""Where numba caches the compiled kernels: a directory per version of the compiled sources.

numba's on-disk cache (`cache=True`) checks a function's own source file only, but the program core's
kernel (`backend/engine/core/vm.py`) and the engine's frame tail inline kernels from other files: after
an edit to, say, `compiled/ik.py`, the cached core would still run the old IK and disagree with the
IK block's own tick. So the cache lives under `.numba-cache/<hash>/` at the top of the checkout, where
`<hash>` covers every backend source file that defines compiled code: any edit to one starts a new
cache (compiled once, ~15 s), and unchanged sources keep loading theirs.

`NUMBA_CACHE_DIR`, when set, is used as it is (numba's own setting).
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

BACKEND = Path(__file__).resolve().parent
#: The caches' parent: one directory per version of the compiled sources.
CACHE_ROOT = BACKEND.parent / ".numba-cache"
ENV = "NUMBA_CACHE_DIR"


def sources_hash() -> str:
    """A hash of every backend source file that defines compiled (numba) code, paths included."""
    digest = hashlib.sha1()
    for path in sorted(BACKEND.rglob("*.py")):
        text = path.read_bytes()
        if b"njit" in text:
            digest.update(path.relative_to(BACKEND).as_posix().encode())
            digest.update(text)
    return digest.hexdigest()[:16]


def configure() -> str | None:
    """Point numba's cache at this version's directory unless `NUMBA_CACHE_DIR` is set; the directory
    (None: the user's setting stands)."""
    if os.environ.get(ENV):
        return None
    folder = str(CACHE_ROOT / sources_hash())
    os.environ[ENV] = folder  # read when numba is imported (and by child processes)
    numba_config = sys.modules.get("numba.core.config")
    if numba_config is not None:  # numba came first (a test runner's plugin): tell it too
        numba_config.CACHE_DIR = folder  # type: ignore[attr-defined]  # (a module attribute numba reads)
    return folder
