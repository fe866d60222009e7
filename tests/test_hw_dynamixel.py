"""Dynamixel Protocol 2.0: the emulator checked against the e-Manual's own example packets, then the real
dynamixel-sdk (through DynamixelBus) driving the emulator over a real pty, with injected faults."""

from __future__ import annotations

import os
import random
import select
import sys
import time

import numpy as np
import pytest

from backend.hardware.bus import HardwareError
from backend.hardware.config import DynamixelBusConfig
from backend.hardware.dynamixel import DynamixelBus
from backend.hardware.emulator.dynamixel import (
    HARDWARE_ERROR,
    MAX_POSITION,
    MIN_POSITION,
    DynamixelEmulator,
    crc16,
    packet,
    stuff,
    unstuff,
)

# The e-Manual's Protocol 2.0 examples (instruction packet, then the status packet of ID 1).
DOC_PING = "FF FF FD 00 01 03 00 01 19 4E"
DOC_PING_STATUS = "FF FF FD 00 01 07 00 55 00 06 04 26 65 5D"  # model 1030 (0x0406), firmware 0x26
DOC_READ = "FF FF FD 00 01 07 00 02 84 00 04 00 1D 15"  # Present Position (132), 4 bytes
DOC_READ_STATUS = "FF FF FD 00 01 08 00 55 00 A6 00 00 00 8C C0"  # position 166
DOC_WRITE = "FF FF FD 00 01 09 00 03 74 00 00 02 00 00 CA 89"  # Goal Position (116) = 512
DOC_WRITE_STATUS = "FF FF FD 00 01 04 00 55 00 A1 0C"
DOC_SYNC_WRITE = "FF FF FD 00 FE 11 00 83 74 00 04 00 01 96 00 00 00 02 AA 00 00 00 82 87"  # 150, 170
DOC_SYNC_READ = "FF FF FD 00 FE 09 00 82 84 00 04 00 01 02 CE FA"  # Present Position of IDs 1, 2
DOC_REBOOT = "FF FF FD 00 01 03 00 08 2F 4E"


def hx(text: str) -> bytes:
    return bytes.fromhex(text)


# -- the protocol, by hand --------------------------------------------------------------------------
def test_crc_matches_the_documents_examples_and_the_crc16_check_value():
    assert crc16(b"123456789") == 0xFEE8  # CRC-16 with polynomial 0x8005, init 0, not reflected
    for text in (
        DOC_PING,
        DOC_PING_STATUS,
        DOC_READ,
        DOC_READ_STATUS,
        DOC_WRITE,
        DOC_SYNC_WRITE,
        DOC_SYNC_READ,
    ):
        raw = hx(text)
        assert crc16(raw[:-2]) == int.from_bytes(raw[-2:], "little"), text


def test_packets_are_built_byte_for_byte_as_in_the_document():
    assert packet(1, 0x01) == hx(DOC_PING)
    assert packet(1, 0x55, bytes([0x00, 0x06, 0x04, 0x26])) == hx(DOC_PING_STATUS)
    assert packet(1, 0x02, hx("84 00 04 00")) == hx(DOC_READ)
    assert packet(1, 0x03, hx("74 00 00 02 00 00")) == hx(DOC_WRITE)
    assert packet(0xFE, 0x83, hx("74 00 04 00 01 96 00 00 00 02 AA 00 00 00")) == hx(DOC_SYNC_WRITE)
    assert packet(1, 0x08) == hx(DOC_REBOOT)


def test_byte_stuffing_adds_fd_after_the_header_pattern_and_the_length_counts_it():
    assert stuff(hx("03 FF FF FD 01")) == hx("03 FF FF FD FD 01")
    assert stuff(hx("FF FF FD FD")) == hx("FF FF FD FD FD")
    raw = packet(1, 0x03, hx("4C 00 FF FF FD"))  # WRITE of FF FF FD at address 76
    assert raw[7:-2] == hx("03 4C 00 FF FF FD FD")
    assert int.from_bytes(raw[5:7], "little") == 7 + 2
    rng = random.Random(34)
    for _ in range(500):  # bodies dense in FF and FD round-trip
        body = bytes(rng.choice((0xFF, 0xFD, 0x00, 0x55)) for _ in range(rng.randint(0, 24)))
        assert unstuff(stuff(body)) == body


def _exchange(emu: DynamixelEmulator, fd: int, data: bytes, expect: int) -> bytes:
    """Write `data` to the pty as a driver would; read up to `expect` bytes of reply (0.5 s at most)."""
    os.write(fd, data)
    out, end = b"", time.monotonic() + 0.5
    while len(out) < expect and time.monotonic() < end:
        if select.select([fd], [], [], 0.05)[0]:
            out += os.read(fd, 4096)
    return out


@pytest.fixture
def raw_emulator():
    """An emulator with the document's example servo (ID 1, model 1030, firmware 0x26), read raw."""
    with DynamixelEmulator({1: 1030, 2: 1060}, firmware=0x26) as emu:
        fd = os.open(emu.path, os.O_RDWR | os.O_NOCTTY)
        try:
            yield emu, fd
        finally:
            os.close(fd)


def test_emulator_answers_the_documents_packets(raw_emulator):
    emu, fd = raw_emulator
    assert _exchange(emu, fd, hx(DOC_PING), 14) == hx(DOC_PING_STATUS)
    emu.set_position(1, 166)
    assert _exchange(emu, fd, hx(DOC_READ), 15) == hx(DOC_READ_STATUS)
    assert _exchange(emu, fd, hx(DOC_WRITE), 11) == hx(DOC_WRITE_STATUS)
    assert emu.goal(1) == 512 and emu.position(1) == 166  # torque off: accepted, nothing moves
    assert _exchange(emu, fd, hx(DOC_SYNC_WRITE), 1) == b""  # no status packet
    assert (emu.goal(1), emu.goal(2)) == (150, 170)
    emu.set_position(2, 0x01FD)
    replies = _exchange(emu, fd, hx(DOC_SYNC_READ), 30)
    assert replies == packet(1, 0x55, hx("00 A6 00 00 00")) + packet(2, 0x55, hx("00 FD 01 00 00"))
    assert emu.counts == {"ping": 1, "read": 1, "write": 1, "sync_write": 1, "sync_read": 1}


def test_emulator_stuffs_and_unstuffs_and_rejects_a_bad_crc(raw_emulator):
    emu, fd = raw_emulator
    write = packet(1, 0x03, hx("4C 00 FF FF FD"))  # velocity I gain + P gain low byte
    assert _exchange(emu, fd, write, 11) == packet(1, 0x55, b"\x00")
    assert emu.read_table(1, 76, 3) == hx("FF FF FD")
    reply = _exchange(emu, fd, packet(1, 0x02, hx("4C 00 03 00")), 15)
    assert reply == hx("FF FF FD 00 01 08 00 55 00 FF FF FD FD") + reply[-2:]
    assert crc16(reply[:-2]) == int.from_bytes(reply[-2:], "little")
    bad = bytearray(hx(DOC_PING))
    bad[-1] ^= 0x01
    assert _exchange(emu, fd, bytes(bad), 11) == packet(1, 0x55, b"\x03")  # result fault: CRC error
    assert emu.bad_packets == 1


def test_broadcast_ping_each_servo_answers_and_reboot_clears_a_hardware_error(raw_emulator):
    emu, fd = raw_emulator
    replies = _exchange(emu, fd, packet(0xFE, 0x01), 28)
    assert replies == packet(1, 0x55, hx("00 06 04 26")) + packet(2, 0x55, hx("00 24 04 26"))
    emu.set_fault(2, "voltage")  # not in the default Shutdown set: Alert, torque unaffected
    assert _exchange(emu, fd, packet(2, 0x01), 14)[8] == 0x80
    assert _exchange(emu, fd, packet(2, 0x08), 11) == packet(2, 0x55, b"\x80")
    assert emu.hardware_error(2) == 0
    assert _exchange(emu, fd, packet(2, 0x01), 14)[8] == 0x00


# -- the bus (the real SDK) against the emulator -----------------------------------------------------
SERVOS = {1: "XM430-W350", 2: "XL430-W250", 3: "XL430-W250"}


def make_bus(emu: DynamixelEmulator, **kwargs) -> DynamixelBus:
    joints = {"head_yaw": {"id": 1, "zero": 2048}, "head_pitch": {"id": 2, "zero": 2048}}
    bus = DynamixelBus(DynamixelBusConfig.model_validate({"port": emu.path, "joints": joints}), **kwargs)
    bus.open()
    return bus


def wait_for(condition, seconds: float = 1.0) -> None:
    """Wait until the emulator's thread has handled what was sent (`condition()` holds)."""
    end = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > end:
            raise AssertionError("the emulator did not get there in time")
        time.sleep(0.002)


@pytest.fixture
def rig():
    # latency 20 ms (a reply timeout of ~42 ms): room for a loaded test machine's scheduling; the
    # timing test below uses the default
    with DynamixelEmulator(SERVOS) as emu:
        bus = make_bus(emu, latency_ms=20.0)
        try:
            yield emu, bus
        finally:
            bus.close()


def test_ping_present_and_missing_ids(rig):
    emu, bus = rig
    emu.set_position(2, 1000)
    emu.write_table(3, MIN_POSITION, (500).to_bytes(4, "little"))
    emu.write_table(3, MAX_POSITION, (3500).to_bytes(4, "little"))
    infos = bus.ping([1, 2, 3, 7])
    assert infos[7] is None
    assert (infos[1].model, infos[1].model_name) == (1020, "XM430-W350")
    assert (infos[2].model_name, infos[2].position, infos[2].ticks_per_turn) == ("XL430-W250", 1000.0, 4096)
    assert (infos[3].raw_min, infos[3].raw_max) == (500.0, 3500.0)


def test_scan_finds_every_servo_but_the_missing_one():
    with DynamixelEmulator({**SERVOS, 40: 1060}, missing=[3]) as emu:
        bus = make_bus(emu, latency_ms=20.0)
        started = time.perf_counter()
        found = bus.scan()
        took = time.perf_counter() - started
        bus.close()
    assert [info.id for info in found] == [1, 2, 40]
    print(f"scan of ids 0..252 (broadcast ping + 3 pings): {took * 1e3:.0f} ms")


def test_unknown_model_is_a_hardware_error_naming_id_and_model():
    with DynamixelEmulator({5: 9999}) as emu:
        bus = make_bus(emu, latency_ms=20.0)
        with pytest.raises(HardwareError, match=r"servo 5 reports model number 9999"):
            bus.ping([5])
        bus.close()


def test_torque_on_and_off(rig):
    emu, bus = rig
    bus.torque([1, 2], True)
    assert emu.torque(1) and emu.torque(2) and not emu.torque(3)
    bus.torque([1, 2], False)
    assert not emu.torque(1) and not emu.torque(2)
    emu.missing.add(2)
    with pytest.raises(HardwareError, match=r"servo 2 \(head_pitch\): torque on failed: no answer"):
        bus.torque([2], True)


def test_one_sync_write_per_call_and_positions_follow_goals(rig):
    emu, bus = rig
    ids = [1, 2, 3]
    bus.ping(ids)
    bus.write_goals(ids, np.array([1000.0, 3000.0, 2500.0]))
    wait_for(lambda: emu.counts["sync_write"] == 1)  # a SYNC WRITE has no reply to wait for
    assert emu.counts["write"] == 0
    time.sleep(0.05)
    assert [emu.position(i) for i in ids] == [2048, 2048, 2048]  # torque off: nothing moves
    bus.torque(ids, True)
    for k in range(10):
        bus.write_goals(ids, np.array([1000.0, 3000.0, 2500.4 + k * 0.01]))
    wait_for(lambda: emu.counts["sync_write"] == 11)
    time.sleep(0.25)  # 1048 ticks at 8192 ticks/s: 0.13 s
    reading = bus.read_state(ids)
    assert emu.counts["sync_read"] == 1
    np.testing.assert_array_equal(reading.position, [1000.0, 3000.0, 2500.0])
    assert reading.faults == {}
    bus.write_goals(ids, np.array([-50.0, 9000.0, 2048.0]))  # beyond the position limits: clipped
    wait_for(lambda: (emu.goal(1), emu.goal(2)) == (0, 4095))


def test_write_goals_rejects_bad_input(rig):
    _, bus = rig
    with pytest.raises(ValueError, match=r"raw\[1\] \(servo id 2\) is nan"):
        bus.write_goals([1, 2], np.array([1.0, np.nan]))
    with pytest.raises(ValueError, match="shape"):
        bus.write_goals([1, 2], np.array([1.0]))


def test_effort_is_the_load_as_a_fraction(rig):
    emu, bus = rig
    bus.ping([1, 2])
    emu.set_load(1, -0.25)  # XM430: Present Current over Current Limit
    emu.set_load(2, 0.5)  # XL430: Present Load in 0.1 %
    assert emu.state(2)["load"] == 500
    np.testing.assert_allclose(bus.read_state([1, 2]).effort, [-0.25, 0.5], atol=1e-3)


def test_a_bad_crc_loses_that_servos_reading_for_that_read_only(rig):
    emu, bus = rig
    emu.corrupt_replies(2, 1)
    first = bus.read_state([1, 2, 3])
    assert np.isnan(first.position[1]) and not np.isnan(first.position[[0, 2]]).any()
    assert np.isnan(first.effort[1])
    assert not np.isnan(bus.read_state([1, 2, 3]).position).any()


def test_silence_and_missing_give_nan_without_stalling(rig):
    emu, bus = rig
    emu.silence(2, 0.3)
    started = time.perf_counter()
    reading = bus.read_state([1, 2, 3])
    took = time.perf_counter() - started
    assert np.isnan(reading.position[1]) and not np.isnan(reading.position[[0, 2]]).any()
    assert took < 0.2, took
    time.sleep(0.3)
    assert not np.isnan(bus.read_state([1, 2, 3]).position).any()
    emu.missing.add(3)
    assert np.isnan(bus.read_state([1, 2, 3]).position).tolist() == [False, False, True]


def test_overload_is_a_fault_turns_torque_off_and_lasts_until_reboot(rig):
    emu, bus = rig
    bus.ping([1, 2])
    bus.torque([1, 2], True)
    emu.set_fault(1, "overload")
    assert not emu.torque(1) and emu.torque(2)
    reading = bus.read_state([1, 2])
    assert reading.faults == {1: "overload"}
    assert not np.isnan(reading.position).any()
    reads = emu.counts["read"]
    assert bus.read_state([1, 2]).faults == {1: "overload"}
    assert emu.counts["read"] == reads  # the fault word is cached while the Alert stays
    with pytest.raises(HardwareError, match=r"servo 1 \(head_yaw\) reports overload"):
        bus.torque([1], True)
    import dynamixel_sdk  # lazy: only this test reboots a servo, which the bus does not offer

    port = bus._port  # the bus's own open port: the bus has no reboot of its own
    assert dynamixel_sdk.PacketHandler(2.0).reboot(port, 1)[0] == dynamixel_sdk.COMM_SUCCESS
    assert emu.read_table(1, HARDWARE_ERROR, 1) == b"\x00"
    assert bus.read_state([1, 2]).faults == {}
    bus.torque([1], True)


def test_opening_without_the_sdk_or_the_port_says_why(monkeypatch, tmp_path):
    config = DynamixelBusConfig.model_validate(
        {"port": str(tmp_path / "ttyUSB9"), "joints": {"a": {"id": 1, "zero": 0}}}
    )
    with pytest.raises(HardwareError, match="cannot open the port"):
        DynamixelBus(config).open()
    monkeypatch.setitem(sys.modules, "dynamixel_sdk", None)
    with pytest.raises(HardwareError, match=r"pip install 'nutty\[dynamixel\]'"):
        DynamixelBus(config).open()


def test_timing_of_a_tick_and_of_a_missing_servo():
    """Not pass/fail on speed: prints what one SYNC WRITE + SYNC READ costs on the pty at 1 Mbaud."""
    ids = list(range(1, 13))
    with DynamixelEmulator(dict.fromkeys(ids, 1060)) as emu:
        bus = make_bus(emu)  # the default latency allowance, as `nutty serve` would use on a pty
        bus.ping(ids)
        bus.torque(ids, True)
        ticks, nans = [], 0
        for k in range(200):
            started = time.perf_counter()
            bus.write_goals(ids, np.full(len(ids), 2000.0 + k))
            nans += int(np.isnan(bus.read_state(ids).position).sum())
            ticks.append(time.perf_counter() - started)
        emu.missing.add(12)
        started = time.perf_counter()
        assert np.isnan(bus.read_state(ids).position[-1])
        missing = time.perf_counter() - started
        bus.close()
    ms = np.array(ticks) * 1e3
    print(
        f"12 servos, sync write + sync read: median {np.median(ms):.2f} ms, p99 {np.percentile(ms, 99):.2f} ms, "
        f"{nans} lost readings in 200; read with the last servo missing: {missing * 1e3:.1f} ms"
    )
    assert emu.counts["sync_write"] == 200
    assert missing < 0.1
