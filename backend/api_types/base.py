"""What every API shape is built on: closed shapes (a key the model does not name is drift) and
open ones (known keys typed, others kept)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field


class Shape(BaseModel):
    """A response shape: a key the model does not name is drift, not an extension."""

    model_config = ConfigDict(extra="forbid")


class OpenShape(BaseModel):
    """A shape whose details vary (block events, error extras, diagnostics): known keys typed, others
    kept. Each one says why it is open."""

    model_config = ConfigDict(extra="allow")


def ts_ref(ts_type: str) -> Any:
    """A field typed in TypeScript by a type of another generated module (see gen-types.mjs)."""
    return Field(..., json_schema_extra={"tsType": ts_type})
