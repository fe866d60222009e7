"""Drivers that the command line can attach: one declaration per driver class, one entry point.

A driver is a `Sink` class that declares its command-line option as `option = DriverOption(...)` and
makes itself from the option's value with `from_option(embodiment, value)`. It is registered by an entry
point named after the option, in the pyproject.toml of its distribution (this project's, or a plugin
package's; see backend.plugins):

    [project.entry-points."nutty.drivers"]
    udp-json = "backend.drivers.udp_json:UdpJsonDriver"

then `pip install -e .`. `nutty serve` (and any tool that takes drivers, e.g. a robot-side bridge)
gets the options from `add_driver_options(parser)` and the sinks from `build_drivers(embodiment, args)`.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from backend.engine.embodiment import Embodiment
from backend.engine.runtime import Sink
from backend.plugins import load


def _unregistered(embodiment: Embodiment, value: Any) -> Sink:
    raise TypeError("a driver option builds its sink once its class is registered (register_driver)")


@dataclass(frozen=True)
class DriverSetting:
    """A further flag of a driver (`--<name>`), e.g. `--sim-table 0.1` beside `--sim mujoco`: `parse`
    converts the text (argparse type); `flag=True` makes a switch that takes no value."""

    name: str
    metavar: str | None
    help: str
    parse: Callable[[str], Any] = str
    flag: bool = False

    @property
    def dest(self) -> str:
        return self.name.replace("-", "_")


@dataclass(frozen=True)
class DriverArgs:
    """What `from_option` gets for a driver that declares settings: its option's value and every
    setting's value by dest (None, or False for a switch, when not given), plus the whole command line
    (`args`) for a driver that reads another's option."""

    value: Any
    settings: dict[str, Any]
    args: argparse.Namespace


@dataclass(frozen=True)
class DriverOption:
    """How one driver appears on the command line.

    `name` is the driver's short name (`osc`, `record`, `sim-servo`) and its flag (`--<name>`);
    `parse` converts and validates the text (an `argparse` type: raise `argparse.ArgumentTypeError`
    with a clear message); `enabled(value)` says whether the given value asks for the driver (e.g.
    0 Hz disables servos). `build(embodiment, value)` makes the sink from the option's value: the
    class's `from_option`, filled in when the class is registered.
    """

    name: str
    metavar: str
    help: str
    parse: Callable[[str], Any] = str
    default: Any = None
    enabled: Callable[[Any], bool] = bool
    build: Callable[[Embodiment, Any], Sink] = _unregistered
    #: The driver starts the engine itself (`prepare(engine)`, e.g. real servos: from the measured
    #: pose), so only `nutty serve` can run it, not the engine-less bridge or player.
    needs_engine: bool = False
    #: Further flags (`DriverSetting`); a driver that declares any gets a `DriverArgs` in `from_option`.
    settings: tuple[DriverSetting, ...] = ()

    @property
    def dest(self) -> str:
        return self.name.replace("-", "_")


DRIVER_OPTIONS: dict[str, DriverOption] = {}


def option_name(cls: Any) -> str:
    """The option name a driver class declares (its entry point's name)."""
    return cls.option.name


def register_driver(cls: type[Sink], registry: dict[str, DriverOption] | None = None) -> type[Sink]:
    """Add a driver class's option to `registry` (default DRIVER_OPTIONS; names are unique). The plugin
    loader calls it for every `nutty.drivers` entry point (`reload`)."""
    options = DRIVER_OPTIONS if registry is None else registry
    opt = getattr(cls, "option", None)
    if not isinstance(opt, DriverOption):
        raise TypeError(f"{cls!r} declares no `option = DriverOption(...)`")
    build: Callable[[Embodiment, Any], Sink] | None = getattr(cls, "from_option", None)
    if not callable(build):
        raise TypeError(f"{cls!r} has no from_option(embodiment, value) classmethod")
    if opt.name in options:
        raise ValueError(
            f"driver option --{opt.name} is declared twice ({options[opt.name].build} and {cls})"
        )
    options[opt.name] = dataclasses.replace(opt, build=build)
    return cls


def reload() -> None:
    """Fill DRIVER_OPTIONS (in place) from the `nutty.drivers` entry points; on a PluginError it is left
    as it was."""
    found: dict[str, DriverOption] = {}
    load("nutty.drivers", option_name, lambda cls: register_driver(cls, found))
    DRIVER_OPTIONS.clear()
    DRIVER_OPTIONS.update(found)


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
        for setting in opt.settings:
            if setting.flag:
                parser.add_argument(
                    f"--{setting.name}", dest=setting.dest, action="store_true", help=setting.help
                )
            else:
                parser.add_argument(
                    f"--{setting.name}",
                    dest=setting.dest,
                    metavar=setting.metavar,
                    type=setting.parse,
                    default=None,
                    help=setting.help,
                )


def build_drivers(embodiment: Embodiment, args: argparse.Namespace) -> list[Sink]:
    """The sinks the parsed command line asks for, in declaration-name order."""
    sinks = []
    for name in sorted(DRIVER_OPTIONS):
        opt = DRIVER_OPTIONS[name]
        value = getattr(args, opt.dest, opt.default)
        if value is not None and opt.enabled(value):
            sinks.append(build_driver(opt, embodiment, value, args))
            continue
        for setting in opt.settings:  # a setting alone would be silently ignored: say so instead
            if getattr(args, setting.dest, None) not in (None, False):
                raise ValueError(f"--{setting.name} needs --{opt.name}")
    return sinks


def build_driver(opt: DriverOption, embodiment: Embodiment, value: Any, args: argparse.Namespace) -> Sink:
    """One driver's sink from its option's value (with its settings, when it declares any)."""
    if opt.settings:
        settings = {st.dest: getattr(args, st.dest, None) for st in opt.settings}
        return opt.build(embodiment, DriverArgs(value, settings, args))
    return opt.build(embodiment, value)


def engine_only(args: argparse.Namespace, tool: str) -> str | None:
    """Why `tool` (an engine-less command: the bridge, the player) cannot run the drivers `args` asks
    for, or None: a driver that starts the engine itself runs only in `nutty serve`."""
    for name in sorted(DRIVER_OPTIONS):
        opt = DRIVER_OPTIONS[name]
        value = getattr(args, opt.dest, opt.default)
        if opt.needs_engine and value is not None and opt.enabled(value):
            return f"--{name} runs only in `nutty serve` (it starts the engine from where the robot stands), not in {tool}"
    return None


def host_port(text: str, default_host: str | None = None) -> tuple[str, int]:
    """Parse `HOST:PORT` (port 1..65535) for network drivers; with `default_host`, `PORT` alone too."""
    host, _, port = text.rpartition(":")
    host = host or (default_host or "")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        wanted = "PORT or HOST:PORT" if default_host else "HOST:PORT"
        raise argparse.ArgumentTypeError(f"expected {wanted} with a port within 1..65535, got '{text}'")
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
