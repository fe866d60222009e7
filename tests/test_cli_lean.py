"""`nutty COMMAND` imports only COMMAND's module (backend/cli.py), and the parser it builds is the full
parser's: every command, sub-command and option parses alike; `--help` and an unknown command still see
every command."""

from __future__ import annotations

import argparse
import contextlib
import io

import pytest

from backend.cli import build_parser, command_modules, parser_for


def _commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _shape(parser: argparse.ArgumentParser) -> list:
    """Every option and positional of a parser and its sub-parsers, with their defaults and choices."""
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            out.append(("sub", {name: _shape(p) for name, p in action.choices.items()}))
        elif not isinstance(action, argparse._HelpAction):
            out.append((tuple(action.option_strings), action.dest, repr(action.default), action.choices))
    return out


FULL = _commands(build_parser())


@pytest.mark.parametrize("name", sorted(FULL))
def test_each_command_gets_its_own_module_and_the_same_parser(name):
    lean = parser_for([name])
    lean_commands = _commands(lean)
    assert name in lean_commands
    assert len(lean_commands) < len(FULL)  # not every module was imported
    assert _shape(lean_commands[name]) == _shape(FULL[name])


def test_every_command_module_is_found_by_its_command():
    found = {m for name in FULL for m in command_modules(name)}
    assert found == set(command_modules())  # a module not named after its command would cost start-up


def test_help_and_unknown_commands_see_every_command():
    for argv in ([], ["--help"], ["sevre"]):
        assert set(_commands(parser_for(argv))) == set(FULL)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), pytest.raises(SystemExit):
        parser_for(["sevre"]).parse_args(["sevre"])
    assert "serve" in err.getvalue()  # the choices are listed
