"""A robot's asset library on disk: clips, postures, programs, subgraphs and behaviours as JSON files,
and sounds as audio files (`self.sounds`, backend.engine.sounds).

Layout: `robots/<name>/clips/<clip>.json`, `robots/<name>/postures/<posture>.json`,
`robots/<name>/programs/<program>.json`, `robots/<name>/behaviours/<behaviour>.json`,
`robots/<name>/sounds/<sound>.wav|ogg|flac`. Postures declared in `embodiment.yaml` are listed too
(read-only). Names are restricted to a safe character set, so a request can never escape the folder.
Writes are atomic (write to a temporary file, then rename) and validated against the asset's
format first, so nothing malformed is ever stored: a program must parse as `nutty-program/1`, a clip
as `nutty-clip/1` whose tracks are DoFs of the robot, a posture as `nutty-posture/1`
(`{"name", "description"?, "values": {dof: value}}`, every DoF the robot's, every value within
the DoF's limits: a number for a continuous DoF, `[r, g, b]` in 0..1 for a colour, an option name
or index for an expression).
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal, Protocol

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from backend.engine.asset_errors import LibraryError, NotFound  # re-exported: the library's errors
from backend.engine.clips import compile_clip, validate_clip_doc
from backend.engine.embodiment import DofType, Embodiment
from backend.engine.sounds import SoundLibrary

KINDS = ("clips", "postures", "programs", "subgraphs", "behaviours")
LIBRARY_FILE_MODE = 0o644  # saved files: readable by everyone, like the files the library ships with
_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_\-\.]{0,79}$")
POSTURE_FORMAT = "nutty-posture/1"


class Resources(Protocol):
    """What blocks read of a robot's library (`BlockContext.resources`; a `RobotLibrary`)."""

    def get(self, kind: str, name: str) -> dict[str, Any]:
        """The document `name` of `kind` ("clips", "postures", ...); NotFound, or LibraryError when it
        cannot be read."""
        ...


class Posture(BaseModel):
    """A named posture (`nutty-posture/1`): DoF name -> value. `builtin` (set on the postures
    `embodiment.yaml` declares, as GET returns them) is accepted so a GET/PUT round trip works, and
    never stored."""

    model_config = ConfigDict(extra="forbid")
    format: Literal["nutty-posture/1"] = POSTURE_FORMAT
    name: str = Field(default="", max_length=80)
    description: str = Field(default="", max_length=2000)
    values: dict[str, float | str | list[float]] = Field(
        ...,
        min_length=1,
        max_length=1000,
        description="DoF name -> value: rad/m for continuous DoFs, [r, g, b] in 0..1 for colours, an option name",
    )
    builtin: bool | None = None


def _first_error(exc: ValidationError) -> str:
    first = exc.errors()[0]
    where = ".".join(str(p) for p in first["loc"])
    return f"{where}: {first['msg']}" if where else first["msg"]


def check_posture_values(values: dict[str, Any], embodiment: Embodiment) -> None:
    """Every DoF is the robot's and every value is within its limits; LibraryError names the first
    that is not."""
    for name, value in values.items():
        if not embodiment.has_dof(name):
            raise LibraryError(
                f"invalid posture: values.{name}: robot '{embodiment.name}' has no DoF '{name}'"
            )
        dof = embodiment.dof(name)
        where = f"invalid posture: values.{name}"
        if dof.type is DofType.continuous:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise LibraryError(f"{where}: a continuous DoF takes a finite number, got {value!r}")
            if not dof.min <= value <= dof.max:
                raise LibraryError(
                    f"{where}: {value:g} is outside the DoF's limits [{dof.min:g}, {dof.max:g}]"
                )
        elif dof.type is DofType.colour:
            if (
                not isinstance(value, list)
                or len(value) != 3
                or not all(
                    isinstance(c, (int, float)) and not isinstance(c, bool) and 0.0 <= c <= 1.0 for c in value
                )
            ):
                raise LibraryError(f"{where}: a colour DoF takes [r, g, b] within 0..1, got {value!r}")
        elif dof.type is DofType.enum:
            options = list(dof.options or ())
            if isinstance(value, str):
                if value not in options:
                    raise LibraryError(f"{where}: '{value}' is not one of {options}")
            elif (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or value != int(value)
                or not 0 <= value < len(options)
            ):
                raise LibraryError(
                    f"{where}: an expression DoF takes one of {options} (or its index), got {value!r}"
                )
        else:
            raise LibraryError(f"{where}: '{name}' is an event DoF and has no pose value")


def validate_posture_doc(doc: Any, embodiment: Embodiment | None = None, name: str = "") -> dict[str, Any]:
    """A normalised posture document, or LibraryError naming the field."""
    if not isinstance(doc, dict):
        raise LibraryError('invalid posture: a posture is a JSON object {"name", "values": {dof: value}}')
    try:
        posture = Posture.model_validate(doc)
    except ValidationError as exc:
        raise LibraryError(f"invalid posture: {_first_error(exc)}") from exc
    if embodiment is not None:
        check_posture_values(doc["values"], embodiment)
    out = posture.model_dump(mode="json", exclude={"builtin"})
    out["values"] = dict(doc["values"])  # as written: ints stay ints, option names stay names
    out["name"] = posture.name or name
    if not out["description"]:
        del out["description"]
    return out


def _validate_with(model: Any, what: str, doc: Any) -> dict[str, Any]:
    """`doc` if it is a JSON object that `model` accepts, else LibraryError naming the first problem."""
    if not isinstance(doc, dict):
        raise LibraryError(f"invalid {what}: a {what} is a JSON object")
    try:
        model.model_validate(doc)
    except ValidationError as exc:
        raise LibraryError(f"invalid {what}: {_first_error(exc)}") from exc
    return doc


DocValidator = Callable[[dict[str, Any]], dict[str, Any]]


def model_validator_for(model: type[BaseModel], what: str) -> DocValidator:
    """A document validator from a pydantic model: the normalised document, or LibraryError naming the
    first bad field (`what` is the kind's singular, e.g. "program")."""
    return lambda doc: _validate_with(model, what, doc)


class RobotLibrary:
    """Clips, postures and programs of one robot folder. Thread-safe for concurrent API requests.

    `validators[kind]` (optional) checks and normalises a document before it is saved or after it is
    read; block modules register the clip validator, the graph package the program validator.
    """

    def __init__(
        self,
        folder: str | Path | None,
        embodiment: Embodiment | None = None,
        validators: dict[str, DocValidator] | None = None,
    ):
        self.folder = Path(folder) if folder is not None else None
        self.embodiment = embodiment
        # Clips are an engine format; programs and subgraphs are the graph's, which gives their
        # validators (`backend.graph.library_docs.library_validators`) so this layer never imports it.
        self.validators: dict[str, DocValidator] = {"clips": validate_clip_doc, **(validators or {})}
        self._lock = threading.Lock()
        self._cache: dict[tuple[str, str], tuple[float, dict[str, Any]]] = {}
        self.sounds = SoundLibrary(self.folder / "sounds" if self.folder is not None else None)

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
            raise LibraryError(
                f"invalid name {name!r}: use letters, digits, '_', '-' or '.', at most 80 characters"
            )
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
                    raise LibraryError(
                        f"{kind}/{name}.json is not valid JSON: line {exc.lineno}: {exc.msg}"
                    ) from exc
                validate = self.validators.get(kind)
                if validate is not None:
                    doc = validate(doc)
                self._cache[(kind, name)] = (mtime, doc)
                return doc
        if kind == "postures" and self.embodiment is not None and name in self.embodiment.postures:
            doc = {"name": name, "values": dict(self.embodiment.postures[name]), "builtin": True}
            description = getattr(self.embodiment, "posture_descriptions", {}).get(name)
            return {**doc, "description": description} if description else doc
        raise NotFound(f"no {kind[:-1]} named '{name}'")

    def exists(self, kind: str, name: str) -> bool:
        try:
            self.get(kind, name)
            return True
        except NotFound:
            return False

    # --- changes --------------------------------------------------------------------------------------
    def validate(self, kind: str, name: str, doc: Any) -> dict[str, Any]:
        """The document as it would be stored, or LibraryError: every write is checked against its
        format (and the robot, when the library knows it) before anything touches the disk."""
        if kind not in KINDS:
            raise LibraryError(f"unknown asset kind '{kind}' (one of {list(KINDS)})")
        if not isinstance(doc, dict):
            raise LibraryError(f"invalid {kind[:-1]}: a {kind[:-1]} is a JSON object")
        if kind == "postures":
            return validate_posture_doc(doc, self.embodiment, name)
        validate = self.validators.get(kind)
        if validate is None:
            raise LibraryError(
                f"this library cannot check {kind}: it was made without their validator "
                "(backend.graph.library_docs.library_validators)"
            )
        try:
            doc = validate(doc)
        except LibraryError:
            raise
        except ValueError as exc:
            raise LibraryError(str(exc)) from exc
        if kind == "clips" and self.embodiment is not None:
            try:
                compile_clip(doc, self.embodiment)
            except ValueError as exc:
                raise LibraryError(f"invalid clip: {exc}", getattr(exc, "field", None)) from exc
        return doc

    def joint_warnings(self, kind: str, doc: dict[str, Any]) -> list[str]:
        """Warnings for a valid posture or clip whose DoFs add up past a joint's range (naming the joint
        and the amount; `backend.engine.joint_range`); none for other kinds or without a robot."""
        if self.embodiment is None or kind not in ("postures", "clips"):
            return []
        from backend.engine import joint_range  # it reads blocks.core, whose posture block reads this module

        if kind == "postures":
            return joint_range.posture_warnings(doc.get("values", {}), self.embodiment)
        return joint_range.clip_warnings(compile_clip(doc, self.embodiment), self.embodiment)

    def save(self, kind: str, name: str, doc: dict[str, Any]) -> dict[str, Any]:
        name = self.check_name(name)
        doc = self.validate(kind, name, doc)
        d = self._dir(kind)
        with self._lock:
            d.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=d, prefix=f".{name}.", suffix=".tmp")
            try:
                os.fchmod(fd, LIBRARY_FILE_MODE)  # mkstemp makes it private (0600); the library is shared
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
