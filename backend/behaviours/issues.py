"""Errors in a behaviour, each on its item and field, like a program's report on its nodes and ports."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from backend.errors import DomainError


@dataclass(frozen=True)
class Issue:
    """One error: where (track index, item id, field of the item or of the behaviour) and why.

    `path` is the dotted path in the document (`tracks.1.items.0.clip`, `params.name.default`)."""

    message: str
    path: str = ""
    track: int | None = None
    item: str | None = None
    field: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if v is not None and v != ""} | {
            "message": self.message
        }

    def render(self) -> str:
        where = f"item '{self.item}'" if self.item else (self.path or "behaviour")
        return f"{where}{f' ({self.field})' if self.item and self.field else ''}: {self.message}"


class BehaviourInvalid(DomainError):
    """A behaviour (or its parameters) with errors: every one listed in `errors` (422 `invalid_behaviour`)."""

    def __init__(self, issues: list[Issue], what: str = "behaviour"):
        self.issues = list(issues)
        head = "; ".join(i.render() for i in self.issues[:3])
        more = f" (and {len(self.issues) - 3} more)" if len(self.issues) > 3 else ""
        first = self.issues[0] if self.issues else None
        super().__init__(
            f"{what} is invalid: {head}{more}",
            code="invalid_behaviour",
            field=first.path if first is not None and first.path else None,
            errors=[i.to_dict() for i in self.issues],
        )
