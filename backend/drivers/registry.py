"""Drivers that the command line can attach: one declaration per driver class, no list to edit.

A driver module declares its command-line option with `@driver_option(...)` on its `Sink` class;
`nutty serve` (and any tool that takes drivers, e.g. a robot-side bridge) gets the option from
`add_driver_options(parser)` and the sinks from `build_drivers(embodiment, args)`. Every module of
`backend.drivers` is imported by the package, so adding a driver is one new file (and its test).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from backend.engine.embodiment import Embodiment
from backend.engine.runtime import Sink


@dataclass(frozen=True)
class DriverOption:
    """How one driver appears on the command line.

    `name` is the driver's short name (`osc`, `record`, `sim-servo`) and its flag (`--<name>`);
    `build(embodiment, value)` makes the sink from the option's value; `parse` converts and validates
    the text (an `argparse` type: raise `argparse.ArgumentTypeError` with a clear message);
    `enabled(value)` says whether the given value asks for the driver (e.g. 0 Hz disables servos).
    """

    name: str
    metavar: str
    help: str
    build: Callable[[Embodiment, Any], Sink]
    parse: Callable[[str], Any] = str
    default: Any = None
    enabled: Callable[[Any], bool] = bool

    @property
    def dest(self) -> str:
        return self.name.replace("-", "_")


DRIVER_OPTIONS: dict[str, DriverOption] = {}


def driver_option(
    name: str,
    *,
    metavar: str,
    help: str,
    parse: Callable[[str], Any] = str,
    default: Any = None,
    enabled: Callable[[Any], bool] = bool,
):
    """Class decorator: declare a `Sink` subclass's command-line option.

    The class must provide `from_option(embodiment, value) -> Sink` (a classmethod).
    """

    def register(cls: type[Sink]) -> type[Sink]:
        if name in DRIVER_OPTIONS:
            raise ValueError(
                f"driver option --{name} is declared twice ({DRIVER_OPTIONS[name].build} and {cls})"
            )
        DRIVER_OPTIONS[name] = DriverOption(name, metavar, help, cls.from_option, parse, default, enabled)
        return cls

    return register


def add_driver_options(parser: argparse.ArgumentParser) -> None:
    """Add `--<name>` for every declared driver (sorted by name, so `--help` is stable)."""
    for name in sorted(DRIVER_OPTIONS):
        opt = DRIVER_OPTIONS[name]
        parser.add_argument(
            f"--{name}",
            dest=opt.dest,
            metavar=opt.metavar,
            type=opt.parse,
            default=opt.default,
            help=opt.help,
        )


def build_drivers(embodiment: Embodiment, args: argparse.Namespace) -> list[Sink]:
    """The sinks the parsed command line asks for, in declaration-name order."""
    sinks = []
    for name in sorted(DRIVER_OPTIONS):
        opt = DRIVER_OPTIONS[name]
        value = getattr(args, opt.dest, opt.default)
        if value is not None and opt.enabled(value):
            sinks.append(opt.build(embodiment, value))
    return sinks


def host_port(text: str) -> tuple[str, int]:
    """Parse `HOST:PORT` (port 1..65535) for network drivers."""
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT with a port within 1..65535, got '{text}'")
    return host, int(port)


def positive_or_off(text: str) -> float:
    """A rate in Hz; 0 turns the driver off."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of Hz (0 = off), got '{text}'") from None
    if not value >= 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number of Hz >= 0 (0 = off), got '{text}'")
    return value
