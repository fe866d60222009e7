"""`nutty mcp`: offer a running robot's tools to AIs over the Model Context Protocol (docs/ai.md)."""

from __future__ import annotations

import os

from backend.commands._common import fail
from backend.logs import add_logging_options

DEFAULT_URL = "http://127.0.0.1:8000"


def register(sub) -> None:
    p = sub.add_parser(
        "mcp",
        help="offer a running robot's tools to AIs over MCP (stdio, or HTTP)",
        description="Speak the Model Context Protocol for a running `nutty serve`: its tools (play_clip, "
        "set_posture, look_at, ... generated from the robot, program and library), and "
        "its robot, program, library and status as resources. Over stdio by default "
        "(for an MCP client that starts it); with --http PORT over streamable HTTP at "
        "http://127.0.0.1:PORT/mcp. Logs go to stderr (stdout carries the protocol).",
    )
    p.add_argument("--url", default=DEFAULT_URL, help=f"the Nutty server (default {DEFAULT_URL})")
    p.add_argument(
        "--token",
        default=os.environ.get("NUTTY_TOKEN"),
        help="the server's --token (default: the NUTTY_TOKEN environment variable)",
    )
    p.add_argument(
        "--http",
        type=int,
        default=None,
        metavar="PORT",
        help="serve streamable HTTP on 127.0.0.1:PORT (path /mcp) instead of stdio",
    )
    add_logging_options(p)  # --log-level, --log-json (backend/logs.py): always to stderr
    p.set_defaults(func=run)


def run(args) -> int:
    import asyncio  # lazy: a fast `nutty --help`

    from backend.security import parse_origin  # lazy: a fast `nutty --help`

    if parse_origin(args.url.rstrip("/")) is None or not args.url.startswith(("http://", "https://")):
        return fail(f"--url must be http(s)://host[:port], got {args.url!r}")
    if args.http is not None and not 1 <= args.http <= 65535:
        return fail(f"--http must be a port within 1..65535, got {args.http}")
    from backend.mcp_bridge import Remote  # lazy: a fast `nutty --help`
    from backend.mcp_bridge import run as serve  # lazy: a fast `nutty --help`

    try:
        asyncio.run(serve(Remote(args.url, args.token), http=args.http))
    except KeyboardInterrupt:
        return 0
    return 0
