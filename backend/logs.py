"""Logging for the long-running commands (`nutty serve`, `nutty bridge`, `nutty mcp`).

Every record goes to stderr: stdout stays for what a command promises to print (the server's
banner, the bridge's `summary` line, and for `nutty mcp` the JSON-RPC stream itself). Two forms:

- text (default): `2025-01-02 12:00:00,123 WARNING backend.shutdown: ...`, a traceback below when
  there is one;
- JSON lines (`--log-json`): one object per line with `time` (ISO 8601, UTC), `level`, `logger`,
  `message` and, when an exception was logged, `exc_info` (the formatted traceback).

`--log-level` sets the root logger and uvicorn's own loggers. Libraries that log every request at
INFO (httpx, the MCP SDK, websockets, uvicorn's access lines) are held at WARNING unless the level is
debug, so the default output says what the robot and the server do, not each HTTP exchange.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from datetime import UTC, datetime
from typing import IO, Any

LEVELS = ("debug", "info", "warning", "error")
DEFAULT_LEVEL = "info"
TEXT_FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"
UVICORN_LOGGERS = ("uvicorn", "uvicorn.error", "uvicorn.asgi")
# One line per HTTP request or protocol message at INFO: shown only at debug.
CHATTY_LOGGERS = ("uvicorn.access", "httpx", "httpcore", "mcp", "websockets")

_settings: tuple[str | int, bool] | None = None  # what configure_logging was last called with


class JsonLinesFormatter(logging.Formatter):
    """One JSON object per record: time, level, logger, message, and exc_info when there is one."""

    def format(self, record: logging.LogRecord) -> str:
        doc: dict[str, Any] = {
            "time": datetime.fromtimestamp(record.created, UTC).isoformat(timespec="milliseconds"),
            "level": record.levelname,
            "logger": record.name,
            "message": record.getMessage(),
        }
        if record.exc_info:
            doc["exc_info"] = self.formatException(record.exc_info)
        elif record.exc_text:
            doc["exc_info"] = record.exc_text
        if record.stack_info:
            doc["stack_info"] = self.formatStack(record.stack_info)
        return json.dumps(doc, ensure_ascii=False, default=str)


class _NuttyHandler(logging.StreamHandler):
    """The handler configure_logging installs (told apart from others, e.g. pytest's, to replace it)."""


def level_number(level: str | int) -> int:
    """A level name of LEVELS (any case) or a logging level number, as a number."""
    if isinstance(level, int):
        return level
    name = str(level).lower()
    if name not in LEVELS:
        raise ValueError(f"log level must be one of {', '.join(LEVELS)}, got {level!r}")
    return logging.getLevelNamesMapping()[name.upper()]


def configure_logging(
    level: str | int = DEFAULT_LEVEL, json_lines: bool = False, stream: IO[str] | None = None
) -> None:
    """Send every record at `level` or above to `stream` (default: stderr) as text or JSON lines.

    Idempotent: a second call replaces the handler of the first. Handlers others installed on the
    root logger (a test runner's) are left in place.
    """
    global _settings
    number = level_number(level)
    handler = _NuttyHandler(stream if stream is not None else sys.stderr)
    if json_lines:
        handler.setFormatter(JsonLinesFormatter())
    else:
        handler.setFormatter(logging.Formatter(TEXT_FORMAT))
    root = logging.getLogger()
    for old in [h for h in root.handlers if isinstance(h, _NuttyHandler)]:
        root.removeHandler(old)
    root.addHandler(handler)
    root.setLevel(number)
    for name in UVICORN_LOGGERS:
        logging.getLogger(name).setLevel(number)
    for name in CHATTY_LOGGERS:
        logging.getLogger(name).setLevel(number if number <= logging.DEBUG else max(number, logging.WARNING))
    logging.captureWarnings(True)
    name = logging.getLevelName(number).lower()
    _settings = (name if name in LEVELS else number, bool(json_lines))


def direct_line(logger: str, level: int, message: str, now: float | None = None) -> bytes:
    """`message` as the configured handler would write it (text or JSON, one line), for a caller that
    must write to fd 2 itself: a signal handler or a watchdog, which cannot take the logging module's
    locks or a buffered stream's (the thread they interrupted, or a hung one, may hold them).
    `now`: the line's Unix time (s), by default the current time."""
    now = time.time() if now is None else now
    name = logging.getLevelName(level)
    if _settings is not None and _settings[1]:
        doc = {
            "time": datetime.fromtimestamp(now, UTC).isoformat(timespec="milliseconds"),
            "level": name,
            "logger": logger,
            "message": message,
        }
        line = json.dumps(doc, ensure_ascii=False)
    else:
        stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(now)) + f",{int(now % 1 * 1000):03d}"
        line = f"{stamp} {name} {logger}: {message}".replace("\n", " ")
    return (line + "\n").encode(errors="replace")


def settings() -> tuple[str | int, bool] | None:
    """(level, json_lines) of the last configure_logging, for a child process to log the same way;
    None when logging was never configured here."""
    return _settings


def add_logging_options(parser: argparse.ArgumentParser) -> None:
    """--log-level and --log-json on a long-running command's parser."""
    group = parser.add_argument_group("logging (to stderr)")
    group.add_argument(
        "--log-level",
        choices=LEVELS,
        default=DEFAULT_LEVEL,
        type=str.lower,
        help=f"the least severe messages shown (default {DEFAULT_LEVEL}; debug adds per-request lines)",
    )
    group.add_argument(
        "--log-json",
        action="store_true",
        help="one JSON object per line (time, level, logger, message, exc_info) instead of text",
    )


def configure_from_args(args: argparse.Namespace) -> bool:
    """configure_logging from a command's --log-level/--log-json; False (nothing done) for a command
    without them."""
    level = getattr(args, "log_level", None)
    if level is None:
        return False
    configure_logging(level, bool(getattr(args, "log_json", False)))
    return True


class Throttle:
    """Log a repeating failure without flooding: the first occurrence of a kind (`key`, e.g. the
    exception's type) at once, then that kind at most every `every` seconds, with how many were not
    logged meanwhile. For a fault that can recur on every tick of a 1 kHz clock."""

    MAX_KINDS = 64  # kinds remembered; the oldest is forgotten (and may be logged again at once)

    def __init__(self, every: float = 10.0, clock=time.monotonic):
        self.every = float(every)
        self._clock = clock
        self._kinds: dict[str, list] = {}  # key -> [last logged at (clock s), skipped since]

    def due(self, key: str) -> int | None:
        """None when `key` should not be logged now; otherwise how many of it were skipped before."""
        now = self._clock()
        seen = self._kinds.get(key)
        if seen is not None and now - seen[0] < self.every:
            seen[1] += 1
            return None
        skipped = seen[1] if seen is not None else 0
        self._kinds.pop(key, None)
        self._kinds[key] = [now, 0]
        while len(self._kinds) > self.MAX_KINDS:
            self._kinds.pop(next(iter(self._kinds)))
        return skipped
