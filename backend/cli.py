"""The `nutty` command line.

Each sub-command lives in its own module under `backend.commands` and exposes
`register(subparsers)`, which adds its parser and sets `func(args) -> int` as the handler.
Modules are discovered, so adding a command never touches this file. A module is named after its
command (`serve.py`), or after it and a suffix when the name is taken (`import_clip.py` for `import`):
`nutty serve` then imports the serve module alone, so the robot's first frame never waits for the
imports of every other command (the full parser, for `--help` or a mistyped command, imports them all).

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


def command_modules(word: str | None = None) -> list[str]:
    """The command modules' names: all of them, or those that may define the command `word` (named
    `word` or `word_...`)."""
    names = sorted(m.name for m in pkgutil.iter_modules(_commands_pkg.__path__) if not m.name.startswith("_"))
    if word is None:
        return names
    return [n for n in names if n == word or n.startswith(f"{word}_")]


def build_parser(word: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser: with every command, or (`word`) with the commands of the modules that
    may define it."""
    return _parser(word)[0]


def _parser(word: str | None) -> tuple[argparse.ArgumentParser, set[str]]:
    """build_parser's parser, and the commands it knows."""
    parser = argparse.ArgumentParser(
        prog="nutty",
        description="Nutty robot animation engine: run Animation Programs on a robot's embodiment.",
        epilog="serve, bridge and mcp log to stderr: --log-level {debug,info,warning,error} (default "
        "info) and --log-json (one JSON object per line) go after the command's name.",
    )
    parser.add_argument("--version", action="version", version=f"nutty {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in command_modules(word):
        importlib.import_module(f"{_commands_pkg.__name__}.{name}").register(sub)
    return parser, set(sub.choices)


def parser_for(argv: list[str]) -> argparse.ArgumentParser:
    """The parser for `argv`: only the named command's module when that module defines it, else all."""
    word = argv[0] if argv and not argv[0].startswith("-") else None
    if word is not None:
        lean, known = _parser(word)
        if word in known:
            return lean
    return build_parser()


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = parser_for(argv)
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
