"""The `nutty` command line.

Each sub-command lives in its own module under `backend.commands` and exposes
`register(subparsers)`, which adds its parser and sets `func(args) -> int` as the handler.
Modules are discovered, so adding a command never touches this file.

The long-running commands (`serve`, `bridge`, `mcp`) take `--log-level` and `--log-json` after their
name (`nutty serve --log-level debug`); `main` configures logging from them (backend/logs.py).
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from backend import __version__
from backend import commands as _commands_pkg
from backend.logs import configure_from_args


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="nutty",
        description="Nutty robot animation engine: run Animation Programs on a robot's embodiment.",
        epilog="serve, bridge and mcp log to stderr: --log-level {debug,info,warning,error} (default "
        "info) and --log-json (one JSON object per line) go after the command's name.",
    )
    parser.add_argument("--version", action="version", version=f"nutty {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(_commands_pkg.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{_commands_pkg.__name__}.{info.name}")
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    configure_from_args(args)  # only the commands with --log-level: the others print what they do
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
