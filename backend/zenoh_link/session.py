"""Joining Zenoh: the command-line options every Nutty tool shares, and opening a session from them.

`nutty serve --zenoh`, `nutty bridge` and `nutty fleet` take the same options:

- `--zenoh-mode peer|client|router` (default: peer, or the config file's mode): a peer talks to other
  peers directly and finds them by multicast scouting on the LAN; a client goes through one router or
  peer; a router forwards for others (`nutty fleet router` runs one).
- `--zenoh-connect ENDPOINT` / `--zenoh-listen ENDPOINT` (repeatable): e.g. `tcp/192.168.1.20:7447`.
  Given, they replace the config file's lists.
- `--zenoh-config FILE`: a Zenoh JSON5 configuration (access control, TLS, user/password,
  scouting): the flags above are applied on top. docs/fleet/ has the examples; docs/fleet.md explains.
- `--zenoh-scout`: find peers by multicast scouting on the LAN.

Secure by default: unless `--zenoh-listen` or the config file names listen endpoints, a session listens
on loopback only (`tcp/127.0.0.1:0`; Zenoh's own default is every interface), and unless
`--zenoh-scout` or the config file sets `scouting.multicast`, multicast scouting is off (peers are
found through explicit endpoints). Listening beyond loopback without access control is warned about
(`exposure_warning`).

Every session must be closed (`Session.close`): a Python process whose Zenoh session still has
callbacks declared does not exit. The tools here close theirs in `finally` blocks.
"""

from __future__ import annotations

import argparse
import json
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

MODES = ("peer", "client", "router")
#: Where a session listens when neither a flag nor its config file says (Zenoh's default: everywhere).
LOOPBACK_LISTEN = ["tcp/127.0.0.1:0"]
_LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "[::1]", "::1")
#: Where docs/fleet.md explains access control (named in refusals and warnings).
SECURITY_DOCS = "docs/fleet.md#security-who-may-move-the-robot"
# The protocols of Zenoh's standard build that take `host:port` addresses.
_IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
_ENDPOINT = re.compile(r"(?P<proto>[a-z][a-z0-9-]*)/(?P<address>[^?#\s]+)(?:\?[^#\s]*)?(?:#\S*)?")


class ZenohSetupError(ValueError):
    """A Zenoh option or configuration that cannot work; the message names the option and the reason."""


def endpoint_arg(text: str) -> str:
    """argparse type of --zenoh-connect/--zenoh-listen: `<protocol>/<address>`, a port within 0..65535."""
    m = _ENDPOINT.fullmatch(text)
    if not m:
        raise argparse.ArgumentTypeError(
            f"expected a Zenoh endpoint such as tcp/127.0.0.1:7447, got '{text}'"
        )
    if m["proto"] in _IP_PROTOCOLS:
        host, _, port = m["address"].rpartition(":")
        if not host or not port.isdigit() or int(port) > 65535:
            raise argparse.ArgumentTypeError(
                f"expected {m['proto']}/HOST:PORT with a port within 0..65535, got '{text}'"
            )
    return text


def add_zenoh_options(parser: argparse.ArgumentParser) -> None:
    """The session options (see the module doc) on a sub-command's parser."""
    g = parser.add_argument_group("Zenoh")
    g.add_argument(
        "--zenoh-mode",
        choices=MODES,
        default=None,
        help="peer (default: talk to peers directly, find them on the LAN), client (through a router) "
        "or router",
    )
    g.add_argument(
        "--zenoh-connect",
        action="append",
        default=[],
        type=endpoint_arg,
        metavar="ENDPOINT",
        help="connect to this Zenoh endpoint, e.g. tcp/192.168.1.20:7447 (repeatable)",
    )
    g.add_argument(
        "--zenoh-listen",
        action="append",
        default=[],
        type=endpoint_arg,
        metavar="ENDPOINT",
        help="listen on this Zenoh endpoint, e.g. tcp/0.0.0.0:7447 (repeatable)",
    )
    g.add_argument(
        "--zenoh-scout",
        action="store_true",
        default=False,
        help="find peers by multicast scouting on the LAN (off by default: explicit endpoints only)",
    )
    g.add_argument(
        "--zenoh-config",
        default=None,
        metavar="FILE",
        help="Zenoh JSON5 configuration (access control, TLS, credentials, scouting); the flags above "
        "apply on top (docs/fleet.md)",
    )


def given(args: argparse.Namespace) -> list[str]:
    """The Zenoh session options set on a command line (for 'this needs --zenoh' errors)."""
    flags = []
    for name in ("zenoh_mode", "zenoh_config"):
        if getattr(args, name, None) is not None:
            flags.append("--" + name.replace("_", "-"))
    for name in ("zenoh_connect", "zenoh_listen", "zenoh_scout"):
        if getattr(args, name, None):
            flags.append("--" + name.replace("_", "-"))
    return flags


@dataclass
class ZenohOptions:
    """How to join Zenoh. Empty lists keep the config file's (or Zenoh's default) endpoints."""

    mode: str | None = None
    connect: list[str] = field(default_factory=list)
    listen: list[str] = field(default_factory=list)
    config_file: str | None = None
    overrides: dict[str, Any] = field(default_factory=dict)  # Zenoh config key -> value, applied last
    scout: bool = False  # multicast scouting on (--zenoh-scout)
    default_listen: list[str] = field(default_factory=lambda: list(LOOPBACK_LISTEN))  # when nothing says

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> ZenohOptions:
        return cls(
            getattr(args, "zenoh_mode", None),
            list(getattr(args, "zenoh_connect", None) or []),
            list(getattr(args, "zenoh_listen", None) or []),
            getattr(args, "zenoh_config", None),
            scout=bool(getattr(args, "zenoh_scout", False)),
        )

    def file_settings(self) -> dict[str, Any]:
        """The config file's own settings (JSON5), to tell what it asks for from Zenoh's defaults."""
        if self.config_file is None:
            return {}
        import json5  # only a config file needs it

        try:
            doc = json5.loads(Path(self.config_file).read_text())
        except (OSError, ValueError) as exc:
            raise ZenohSetupError(f"--zenoh-config {self.config_file}: {exc}") from None
        return doc if isinstance(doc, dict) else {}

    def describe(self) -> str:
        """One line for a start-up banner: mode, the endpoints it really listens on, connects to, scouting."""
        parts = [self.mode or "peer"]
        try:
            listen = self.listen or self.listen_endpoints()
        except ZenohSetupError:
            listen = self.listen
        if listen:
            parts.append("listen " + " ".join(listen))
        if self.connect:
            parts.append("connect " + " ".join(self.connect))
        if self.config_file:
            parts.append(f"config {self.config_file}")
        if self.scout:
            parts.append("multicast scouting")
        return "; ".join(parts)

    def listen_endpoints(self, cfg: Any = None) -> list[str]:
        """The endpoints the session will listen on, for its mode (after flags, file and defaults);
        `cfg`: `config()` when the caller has it already."""
        cfg = cfg or self.config()
        listen = json.loads(cfg.get_json("listen/endpoints") or "[]")
        if isinstance(listen, dict):
            mode = json.loads(cfg.get_json("mode") or "null") or "peer"
            listen = listen.get(mode, [])
        return [str(e) for e in listen]

    def config(self):
        """The zenoh.Config these options describe; ZenohSetupError when the file or a value is wrong."""
        import zenoh  # Zenoh's native library loads only when Zenoh is used

        if self.mode is not None and self.mode not in MODES:
            raise ZenohSetupError(f"--zenoh-mode must be one of {', '.join(MODES)}, got '{self.mode}'")
        try:
            if self.config_file is not None:
                if not Path(self.config_file).is_file():
                    raise ZenohSetupError(f"--zenoh-config {self.config_file}: no such file")
                cfg = zenoh.Config.from_file(self.config_file)
            else:
                cfg = zenoh.Config()
        except zenoh.ZError as exc:
            raise ZenohSetupError(f"--zenoh-config {self.config_file}: {clean_error(exc)}") from None
        values: list[tuple[str, str, Any]] = []
        own = self.file_settings()
        if self.scout:
            values.append(("--zenoh-scout", "scouting/multicast/enabled", True))
        elif not _sets(own, "scouting", "multicast", "enabled"):
            values.append(("(default)", "scouting/multicast/enabled", False))
        if not self.listen and not _sets(own, "listen", "endpoints"):
            values.append(("(default)", "listen/endpoints", self.default_listen))
        if self.mode is not None:
            values.append(("--zenoh-mode", "mode", self.mode))
        if self.connect:
            values.append(("--zenoh-connect", "connect/endpoints", self.connect))
        if self.listen:
            values.append(("--zenoh-listen", "listen/endpoints", self.listen))
        values += [(k, k, v) for k, v in self.overrides.items()]
        for flag, path, value in values:
            try:
                cfg.insert_json5(path, json.dumps(value))
            except zenoh.ZError as exc:
                raise ZenohSetupError(f"{flag} {value}: {clean_error(exc)}") from None
        return cfg

    def exposure_warning(self) -> str | None:
        """A warning when this session listens beyond loopback with no access control (None otherwise)."""
        cfg = self.config()
        if self.access_controlled(cfg):
            return None
        exposed = [e for e in self.listen_endpoints(cfg) if not is_loopback_endpoint(e)]
        if not exposed:
            return None
        return (
            f"Zenoh listens on {', '.join(exposed)} with no access control: anyone who can reach it may "
            f"command this robot and publish its frames (see {SECURITY_DOCS})"
        )

    def access_controlled(self, cfg: Any = None) -> bool:
        """Whether the configuration (`cfg`, or `config()`) turns Zenoh's access control on."""
        return json.loads((cfg or self.config()).get_json("access_control/enabled") or "false") is True

    def scouts(self) -> bool:
        """Whether this session looks for peers by multicast (Zenoh's default, unless the config turns it off)."""
        return json.loads(self.config().get_json("scouting/multicast/enabled")) is not False

    def open(self):
        """An open zenoh.Session (close it!); ZenohSetupError when Zenoh refuses, e.g. nothing to connect to."""
        import zenoh  # Zenoh's native library loads only when Zenoh is used

        zenoh.init_log_from_env_or("error")  # Zenoh's own warnings only with RUST_LOG set
        cfg = self.config()
        try:
            return zenoh.open(cfg)
        except zenoh.ZError as exc:
            raise ZenohSetupError(f"cannot join Zenoh ({self.describe()}): {clean_error(exc)}") from None


def _sets(doc: Any, *path: str) -> bool:
    """Whether a config file's own settings (nested dicts) name `path`, e.g. ("listen", "endpoints")."""
    for key in path:
        if not isinstance(doc, dict) or key not in doc:
            return False
        doc = doc[key]
    return True


def is_loopback_endpoint(endpoint: str) -> bool:
    """Whether a Zenoh endpoint is reachable from this machine only (loopback IP, or a local socket)."""
    m = _ENDPOINT.fullmatch(endpoint)
    if m is None:
        return False
    if m["proto"] not in _IP_PROTOCOLS:
        return m["proto"].startswith("unixsock")  # unix sockets are local; anything else: assume not
    host = m["address"].rpartition(":")[0]
    return host in _LOOPBACK_HOSTS or host.startswith("127.")


def settle(session, options: ZenohOptions, seconds: float = 1.0) -> None:
    """With no endpoint to connect to (multicast scouting only), wait up to `seconds` for a first peer or
    router, so that what is asked next (who is alive?) is asked of someone."""
    if options.connect or not options.scouts():
        return  # opening connected already, or there is no one to find
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        info = session.info
        if info.peers_zid() or info.routers_zid():
            return
        time.sleep(0.05)


def clean_error(exc: BaseException) -> str:
    """Zenoh's error text without the Rust source locations it appends."""
    text = re.sub(r"\s+at /\S+:\d+\.?", "", str(exc))
    return text.strip() or type(exc).__name__
