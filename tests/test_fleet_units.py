"""The fleet's small parts without a network: robot ids and patterns, what travels on the wire, and the
command-line checks of `nutty serve --zenoh`, `nutty bridge` and `nutty fleet`."""

from __future__ import annotations

import argparse

import msgpack
import numpy as np
import pytest

from backend.cli import build_parser, main
from backend.commands.bridge import chosen_drivers
from backend.session import EngineSession
from backend.zenoh_link import keys
from backend.zenoh_link.codec import FrameDoc, decode_frame, encode_frame, read_stamp, stamp
from backend.zenoh_link.session import ZenohOptions, ZenohSetupError, endpoint_arg


@pytest.mark.parametrize("good", ["museum-1", "nutty_desk-lab.pc", "7", "a" * 64])
def test_robot_ids(good):
    assert keys.check_robot_id(good) == good


@pytest.mark.parametrize(
    "bad, why",
    [
        ("", "empty"),
        ("a/b", "'/'"),
        ("museum-*", "'*'"),
        ("$x", "'\\$'"),
        ("-x", "start"),
        ("a" * 65, "longer"),
        ("é", "'é'"),
        ("a b", "' '"),
    ],
)
def test_bad_robot_ids_say_what_is_wrong(bad, why):
    with pytest.raises(keys.RobotIdError, match=why):
        keys.check_robot_id(bad)


def test_patterns_become_zenoh_key_expressions():
    assert keys.key("museum-*", keys.COMMANDS) == "nutty/museum-$*/commands"
    assert keys.key("*", keys.ALIVE) == "nutty/*/alive"
    assert keys.key("**", keys.ALIVE) == "nutty/*/alive"  # one chunk: an id never holds '/'
    assert keys.key("a*b*", keys.FRAMES) == "nutty/a$*b$*/frames"
    assert keys.matches("museum-*", "museum-12") and not keys.matches("museum-*", "lab-1")
    for bad in ("museum/*", "x?", "$*", ""):
        with pytest.raises(keys.RobotIdError):
            keys.check_pattern(bad)
    assert keys.robot_of("nutty/museum-1/frames") == "museum-1" and keys.robot_of("other/x/y") is None
    assert keys.is_command_key("nutty/museum-$*/commands") and keys.is_command_key("nutty/*/commands")
    assert not keys.is_command_key("nutty/**") and not keys.is_command_key("nutty/**/commands")


def test_default_robot_id_is_the_robot_and_the_host():
    assert keys.default_robot_id("nutty_desk", "lab-pc") == "nutty_desk-lab-pc"
    assert keys.default_robot_id("nutty desk", "Lab PC (2)") == "nutty-desk-Lab-PC-2"
    assert len(keys.default_robot_id("r" * 50, "h" * 50)) == keys.MAX_ID


def test_endpoints_are_checked_before_zenoh_sees_them():
    assert endpoint_arg("tcp/127.0.0.1:7447") == "tcp/127.0.0.1:7447"
    assert endpoint_arg("tls/[::1]:7447") == "tls/[::1]:7447"
    for bad in ("127.0.0.1:7447", "tcp/127.0.0.1", "tcp/host:99999", "tcp/"):
        with pytest.raises(argparse.ArgumentTypeError):
            endpoint_arg(bad)
    with pytest.raises(ZenohSetupError, match="--zenoh-config .*no such file"):
        ZenohOptions(config_file="/nonexistent/zenoh.json5").config()


def test_a_frame_survives_the_wire(desk):
    session = EngineSession.create(desk, rate=100)
    session.execute({"type": "set_led", "colour": [1.0, 0.25, 0.0]})
    session.execute({"type": "set_face", "expression": "grin"})
    session.execute({"type": "say", "text": "hello"})
    frame = session.engine.run_ticks(3)[-1]
    payload = encode_frame(frame, desk)
    assert msgpack.unpackb(payload) == frame.to_dict(desk)  # the /ws/frames?format=msgpack content
    back = FrameDoc.parse(decode_frame(payload), desk, desk.rest)
    assert back.seq == frame.seq and back.dt == frame.dt
    assert np.array_equal(back.position, frame.position)
    assert read_stamp(stamp(1234.5)) == 1234.5 and read_stamp(b"xx") is None
    for bad in (b"\xc1", msgpack.packb([1, 2]), msgpack.packb({"dofs": 3})):
        with pytest.raises(ValueError):
            decode_frame(bad)


def run_cli(capsys, *argv) -> tuple[int, str]:
    try:
        code = main(list(argv))
    except SystemExit as exc:  # argparse
        code = exc.code
    return code, capsys.readouterr().err


def test_serve_refuses_zenoh_options_without_zenoh(capsys):
    code, err = run_cli(
        capsys, "serve", "--no-previz", "--robot-id", "museum-1", "--zenoh-listen", "tcp/127.0.0.1:0"
    )
    assert code == 2 and "--zenoh-listen, --robot-id only apply with --zenoh" in err
    code, err = run_cli(capsys, "serve", "--zenoh", "--robot-id", "museum/1")
    assert code == 2 and "may only hold letters" in err


def bridge_args(*argv):
    return build_parser().parse_args(
        ["bridge", "--zenoh", "--robot-id", "r1", "--robot", "nutty_desk", *argv]
    )


def test_the_bridge_takes_its_drivers_from_the_registry():
    assert chosen_drivers(bridge_args("--driver", "osc", "--osc", "127.0.0.1:9000")) == [
        ("osc", ("127.0.0.1", 9000))
    ]
    assert chosen_drivers(bridge_args("--driver", "sim-servo")) == [
        ("sim-servo", 8.0)
    ]  # the driver's default
    with pytest.raises(ValueError, match="--driver record needs --record FILE.jsonl"):
        chosen_drivers(bridge_args("--driver", "record"))
    with pytest.raises(ValueError, match="--osc is given but not --driver osc"):
        chosen_drivers(bridge_args("--driver", "sim-servo", "--osc", "127.0.0.1:9000"))
    with pytest.raises(ValueError, match="turns the sim-servo driver off"):
        chosen_drivers(bridge_args("--driver", "sim-servo", "--sim-servo", "0"))


def test_bridge_and_fleet_command_lines_refuse_bad_input(capsys):
    code, err = run_cli(capsys, "bridge", "--robot-id", "r1", "--driver", "sim-servo")
    assert code == 2 and "--zenoh" in err
    code, err = run_cli(
        capsys, "bridge", "--zenoh", "--robot-id", "r1", "--driver", "teleport", "--robot", "nutty_desk"
    )
    assert code == 2 and "invalid choice: 'teleport'" in err
    code, err = run_cli(capsys, "bridge", "--zenoh", "--robot-id", "r1", "--driver", "sim-servo")
    assert (
        code == 2 and "the following arguments are required: --robot" in err
    )  # limits come from local files only
    code, err = run_cli(
        capsys,
        "bridge",
        "--zenoh",
        "--robot-id",
        "r1",
        "--driver",
        "sim-servo",
        "--robot",
        "nutty_desk",
        "--timeout",
        "0",
    )
    assert code == 2 and "--timeout must be within" in err
    code, err = run_cli(capsys, "fleet", "send", "museum/*", "{}")
    assert code == 2 and "neither a robot id nor a pattern" in err
    code, err = run_cli(capsys, "fleet", "send", "museum-*", "[1]")
    assert code == 2 and "COMMAND-JSON must be a JSON object" in err
    code, err = run_cli(capsys, "fleet", "list", "--zenoh-connect", "tcp/127.0.0.1:notaport")
    assert code == 2 and "expected tcp/HOST:PORT" in err
