"""MCP over stdio that answers every line: JSON the server's way, JSON-RPC errors for the rest.

The SDK's stdio transport passes a line it cannot parse to the session as an exception, which answers
nothing, and parses NaN, Infinity and lone surrogates into a request that then fails somewhere deep.
Here every line is first read with the server's own rules (`backend.safe_json.loads`: finite numbers,
valid Unicode, nesting within 64 levels, no key given twice) and checked as a JSON-RPC message:

- not JSON at all: `-32700` parse error (id null, as JSON-RPC says);
- JSON the server refuses (NaN, Infinity, a lone surrogate, deep nesting, a duplicate key, a huge
  integer): `-32602` invalid params naming the field (`data.field`, `data.code`), under the request's
  id (read leniently from the line; a notification gets no answer, as JSON-RPC says, only a log line);
- JSON that is no JSON-RPC message: `-32600` invalid request.

Only good lines reach the SDK's session, and errors go out through its writer (one line at a time).
"""

from __future__ import annotations

import json
import logging
import re
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from io import TextIOWrapper
from typing import Any, cast

import anyio
import mcp_types as types
from mcp.server.stdio import stdio_server
from mcp.shared.message import SessionMessage
from pydantic import ValidationError

from backend.safe_json import JsonSafetyError, check_json, loads, safe_text

log = logging.getLogger(__name__)
_ID = re.compile(r'"id"\s*:\s*(-?\d{1,18}|"(?:[^"\\]|\\.){0,200}")')


def _lenient(line: str) -> Any:
    """The line parsed the standard library's lenient way (NaN, lone surrogates, the last of a duplicate
    key), or None when even that fails (deep nesting)."""
    try:
        return json.loads(line)
    except (ValueError, RecursionError):
        return None


def _lenient_id(line: str, doc: Any) -> Any:
    """The request id of a line the safe reader refused (its other content may be anything); None when
    there is none to read."""
    if isinstance(doc, dict):
        rid = doc.get("id")
        return rid if isinstance(rid, (int, str)) and not isinstance(rid, bool) else None
    m = _ID.search(line)
    if m is None:
        return None
    try:
        rid = json.loads(m.group(1))
    except ValueError:
        return None
    return rid if isinstance(rid, (int, str)) else None


def check_line(line: str) -> tuple[dict[str, Any] | None, types.JSONRPCError | None]:
    """(the message, None) for a line to hand to the session, or (None, the error to answer; None too
    for a refused notification, which gets no answer)."""
    try:
        doc = loads(line, max_bytes=None)
    except JsonSafetyError as exc:
        if exc.code == "malformed_json":
            return None, _error(None, types.PARSE_ERROR, f"Parse error: {exc}")
        lenient = _lenient(line)
        if exc.field is None and lenient is not None:  # a NaN refused while parsing: find where it stands
            try:
                check_json(lenient)
            except JsonSafetyError as located:
                exc = located
        rid = _lenient_id(line, lenient)
        field = (
            f"params.{exc.field}"
            if exc.field and not exc.field.startswith(("params", "id", "method"))
            else exc.field
        )
        log.warning("refused a message (id %r): %s", rid, safe_text(str(exc)))
        if rid is None:
            return None, None
        return None, _error(
            rid, types.INVALID_PARAMS, f"Invalid params: {exc}", {"field": field, "code": exc.code}
        )
    try:
        types.jsonrpc_message_adapter.validate_python(doc, by_name=False)
    except ValidationError as exc:  # name what is wrong in one line
        rid = _lenient_id(line, doc)
        first = str(exc).splitlines()
        why = first[1].strip() if len(first) > 1 else str(exc)
        return None, _error(
            rid, types.INVALID_REQUEST, f"Invalid Request: not a JSON-RPC 2.0 message ({why})"
        )
    return doc, None


def _error(rid: Any, code: int, message: str, data: dict[str, Any] | None = None) -> types.JSONRPCError:
    return types.JSONRPCError(
        jsonrpc="2.0", id=rid, error=types.ErrorData(code=code, message=message[:500], data=data)
    )


@asynccontextmanager
async def safe_stdio_server(stdin: Any = None) -> AsyncIterator[tuple[Any, Any]]:
    """`mcp.server.stdio.stdio_server`, fed only lines `check_line` accepts; the others are answered here.
    `stdin`: an async iterable of lines (default: the process's standard input, read as UTF-8)."""
    source = (
        stdin
        if stdin is not None
        else anyio.wrap_file(TextIOWrapper(sys.stdin.buffer, encoding="utf-8", errors="replace"))
    )
    writer: list[Any] = []  # the session's write stream, once the transport exists

    async def good_lines() -> AsyncIterator[str]:
        async for line in source:
            if not line.strip():
                continue
            try:
                doc, error = check_line(line)
            except Exception as exc:  # never let one line end the session
                log.exception("could not check a message")
                doc, error = None, _error(None, types.INTERNAL_ERROR, f"Internal error: {type(exc).__name__}")
            if doc is not None:
                yield line
            elif error is not None and writer:
                await writer[0].send(SessionMessage(error))

    # stdio_server only iterates its stdin: the checked lines stand in for the file it expects
    async with stdio_server(stdin=cast(Any, good_lines()), stdout=None) as (read_stream, write_stream):
        writer.append(write_stream)
        yield read_stream, write_stream
