"""A robot's asset library on disk: clips, postures and programs as JSON files.

Layout: `robots/<name>/clips/<clip>.json`, `robots/<name>/postures/<posture>.json`,
`robots/<name>/programs/<program>.json`. Postures declared in `embodiment.yaml` are listed too
(read-only). Names are restricted to a safe character set, so a request can never escape the folder.
Writes are atomic (write to a temporary file, then rename).
"""

from __future__ import annotations

import json
import os
import re
import tempfile
import threading
from pathlib import Path
from typing import Any, Callable

KINDS = ("clips", "postures", "programs")
_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_\-\.]{0,79}$")


class LibraryError(ValueError):
    """A bad name, a missing asset, or an asset that fails validation; the message says which."""


class NotFound(LibraryError):
    pass


class RobotLibrary:
    """Clips, postures and programs of one robot folder. Thread-safe for concurrent API requests.

    `validators[kind]` (optional) checks and normalises a document before it is saved or after it is
    read; block modules register the clip validator, the graph package the program validator.
    """

    validators: dict[str, Callable[[dict[str, Any]], dict[str, Any]]] = {}

    def __init__(self, folder: str | Path | None, embodiment: Any = None):
        self.folder = Path(folder) if folder is not None else None
        self.embodiment = embodiment
        self._lock = threading.Lock()
        self._cache: dict[tuple[str, str], tuple[float, dict[str, Any]]] = {}

    # --- paths ------------------------------------------------------------------------------------
    def _dir(self, kind: str) -> Path:
        if kind not in KINDS:
            raise LibraryError(f"unknown asset kind '{kind}' (one of {list(KINDS)})")
        if self.folder is None:
            raise LibraryError("this robot has no library folder (it was loaded from a bare URDF)")
        return self.folder / kind

    @staticmethod
    def check_name(name: str) -> str:
        if not isinstance(name, str) or not _NAME.match(name):
            raise LibraryError(f"invalid name {name!r}: use letters, digits, '_', '-' or '.', at most 80 characters")
        return name[:-5] if name.endswith(".json") else name

    # --- queries ------------------------------------------------------------------------------------
    def list(self, kind: str) -> list[str]:
        names: set[str] = set()
        if self.folder is not None:
            d = self._dir(kind)
            if d.is_dir():
                names |= {p.stem for p in d.glob("*.json")}
        if kind == "postures" and self.embodiment is not None:
            names |= set(getattr(self.embodiment, "postures", {}))
        return sorted(names)

    def get(self, kind: str, name: str) -> dict[str, Any]:
        name = self.check_name(name)
        if self.folder is not None:
            path = self._dir(kind) / f"{name}.json"
            if path.exists():
                mtime = path.stat().st_mtime
                cached = self._cache.get((kind, name))
                if cached and cached[0] == mtime:
                    return cached[1]
                try:
                    doc = json.loads(path.read_text())
                except json.JSONDecodeError as exc:
                    raise LibraryError(f"{kind}/{name}.json is not valid JSON: line {exc.lineno}: {exc.msg}") from exc
                validate = self.validators.get(kind)
                if validate is not None:
                    doc = validate(doc)
                self._cache[(kind, name)] = (mtime, doc)
                return doc
        if kind == "postures" and self.embodiment is not None and name in self.embodiment.postures:
            return {"name": name, "values": dict(self.embodiment.postures[name]), "builtin": True}
        raise NotFound(f"no {kind[:-1]} named '{name}'")

    def exists(self, kind: str, name: str) -> bool:
        try:
            self.get(kind, name)
            return True
        except NotFound:
            return False

    # --- changes --------------------------------------------------------------------------------------
    def save(self, kind: str, name: str, doc: dict[str, Any]) -> dict[str, Any]:
        name = self.check_name(name)
        validate = self.validators.get(kind)
        if validate is not None:
            doc = validate(doc)
        d = self._dir(kind)
        with self._lock:
            d.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=d, prefix=f".{name}.", suffix=".tmp")
            try:
                with os.fdopen(fd, "w") as fh:
                    json.dump(doc, fh, indent=2)
                    fh.write("\n")
                os.replace(tmp, d / f"{name}.json")
            except BaseException:
                Path(tmp).unlink(missing_ok=True)
                raise
            self._cache.pop((kind, name), None)
        return doc

    def delete(self, kind: str, name: str) -> None:
        name = self.check_name(name)
        path = self._dir(kind) / f"{name}.json"
        with self._lock:
            if not path.exists():
                raise NotFound(f"no {kind[:-1]} named '{name}' on disk")
            path.unlink()
            self._cache.pop((kind, name), None)
