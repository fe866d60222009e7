"""Feetech STS/SCS: the emulator answers packets hand-computed from FEETECH's protocol manual, and the
bus (the vendor SDK, over a real pty) pings, scans, turns torque on and off, writes goals in one SYNC
WRITE, reads positions, loads and faults in one SYNC READ, and reports NaN for a servo that gives no
valid reply, for both series."""

from __future__ import annotations

import math
import os
import select
import time

import numpy as np
import pytest

from backend.hardware.bus import HardwareError
from backend.hardware.config import FeetechBusConfig
from backend.hardware.emulator.feetech import FeetechEmulator
from backend.hardware.feetech import FeetechBus

MODELS = {"sts": "STS3215", "scs": "SCS0009"}
IDS = [1, 2, 3]


def _exchange(path: str, packet: bytes, wait: float = 0.2) -> bytes:
    """Write `packet` to the bus and collect what comes back within `wait` seconds."""
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
    try:
        os.write(fd, packet)
        out, end = b"", time.monotonic() + wait
        while (left := end - time.monotonic()) > 0:
            ready, _, _ = select.select([fd], [], [], left)
            if ready:
                out += os.read(fd, 256)
        return out
    finally:
        os.close(fd)


def _sum(body: bytes) -> int:
    return ~sum(body) & 0xFF


def _bus(emu: FeetechEmulator, ids=IDS, reply_timeout_ms: float = 100.0) -> FeetechBus:
    """A bus on the emulator; a longer reply timeout than the default, as a loaded machine's emulator
    thread may answer late."""
    config = FeetechBusConfig(
        port=emu.path, series=emu.series, joints={f"j{i}": {"id": i, "zero": 0} for i in ids}
    )
    bus = FeetechBus(config, reply_timeout_ms=reply_timeout_ms)
    bus.open()
    return bus


def _wait_for(check, timeout: float = 2.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if value := check():
            return value
        time.sleep(0.01)
    return check()


@pytest.fixture(params=["sts", "scs"])
def emu(request):
    with FeetechEmulator(dict.fromkeys(IDS, MODELS[request.param]), series=request.param) as emulator:
        yield emulator


@pytest.fixture
def bus(emu):
    bus = _bus(emu)
    yield bus
    bus.close()


# -- the emulator against the manual's packets ----------------------------------------------------------


def test_emulator_answers_the_manuals_ping_and_read_examples():
    with FeetechEmulator({1: "STS3215"}) as emu:
        # PING id 1: checksum ~(01 + 02 + 01) = FB; the status has no error: ~(01 + 02 + 00) = FC.
        assert _exchange(emu.path, bytes.fromhex("FF FF 01 02 01 FB")) == bytes.fromhex("FF FF 01 02 00 FC")
        # READ 2 bytes at 0x38 (present position) of id 1 at 1304 ticks = 0x0518, little-endian.
        emu.set_position(1, 1304)
        reply = _exchange(emu.path, bytes.fromhex("FF FF 01 04 02 38 02 BE"))
        assert reply == bytes.fromhex("FF FF 01 04 00 18 05 DD")
        # READ the model number (address 3): STS3215 is 777 = 0x0309.
        body = bytes.fromhex("01 04 02 03 02")
        reply = _exchange(emu.path, b"\xff\xff" + body + bytes([_sum(body)]))
        assert reply[5:7] == bytes.fromhex("09 03")
        assert emu.counters["ping"] == 1 and emu.counters["read"] == 2


def test_emulator_scs_words_are_big_endian():
    with FeetechEmulator({1: "SCS0009"}, series="scs") as emu:
        emu.set_position(1, 0x0123)
        reply = _exchange(emu.path, bytes.fromhex("FF FF 01 04 02 38 02 BE"))
        assert reply == b"\xff\xff\x01\x04\x00\x01\x23" + bytes([_sum(b"\x01\x04\x00\x01\x23")])


def test_emulator_drops_a_bad_checksum_and_obeys_a_sync_write():
    with FeetechEmulator({1: "STS3215", 2: "STS3215"}, speed=1e6) as emu:
        assert _exchange(emu.path, bytes.fromhex("FF FF 01 02 01 FA"), wait=0.1) == b""
        assert emu.bad_packets == 1
        # WRITE torque enable (0x28) = 1 to the broadcast id: every servo obeys, none answers.
        body = bytes.fromhex("FE 04 03 28 01")
        assert _exchange(emu.path, b"\xff\xff" + body + bytes([_sum(body)]), wait=0.1) == b""
        # SYNC WRITE 2 bytes at 0x2A (goal position): id 1 -> 0x0800, id 2 -> 0x0400, little-endian.
        body = bytes.fromhex("FE 0A 83 2A 02 01 00 08 02 00 04")
        assert _exchange(emu.path, b"\xff\xff" + body + bytes([_sum(body)]), wait=0.1) == b""
        assert (emu.state(1).goal, emu.state(2).goal) == (0x0800, 0x0400)
        assert emu.state(2).torque and emu.state(2).position == pytest.approx(0x0400)
        assert emu.counters["sync_write"] == 1


def test_emulator_sync_read_answers_in_turn_and_skips_the_missing():
    with FeetechEmulator({1: "STS3215", 2: "STS3215", 3: "STS3215"}, missing=[2]) as emu:
        body = bytes.fromhex("FE 07 82 38 02 01 02 03")
        reply = _exchange(emu.path, b"\xff\xff" + body + bytes([_sum(body)]))
        one = b"\x01\x04\x00\x00\x08"
        three = b"\x03\x04\x00\x00\x08"
        assert reply == b"\xff\xff" + one + bytes([_sum(one)]) + b"\xff\xff" + three + bytes([_sum(three)])
        # PING the broadcast id: ~(FE + 02 + 01) = FE; every servo present answers, in id order.
        reply = _exchange(emu.path, bytes.fromhex("FF FF FE 02 01 FE"))
        assert reply == bytes.fromhex("FF FF 01 02 00 FC FF FF 03 02 00 FA")


# -- the bus (the vendor SDK) against the emulator, both series ------------------------------------------


def test_ping_names_present_servos_and_none_for_missing(emu, bus):
    emu.missing.add(3)
    found = bus.ping([1, 3, 7])
    assert found[3] is None and found[7] is None
    info = found[1]
    assert info is not None and info.model_name == MODELS[emu.series]
    assert info.position == pytest.approx(emu.state(1).position)
    assert info.raw_max == (4095 if emu.series == "sts" else 1023)
    assert [s.id for s in bus.scan(range(6))] == [1, 2]


def test_unknown_model_and_wrong_series_are_named():
    with FeetechEmulator({4: 999}) as emu:
        bus = _bus(emu, [4])
        with pytest.raises(HardwareError, match=r"id 4 reports model 999"):
            bus.ping([4])
        bus.close()
    with FeetechEmulator({5: "SCS0009"}, series="scs") as emu:
        config = FeetechBusConfig(port=emu.path, series="sts", joints={"j": {"id": 5, "zero": 0}})
        bus = FeetechBus(config, reply_timeout_ms=100.0)
        bus.open()
        with pytest.raises(HardwareError, match=r"id 5 .*SCS0009.*series: scs"):
            bus.ping([5])
        bus.close()


def test_torque_on_and_off(emu, bus):
    bus.torque(IDS, True)
    assert all(emu.state(i).torque for i in IDS)
    bus.torque([2], False)
    assert not emu.state(2).torque and emu.state(1).torque
    emu.missing.add(3)
    with pytest.raises(HardwareError, match=r"id 3: no answer"):
        bus.torque(IDS, False)
    assert not emu.state(1).torque


def test_write_goals_is_one_sync_write_and_read_state_follows(emu, bus):
    start = bus.read_state(IDS).position
    bus.torque(IDS, True)
    goals = np.array([300.0, 400.5, 500.0])
    emu.reset_counters()
    bus.write_goals(IDS, goals)
    assert _wait_for(lambda: emu.counters["sync_write"] == 1)  # no reply to wait for: it is a broadcast
    assert emu.counters == {"sync_write": 1}
    assert [emu.state(i).goal for i in IDS] == [300, 400, 500]  # rounded half to even

    def arrived():
        reading = bus.read_state(IDS)
        return reading if np.allclose(reading.position, [300, 400, 500]) else None

    reading = _wait_for(arrived)
    assert reading is not None, f"the servos did not reach their goals from {start}"
    assert reading.faults == {} and np.all(reading.effort == 0)
    assert emu.counters["sync_read"] >= 1 and emu.counters["read"] == 0
    bus.write_goals(IDS, np.array([1.0e6, -5.0, 10.0]))  # beyond the range: clipped, never wrapped
    clipped = [4095 if emu.series == "sts" else 1023, 0, 10]
    assert _wait_for(lambda: [emu.state(i).goal for i in IDS] == clipped)
    with pytest.raises(ValueError, match="servo id 2"):
        bus.write_goals(IDS, np.array([1.0, math.nan, 2.0]))


def test_effort_is_the_signed_load(emu, bus):
    emu.set_load(1, 0.25)
    emu.set_load(2, -0.5)
    effort = bus.read_state(IDS).effort
    assert effort.tolist() == [0.25, -0.5, 0.0]


def test_sts_negative_position_is_sign_magnitude():
    with FeetechEmulator({1: "STS3215"}) as emu:
        bus = _bus(emu, [1])
        emu.set_position(1, -100)
        assert bus.read_state([1]).position.tolist() == [-100.0]
        info = bus.ping([1])[1]
        assert info is not None and info.position == -100.0
        bus.close()


def test_bad_checksum_gives_nan_for_that_read_only(emu, bus):
    emu.corrupt_replies(2, 1)
    first = bus.read_state(IDS).position
    assert math.isnan(first[1]) and not np.isnan(first[[0, 2]]).any()
    assert not np.isnan(bus.read_state(IDS).position).any()


def test_silence_and_missing_give_nan_without_a_long_stall(emu, bus):
    emu.silence(1, 0.5)
    t0 = time.perf_counter()
    reading = bus.read_state(IDS)
    took = time.perf_counter() - t0
    assert math.isnan(reading.position[0]) and not np.isnan(reading.position[1:]).any()
    assert took < 0.4, f"a silent servo stalled the read {took * 1000:.0f} ms (reply timeout: 100 ms)"
    emu.missing.update(IDS)
    assert np.isnan(bus.read_state(IDS).position).all()  # the SDK's last replies are not reused
    emu.missing.clear()
    assert _wait_for(lambda: not np.isnan(bus.read_state(IDS).position).any(), timeout=1.0)


def test_overload_is_a_fault_and_turns_torque_off(emu, bus):
    bus.torque(IDS, True)
    emu.set_fault(2, "overload")
    emu.set_fault(3, "voltage")
    reading = bus.read_state(IDS)
    assert reading.faults == {2: "overload", 3: "voltage"}
    assert not np.isnan(reading.position).any()
    assert not emu.state(2).torque and emu.state(3).torque
    with pytest.raises(HardwareError, match=r"id 2: overload"):
        bus.torque(IDS, True)
    emu.set_fault(2, None)
    bus.torque(IDS, True)
    assert emu.state(2).torque and bus.read_state(IDS).faults == {3: "voltage"}


def test_open_errors_are_one_line():
    bad = FeetechBusConfig(port="/dev/does-not-exist", joints={"j": {"id": 1, "zero": 0}})
    with pytest.raises(HardwareError, match="/dev/does-not-exist: cannot open"):
        FeetechBus(bad).open()
    odd = FeetechBusConfig(port="/dev/null", baudrate=123, joints={"j": {"id": 1, "zero": 0}})
    with pytest.raises(HardwareError, match="baudrate 123"):
        FeetechBus(odd).open()
    with pytest.raises(HardwareError, match="not open"):
        FeetechBus(bad).read_state([1])


def test_one_tick_of_six_servos_is_quick():
    """Timing is reported, not required: a SYNC WRITE and a SYNC READ of six servos at 1 Mbaud."""
    ids = list(range(1, 7))
    with FeetechEmulator(dict.fromkeys(ids, "STS3215")) as emu:
        bus = _bus(emu, ids)
        bus.torque(ids, True)
        times = []
        for k in range(100):
            t0 = time.perf_counter()
            bus.write_goals(ids, np.full(6, 2048.0 + k))
            reading = bus.read_state(ids)
            times.append(time.perf_counter() - t0)
        assert not np.isnan(reading.position).any()
        assert emu.counters["sync_write"] == 100 and emu.counters["sync_read"] == 100
        print(
            f"\nwrite+read of 6 servos: median {np.median(times) * 1e3:.2f} ms, max {max(times) * 1e3:.2f} ms"
        )
        bus.close()
