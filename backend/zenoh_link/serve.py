"""`nutty serve --zenoh`: the options and the two steps `serve` takes (join before the clock starts,
attach once the API's Hub exists)."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from backend.zenoh_link import keys
from backend.zenoh_link.session import SECURITY_DOCS, ZenohOptions, ZenohSetupError, add_zenoh_options, given

if TYPE_CHECKING:  # the link pulls in the API's routes: `nutty serve` imports it only with --zenoh
    from backend.zenoh_link.engine import EngineLink


def add_serve_options(parser: argparse.ArgumentParser) -> None:
    """--zenoh, --robot-id and the session options on `nutty serve`."""
    parser.add_argument(
        "--zenoh",
        action="store_true",
        help="also put this engine on Zenoh under nutty/<robot-id>/: frames, status, events, "
        "commands, queries and a liveliness token (docs/fleet.md)",
    )
    parser.add_argument(
        "--robot-id",
        type=keys.robot_id_arg,
        default=None,
        metavar="ID",
        help="this robot's id on Zenoh (letters, digits, _ . -; default: the robot's name and "
        "this host, e.g. nutty_desk-lab-pc)",
    )
    add_zenoh_options(parser)


def open_for_serve(args: argparse.Namespace, embodiment) -> EngineLink | None:
    """The engine's link when --zenoh is given (None otherwise); ZenohSetupError (a ValueError) for
    Zenoh options without --zenoh, options Zenoh refuses, or a robot id a live engine already has."""
    if not getattr(args, "zenoh", False):
        extra = given(args) + (["--robot-id"] if getattr(args, "robot_id", None) else [])
        if extra:
            raise ZenohSetupError(f"{', '.join(extra)} only apply with --zenoh")
        return None
    robot_id = args.robot_id or keys.default_robot_id(embodiment.name)
    options = ZenohOptions.from_args(args)
    if getattr(args, "token", None) is not None and not options.access_controlled():
        # The token guards HTTP; Zenoh has its own gate. One authority on every port: no token-less door.
        raise ZenohSetupError(
            "--token guards HTTP only: with --zenoh, give a --zenoh-config with access control "
            f"(access_control.enabled, e.g. docs/fleet/engine.json5; see {SECURITY_DOCS})"
        )
    warning = options.exposure_warning()
    if warning:
        print(f"nutty serve: warning: {warning}", file=sys.stderr, flush=True)
    from backend.zenoh_link.engine import EngineLink  # lazy: the API's routes, only with --zenoh

    return EngineLink.open(options, robot_id)


def banner(link: EngineLink) -> str:
    return f"  Zenoh    robot id '{link.robot_id}' on {keys.key(link.robot_id, '**')} ({link.options.describe()})"
