"""JSON that cannot hurt the server: parsing, checking and writing request and message bodies.

`loads` parses with NaN/Infinity, numbers that overflow to infinity, integers beyond 2**63, invalid
Unicode (lone surrogates), a key given twice in one object and nesting deeper than `MAX_DEPTH` refused
with an error that names the field; `check_json` applies the same rules to an already parsed value (every entry point: REST,
WebSockets, in-process commands); `dumps` never fails (a value that cannot be serialised is
sanitised rather than turned into a 500 or a dead socket).

`dumps` writes with orjson (several times faster than the standard library on telemetry; figures in
benchmarks/RESULTS.md: the event loop holds the interpreter lock, which the engine's clock waits for,
that much less) and falls back to the standard library's encoder on anything orjson refuses, so both
give the same values.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import orjson

MAX_BODY = 1_000_000  # bytes per request body
MAX_MESSAGE = 64_000  # bytes per command message on a bus or /ws/control
MAX_DEPTH = 64  # nesting of JSON arrays/objects
MAX_INT = 2**63  # |int| limit: larger integers overflow floats and fixed-width fields downstream


class JsonSafetyError(ValueError):
    """A JSON document or value the server refuses; `code`, `field` and `status` describe why."""

    def __init__(
        self, message: str, code: str = "malformed_json", field: str | None = None, status: int = 400
    ):
        super().__init__(message)
        self.code = code
        self.field = field
        self.status = status


def _path(parts: tuple[Any, ...]) -> str:
    out = ""
    for p in parts:
        if isinstance(p, int):
            out += f"[{p}]"
        else:
            out += f".{safe_text(p)}" if out else safe_text(p)
    return out


def _valid_text(s: str) -> bool:
    if s.isascii():
        return True
    try:
        s.encode("utf-8")
        return True
    except UnicodeEncodeError:
        return False


def check_json(value: Any, *, max_depth: int = MAX_DEPTH, where: str = "", status: int = 400) -> None:
    """Refuse what JSON must not carry into the engine: raises JsonSafetyError naming the field.

    Checks (iteratively, so any depth is safe to inspect): nesting <= `max_depth`, floats finite,
    ints within +-2**63, strings and keys valid Unicode, only JSON types (dict, list/tuple, str,
    int, float, bool, None; numpy scalars are floats/ints and pass).
    """
    stack: list[tuple[Any, int, tuple[Any, ...]]] = [(value, 0, ())]
    prefix = (where,) if where else ()
    while stack:
        v, depth, parts = stack.pop()
        if v is None or isinstance(v, bool):
            continue
        if isinstance(v, float):
            if not math.isfinite(v):
                p = _path(prefix + parts)
                raise JsonSafetyError(
                    f"{p or 'value'}: NaN and infinity are not allowed", "non_finite", p or None, status
                )
            continue
        if isinstance(v, int):
            if not -MAX_INT <= v <= MAX_INT:
                p = _path(prefix + parts)
                raise JsonSafetyError(
                    f"{p or 'value'}: integer out of range (|n| <= 2**63)",
                    "number_too_large",
                    p or None,
                    status,
                )
            continue
        if isinstance(v, str):
            if not _valid_text(v):
                p = _path(prefix + parts)
                raise JsonSafetyError(
                    f"{p or 'value'}: invalid Unicode (a lone surrogate)",
                    "invalid_unicode",
                    p or None,
                    status,
                )
            continue
        if isinstance(v, (dict, list, tuple)):
            if depth >= max_depth:
                p = _path(prefix + parts)
                raise JsonSafetyError(
                    f"{p or 'value'}: nested deeper than {max_depth} levels", "too_deep", p or None, status
                )
            if isinstance(v, dict):
                for k, item in v.items():
                    if not isinstance(k, str):
                        k = str(k)
                    if not _valid_text(k):
                        p = _path(prefix + parts)
                        raise JsonSafetyError(
                            f"{p or 'value'}: a key is invalid Unicode (a lone surrogate)",
                            "invalid_unicode",
                            p or None,
                            status,
                        )
                    stack.append((item, depth + 1, (*parts, k)))
            else:
                for i, item in enumerate(v):
                    stack.append((item, depth + 1, (*parts, i)))
            continue
        try:  # numpy scalars and other numbers
            x = float(v)
        except (TypeError, ValueError, OverflowError):
            p = _path(prefix + parts)
            raise JsonSafetyError(
                f"{p or 'value'}: {type(v).__name__} is not a JSON value", "invalid_type", p or None, status
            ) from None
        if not math.isfinite(x):
            p = _path(prefix + parts)
            raise JsonSafetyError(
                f"{p or 'value'}: NaN and infinity are not allowed", "non_finite", p or None, status
            )


def deep_path(text: str, max_depth: int = MAX_DEPTH) -> str:
    """The member whose value nests past `max_depth` in a JSON text (`params.arguments`: the deepest
    object key on the way there), read without parsing it (a parser would recurse that deep); "" when
    the nesting stays within the limit or starts at the top."""
    stack: list[list[Any]] = []  # per open container: [its bracket, the current item index]
    path: list[Any] = []  # the key or index leading into each open container but the outermost
    key: str | None = None
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            token, i = text[i : j + 1], j + 1
            if stack and stack[-1][0] == "{" and text[i : i + 64].lstrip().startswith(":"):
                try:
                    key = json.loads(token)
                except ValueError:
                    key = token.strip('"')
            continue
        if c in "[{":
            if stack:
                path.append(key if stack[-1][0] == "{" else stack[-1][1])
            stack.append([c, 0])
            key = None
            if len(stack) > max_depth:
                named = [k for k, part in enumerate(path) if isinstance(part, str)]
                return _path(tuple(path[: named[-1] + 1])) if named else ""
        elif c in "]}" and stack:
            stack.pop()
            if path:
                path.pop()
        elif c == "," and stack and stack[-1][0] == "[":
            stack[-1][1] += 1
        i += 1
    return ""


def _bad_constant(name: str) -> Any:
    raise JsonSafetyError(f"{name} is not allowed (JSON numbers are finite)", "non_finite")


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """An object's members, refusing a key given twice (parsers disagree on which one wins)."""
    out = dict(pairs)
    if len(out) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise JsonSafetyError(
                    f"{safe_text(key)}: the key is given twice in one object", "duplicate_key", safe_text(key)
                )
            seen.add(key)
    return out


def loads(
    raw: bytes | bytearray | str, *, max_bytes: int | None = MAX_BODY, max_depth: int = MAX_DEPTH
) -> Any:
    """Parse JSON the safe way (see module doc). Raises JsonSafetyError with a 4xx `status`."""
    if max_bytes is not None and len(raw) > max_bytes:
        raise JsonSafetyError(f"over {max_bytes} bytes", "too_large", status=413)
    if isinstance(raw, (bytes, bytearray)):
        try:
            raw = bytes(raw).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise JsonSafetyError(
                f"the body is not valid UTF-8 (byte {exc.start})", "invalid_unicode"
            ) from None
    try:
        value = json.loads(raw, parse_constant=_bad_constant, object_pairs_hook=_unique_keys)
    except JsonSafetyError:
        raise
    except RecursionError:
        where = deep_path(raw, max_depth)
        raise JsonSafetyError(
            f"{where + ': ' if where else ''}nested deeper than {max_depth} levels", "too_deep", where or None
        ) from None
    except ValueError as exc:  # JSONDecodeError, and int() of a number with too many digits
        raise JsonSafetyError(f"malformed JSON: {safe_text(str(exc))[:200]}", "malformed_json") from None
    check_json(value, max_depth=max_depth)
    return value


def decode_message(payload: bytes, max_bytes: int = MAX_MESSAGE) -> Any:
    """The JSON value of one bus message (a Zenoh or ROS 2 command, a reply); JsonSafetyError (code
    too_large, invalid_unicode, malformed_json, ...) as `loads` raises it."""
    if len(payload) > max_bytes:
        raise JsonSafetyError(f"message over {max_bytes} bytes", "too_large", status=413)
    return loads(payload, max_bytes=None)


def validation_bytes(value: Any) -> bytes:
    """A value checked by `check_json` as JSON bytes, for validating it *as JSON* (pydantic's strict JSON
    mode): numpy scalars and arrays from in-process callers become the numbers they hold."""
    return orjson.dumps(value, option=orjson.OPT_SERIALIZE_NUMPY, default=_numpy_scalar)


def safe_text(s: Any) -> str:
    """A string that always encodes as UTF-8 (lone surrogates become \\udXXX escapes)."""
    s = s if isinstance(s, str) else str(s)
    if _valid_text(s):
        return s
    return s.encode("utf-8", "backslashreplace").decode("utf-8")


def sanitize(value: Any, _depth: int = 0) -> Any:
    """A JSON-serialisable copy: non-finite floats -> None, bad strings escaped, odd types as str."""
    if _depth > 2 * MAX_DEPTH:
        return None
    if value is None or isinstance(value, (bool, int)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, str):
        return safe_text(value)
    if isinstance(value, dict):
        return {safe_text(k): sanitize(v, _depth + 1) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [sanitize(v, _depth + 1) for v in value]
    try:
        x = float(value)
        return x if math.isfinite(x) else None
    except (TypeError, ValueError, OverflowError):
        return safe_text(value)


# Dict keys as the standard library writes them (numbers, booleans, None as strings); dataclasses and
# datetimes left to the fallback (the standard library refuses them: they are sanitised to strings).
_ORJSON_OPTIONS = orjson.OPT_NON_STR_KEYS | orjson.OPT_PASSTHROUGH_DATACLASS | orjson.OPT_PASSTHROUGH_DATETIME


def _numpy_scalar(value: Any) -> float:
    """orjson's `default`: numpy numbers as the sanitised fallback writes them (floats; non-finite:
    orjson writes null, as the fallback does); anything else goes to the fallback."""
    if isinstance(value, (np.floating, np.integer)):
        return float(value)
    raise TypeError


def dumps(value: Any) -> str:
    """JSON text that is always valid and encodable: orjson, else the standard library, else a
    sanitised copy. Non-finite numbers are written as null."""
    try:
        return orjson.dumps(value, default=_numpy_scalar, option=_ORJSON_OPTIONS).decode("utf-8")
    except (TypeError, ValueError, RecursionError, orjson.JSONEncodeError):
        pass
    try:
        text = json.dumps(value, ensure_ascii=False, allow_nan=False, separators=(",", ":"))
        if _valid_text(text):
            return text
    except (TypeError, ValueError, RecursionError):
        pass
    return json.dumps(sanitize(value), ensure_ascii=False, allow_nan=False, separators=(",", ":"))


def error_body(code: str, message: str, **extra: Any) -> dict[str, Any]:
    return {"detail": {"code": code, "message": safe_text(message), **{k: v for k, v in extra.items()}}}
