"""The Zenoh key layout of a Nutty fleet, and the names in it (docs/fleet.md).

Every engine lives under `nutty/<robot id>/`:

| key | what | who |
|---|---|---|
| `nutty/<id>/alive` | liveliness token: present while the engine runs | engine declares; fleet watches |
| `nutty/<id>/session/<sid>` | liveliness token: the running engine's session id (32 hex digits, new at each start) | engine declares; bridges check frames against it |
| `nutty/<id>/frames` | every Animation Frame, msgpack (the `/ws/frames` content) | engine publishes; bridges subscribe |
| `nutty/<id>/status` | engine statistics, JSON, every second; also answers queries | engine |
| `nutty/<id>/events` | command events (the `/ws/control` shape), and acks/errors of commands put here | engine |
| `nutty/<id>/commands` | commands (the REST union): put (ack on `events`) or query (ack as the reply) | fleet, AIs |
| `nutty/<id>/robot` | query: the robot's embodiment (`GET /api/robot`) | engine answers |
| `nutty/<id>/program` | query: the running program (`GET /api/program`) | engine answers |

A robot id is one key chunk: letters, digits, `_`, `.` and `-` (no `/`, and none of Zenoh's wildcard
characters `*`, `$`, `?`, `#`). A pattern (`museum-*`, `*`) may add `*` for any run of characters
within the id; it becomes Zenoh's `$*` (a bare `*` stays the chunk wildcard).
"""

from __future__ import annotations

import argparse
import fnmatch
import re
import socket

ROOT = "nutty"
ALIVE, FRAMES, STATUS, EVENTS, COMMANDS, ROBOT, PROGRAM, SESSION = (
    "alive",
    "frames",
    "status",
    "events",
    "commands",
    "robot",
    "program",
    "session",
)
QUERIES = (STATUS, ROBOT, PROGRAM)  # the leaves an engine answers queries on, besides COMMANDS

MAX_ID = 64  # characters in a robot id
_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")
_PATTERN = re.compile(r"[A-Za-z0-9_.*-]+")


def session_key(robot_id: str, session: str = "*") -> str:
    """The liveliness key naming an engine's session (`session`: 32 hex digits, or `*` for any)."""
    return key(robot_id, f"{SESSION}/{session}")


class RobotIdError(ValueError):
    """A robot id or pattern that cannot be a key chunk; the message says which character is wrong."""


def check_robot_id(text: str) -> str:
    """`text` if it is a valid robot id (see the module doc), else RobotIdError naming the problem."""
    if not isinstance(text, str) or not text:
        raise RobotIdError("a robot id cannot be empty")
    if len(text) > MAX_ID:
        raise RobotIdError(f"robot id '{text[:MAX_ID]}...' is longer than {MAX_ID} characters")
    if not _ID.fullmatch(text):
        bad = next((c for c in text if not (c.isascii() and (c.isalnum() or c in "_.-"))), text[0])
        raise RobotIdError(
            f"robot id '{text}' may only hold letters, digits, '_', '.' and '-' and start with a "
            f"letter or digit (found {bad!r})"
        )
    return text


def robot_id_arg(text: str) -> str:
    """argparse type of --robot-id."""
    try:
        return check_robot_id(text)
    except RobotIdError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def default_robot_id(robot_name: str, host: str | None = None) -> str:
    """The robot's name plus this host (`nutty_desk-lab-pc`), cut down to the characters an id allows."""
    host = host if host is not None else socket.gethostname().split(".")[0]
    text = re.sub(r"[^A-Za-z0-9_.-]+", "-", f"{robot_name}-{host}").strip("-._") or "robot"
    return check_robot_id(text[:MAX_ID].rstrip("-._") or "robot")


def check_pattern(pattern: str) -> str:
    """A robot id, or one with `*` wildcards (`museum-*`, `*`); RobotIdError otherwise."""
    if not isinstance(pattern, str) or not _PATTERN.fullmatch(pattern) or len(pattern) > MAX_ID:
        raise RobotIdError(
            f"'{pattern}' is neither a robot id nor a pattern: use letters, digits, '_', '.', '-' "
            f"and '*' (any run of characters), at most {MAX_ID} characters"
        )
    if "*" not in pattern:
        check_robot_id(pattern)
    return pattern


def chunk(pattern: str) -> str:
    """The Zenoh key chunk for a robot id or pattern: `museum-*` -> `museum-$*`, `*` -> `*`."""
    check_pattern(pattern)
    text = re.sub(r"\*+", "$*", pattern)
    return "*" if text == "$*" else text


def key(pattern: str, leaf: str) -> str:
    """`nutty/<chunk>/<leaf>` for a robot id or pattern."""
    return f"{ROOT}/{chunk(pattern)}/{leaf}"


def robot_of(key_expr: object) -> str | None:
    """The robot id in a concrete key `nutty/<id>/...` (None when it is not one of ours)."""
    parts = str(key_expr).split("/")
    if len(parts) < 3 or parts[0] != ROOT or not _ID.fullmatch(parts[1]):
        return None
    return parts[1]


def is_command_key(key_expr: object) -> bool:
    """Whether a put's or query's key names the `commands` leaf itself: `nutty/<id or pattern>/commands`.

    An engine runs commands only from such keys. A wider one (`nutty/**`) would also reach its commands
    subscriber, but Zenoh's access control matches a rule only on keys the rule's key includes, so a
    rule on `nutty/*/commands` would not stop it (docs/fleet.md, Security).
    """
    parts = str(key_expr).split("/")
    return len(parts) == 3 and parts[0] == ROOT and parts[2] == COMMANDS and "**" not in parts[1]


def matches(pattern: str, robot_id: str) -> bool:
    """Whether a robot id falls under a pattern (`*` = any run of characters)."""
    return fnmatch.fnmatchcase(robot_id, pattern.replace("[", "[[]"))
