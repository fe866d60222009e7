"""Drivers declare their own command-line option: a new driver is one class and its entry point
(tests/test_plugins.py installs one from another package; here classes are registered directly)."""

from __future__ import annotations

import argparse

import pytest

from backend.drivers import (
    DRIVER_OPTIONS,
    DriverOption,
    FrameRecorder,
    OscDriver,
    SimulatedServos,
    add_driver_options,
    build_drivers,
    register_driver,
)
from backend.engine.runtime import Sink
from backend.session import EngineSession


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(exit_on_error=False)
    add_driver_options(p)
    return p


def test_bundled_drivers_are_on_the_command_line(desk, tmp_path):
    args = parser().parse_args(["--osc", "127.0.0.1:9123", "--record", str(tmp_path / "r.jsonl")])
    sinks = build_drivers(desk, args)
    try:
        kinds = sorted(type(s).__name__ for s in sinks)
        assert kinds == ["FrameRecorder", "OscDriver", "SimulatedServos"]  # sim-servo is on by default
        servo = next(s for s in sinks if isinstance(s, SimulatedServos))
        assert servo.gain == pytest.approx(2 * 3.141592653589793 * 8.0)
    finally:
        for s in sinks:
            s.close()


def test_zero_hz_turns_the_simulated_servos_off(desk):
    assert build_drivers(desk, parser().parse_args(["--sim-servo", "0"])) == []


@pytest.mark.parametrize(
    "flag, value, message",
    [
        ("--osc", "9000", "HOST:PORT"),
        ("--osc", "host:70000", "1..65535"),
        ("--sim-servo", "fast", "number of Hz"),
        ("--sim-servo", "-1", ">= 0"),
    ],
)
def test_bad_values_are_refused_with_the_reason(flag, value, message):
    with pytest.raises(argparse.ArgumentError, match=message):
        parser().parse_args([flag, value])


def test_a_new_driver_is_one_declaration(desk):
    received = []

    class Probe(Sink):
        option = DriverOption("test-probe", metavar="N", parse=int, help="keep every N-th frame")

        def __init__(self, every: int):
            super().__init__("probe", max_queue=64, decimate=every)

        @classmethod
        def from_option(cls, embodiment, every):
            return cls(every)

        def consume(self, frame):
            received.append(frame.t)

    register_driver(Probe)
    try:
        assert "--test-probe" in parser().format_help()
        sinks = build_drivers(desk, parser().parse_args(["--test-probe", "5", "--sim-servo", "0"]))
        assert [type(s) for s in sinks] == [Probe]
        session = EngineSession.create(desk, rate=50)
        session.engine.add_sink(sinks[0])
        list(session.run_headless(50))
        session.engine.close()
        assert len(received) == 10  # every 5th of 50 frames, delivered on the sink's own thread
    finally:
        DRIVER_OPTIONS.pop("test-probe", None)


def test_declaring_the_same_option_twice_is_an_error():
    with pytest.raises(ValueError, match="--osc is declared twice"):
        register_driver(OscDriver)
    assert DRIVER_OPTIONS["osc"].build == OscDriver.from_option
    assert DRIVER_OPTIONS["record"].build == FrameRecorder.from_option
