"""PCA9685 PWM boards: the register emulator against NXP's data sheet, the bus (through Adafruit's
driver) on the emulator, and the smbus2 I2C adaptor against a stand-in SMBus."""

from __future__ import annotations

import ctypes
import errno
import time

import numpy as np
import pytest

from backend.hardware.bus import HardwareError
from backend.hardware.config import Pca9685BusConfig
from backend.hardware.emulator.pca9685 import Pca9685Emulator
from backend.hardware.pca9685 import Pca9685Bus
from backend.hardware.smbus_i2c import SMBusI2C

ADDR = 0x40


def _write(emu: Pca9685Emulator, reg: int, *data: int) -> None:
    emu.writeto(ADDR, bytes([reg, *data]))


def _read(emu: Pca9685Emulator, reg: int, n: int) -> list[int]:
    buf = bytearray(n)
    emu.writeto_then_readfrom(ADDR, bytes([reg]), buf)
    return list(buf)


def _config(**kw) -> Pca9685BusConfig:
    joints = {f"j{c}": {"channel": c, "pulse_us": {0.0: 1000, 1.0: 2000}} for c in range(16)}
    return Pca9685BusConfig(joints=joints, **kw)  # type: ignore[arg-type]  # pydantic coerces the dicts


@pytest.fixture
def emu() -> Pca9685Emulator:
    return Pca9685Emulator(ADDR)


@pytest.fixture
def bus(emu: Pca9685Emulator):
    b = Pca9685Bus(_config(), i2c=emu)
    b.open()
    yield b
    b.close()


# -- the emulator against the data sheet ----------------------------------------------------------------
def test_power_on_state(emu):
    assert emu.register(0x00) == 0x11 and emu.register(0x01) == 0x04  # asleep, ALLCALL; totem pole
    assert emu.prescale == 0x1E and emu.frequency == pytest.approx(25e6 / 4096 / 31)  # ~200 Hz
    assert all(emu.channel_counts(c)[3] for c in range(16))  # every output full off
    assert emu.pulse_us(0) == 0.0
    assert emu.scan() == [0x40, 0x70]  # its own address and the LED All Call address


def test_prescale_for_50hz_is_121_and_writable_only_asleep(emu):
    _write(emu, 0xFE, 121)  # asleep at power-on: accepted
    assert emu.prescale == 121 and emu.frequency == pytest.approx(50.03, abs=0.01)
    _write(emu, 0x00, 0x00)  # wake
    _write(emu, 0xFE, 50)
    assert emu.prescale == 121 and emu.counts["prescale_blocked"] == 1
    _write(emu, 0x00, 0x10)
    _write(emu, 0xFE, 1)
    assert emu.prescale == 3  # the hardware's minimum


def test_auto_increment_on_writes_and_reads(emu):
    _write(emu, 0x00, 0x00)  # AI off: every data byte lands on the same register
    _write(emu, 0x06, 1, 2, 3, 4)
    assert _read(emu, 0x06, 4) == [4, 4, 4, 4]  # and reads stay there too
    _write(emu, 0x00, 0x20)  # AI on
    _write(emu, 0x06, 0x11, 0x02, 0x33, 0x14)
    assert _read(emu, 0x06, 4) == [0x11, 0x02, 0x33, 0x14]
    _write(emu, 0x44, 0xAA, 0xFF, 0x20)  # LED15_OFF_H rolls over to MODE1; reserved bits 7:5 read 0
    assert emu.register(0x44) == 0xAA and emu.register(0x45) == 0x1F and emu.register(0x00) == 0x20
    assert _read(emu, 0x45, 3) == [0x1F, 0x20, 0x04]  # 0x45, then MODE1, MODE2


def test_all_led_registers_load_every_channel_and_read_zero(emu):
    _write(emu, 0x00, 0x20)
    _write(emu, 0xFA, 0, 0, 0x34, 0x01)  # ALL_LED_ON_L..ALL_LED_OFF_H, then 0xFE is next
    assert all(emu.channel_counts(c) == (0, 0x134, False, False) for c in range(16))
    assert _read(emu, 0xFA, 4) == [0, 0, 0, 0]
    _write(emu, 0xFE)  # the pointer after PRE_SCALE rolls over to MODE1
    assert _read(emu, 0xFE, 2) == [0x1E, 0x20]


def test_pulse_width_from_counts_and_prescale(emu):
    _write(emu, 0xFE, 121)
    _write(emu, 0x00, 0x20)
    _write(emu, 0x06 + 4 * 5, 0, 0, 307 & 0xFF, 307 >> 8)
    assert emu.pulse_us(5) == pytest.approx(307 * 122 / 25.0)  # 1498.2 µs: counts * (PRE_SCALE+1) / 25 MHz
    _write(emu, 0x06 + 4 * 5, 4000 & 0xFF, 4000 >> 8, 100, 0)  # a pulse across the period's end
    assert emu.high_ticks(5) == 196
    _write(emu, 0x06 + 4 * 5, 0, 0x10, 0, 0)  # full on
    assert emu.high_ticks(5) == 4096
    _write(emu, 0x01, 0x14)  # INVRT
    assert emu.high_ticks(5) == 0


def test_sleep_stops_outputs_until_restart(emu):
    _write(emu, 0x00, 0x20)
    _write(emu, 0x06, 0, 0, 0x00, 0x01)
    assert emu.running and emu.high_ticks(0) == 256
    _write(emu, 0x00, 0x30)  # sleep with an output running: RESTART set
    assert emu.register(0x00) & 0x80 and emu.pulse_us(0) == 0.0
    _write(emu, 0x00, 0x20)  # awake, but the outputs wait for a RESTART
    _write(emu, 0x00, 0xA0)  # too early: the oscillator needs 500 µs
    assert emu.counts["restart_too_early"] == 1 and emu.pulse_us(0) == 0.0
    time.sleep(0.001)
    _write(emu, 0x00, 0xA0)
    assert emu.register(0x00) == 0x20 and emu.high_ticks(0) == 256  # same registers, running again


def test_addressing_nack_allcall_and_software_reset(emu):
    with pytest.raises(OSError) as err:
        emu.writeto(0x41, b"\x00\x20")
    assert err.value.errno == errno.EREMOTEIO
    emu.writeto(0x70, b"\x00\x20")  # All Call reaches it, and this clears ALLCALL
    assert emu.register(0x00) == 0x20 and emu.scan() == [0x40]
    with pytest.raises(OSError):
        emu.writeto(0x70, b"\x00\x21")
    emu.writeto(0x00, b"\x06")  # SWRST general call
    assert emu.register(0x00) == 0x11
    emu.present = False
    with pytest.raises(OSError):
        emu.readfrom_into(ADDR, bytearray(1))
    assert emu.scan() == []


# -- the bus on the emulator ------------------------------------------------------------------------------
def test_open_sets_the_frequency_the_chip_really_has(bus, emu):
    assert emu.prescale == 121 and emu.running and emu.register(0x00) & 0x20  # auto-increment on
    assert bus.frequency == pytest.approx(emu.frequency) and bus.frequency != 50.0


def test_pulse_widths_within_one_tick(bus, emu):
    tick_us = 1e6 / (emu.frequency * 4096)
    channels = list(range(16))
    bus.torque(channels, True)
    for goal in (600.0, 1000.0, 1234.5, 1500.0, 2000.0, 2400.0):
        bus.write_goals(channels, np.full(16, goal))
        widths = np.array([emu.pulse_us(c) for c in channels])
        assert np.all(np.abs(widths - goal) <= tick_us), (goal, widths)
    ramp = np.linspace(700.0, 2300.0, 16)
    bus.write_goals(channels, ramp)
    assert np.all(np.abs(np.array([emu.pulse_us(c) for c in channels]) - ramp) <= tick_us)


def test_goals_are_clipped_to_the_configured_range(bus, emu):
    tick_us = 1e6 / (emu.frequency * 4096)
    bus.torque([0, 1, 2], True)
    bus.write_goals([0, 1, 2], np.array([100.0, 3000.0, np.nan]))
    assert emu.pulse_us(0) == pytest.approx(500.0, abs=tick_us)
    assert emu.pulse_us(1) == pytest.approx(2500.0, abs=tick_us)
    assert emu.pulse_us(2) == 0.0  # NaN: no goal yet, so no pulse


def test_one_write_per_tick_and_none_when_nothing_changes(bus, emu):
    channels = list(range(16))
    bus.torque(channels, True)
    before = emu.counts["write"]
    bus.write_goals(channels, np.full(16, 1500.0))
    assert emu.counts["write"] == before + 1 and emu.write_log[-1][1] == 0x06  # LED0_ON_L
    assert len(emu.write_log[-1][2]) == 64  # all 16 channels' 4 registers, auto-incremented
    bus.write_goals(channels, np.full(16, 1500.0))
    assert emu.counts["write"] == before + 1
    bus.write_goals([3, 9], np.array([1200.0, 1800.0]))  # one write spanning channels 3..9
    _, first, data = emu.write_log[-1]
    assert emu.counts["write"] == before + 2 and first == 0x06 + 4 * 3 and len(data) == 4 * 7


def test_torque_off_means_no_pulses(bus, emu):
    bus.torque([0, 1], True)
    bus.write_goals([0, 1], np.array([1500.0, 1600.0]))
    bus.torque([0], False)
    assert emu.pulse_us(0) == 0.0 and emu.channel_counts(0)[3] and emu.pulse_us(1) > 0
    bus.write_goals([0], np.array([1700.0]))  # a goal with torque off is kept, not output
    assert emu.pulse_us(0) == 0.0
    bus.torque([0], True)
    assert emu.pulse_us(0) == pytest.approx(1700.0, abs=5.0)


def test_ping_and_read_state(bus, emu):
    infos = bus.ping([0, 15, 16])
    assert infos[16] is None
    info = infos[0]
    assert info is not None and info.model == 9685 and info.model_name == "PCA9685 PWM"
    assert info.position is None and (info.raw_min, info.raw_max, info.ticks_per_turn) == (500.0, 2500.0, 0)
    reading = bus.read_state([0, 1])
    assert np.isnan(reading.position).all() and np.isnan(reading.effort).all() and reading.faults == {}
    with pytest.raises(HardwareError, match="channel 16"):
        bus.torque([16], True)


def test_missing_chip(emu):
    emu.present = False
    b = Pca9685Bus(_config(), i2c=emu)
    b.open()  # the bus opens; the board's channels are what is missing
    assert b.ping([0, 1, 2]) == {0: None, 1: None, 2: None}
    assert b.read_state([0, 1]).faults == {0: "no_answer", 1: "no_answer"}
    b.write_goals([0], np.array([1500.0]))  # never raises
    with pytest.raises(HardwareError, match="does not answer"):
        b.torque([0], True)
    emu.present = True  # plugged in: found on the next ping
    assert b.ping([0])[0] is not None and emu.prescale == 121


def test_recovers_from_a_glitch_and_a_brown_out(bus, emu):
    bus.torque([0, 1], True)
    emu.nack_next(1)
    bus.write_goals([0, 1], np.array([1500.0, 1600.0]))  # lost on the wires
    assert emu.pulse_us(0) == 0.0
    bus.write_goals([0, 1], np.array([1500.0, 1600.0]))  # same goals: rewritten, not skipped
    assert emu.pulse_us(0) == pytest.approx(1500.0, abs=5.0)
    emu.power_cycle()
    assert emu.pulse_us(1) == 0.0
    assert bus.read_state([0, 1]).faults == {} and bus.resets == 1
    assert emu.prescale == 121 and emu.pulse_us(1) == pytest.approx(1600.0, abs=5.0)


def test_reopening_keeps_the_outputs_running(bus, emu):
    bus.torque([4], True)
    bus.write_goals([4], np.array([1300.0]))
    again = Pca9685Bus(_config(), i2c=emu)
    again.open()  # the frequency is set again (sleep, PRE_SCALE, RESTART)
    assert emu.counts["restart"] >= 1 and emu.pulse_us(4) == pytest.approx(1300.0, abs=5.0)


def test_no_i2c_device_is_a_hardware_error_naming_it():
    b = Pca9685Bus(_config(i2c_bus=97))
    with pytest.raises(HardwareError, match="/dev/i2c-97"):
        b.open()


# -- SMBusI2C against a stand-in smbus2.SMBus ----------------------------------------------------------------
class FakeSMBus:
    """smbus2.SMBus's i2c_rdwr/write_quick/read_byte, answering from a Pca9685Emulator."""

    def __init__(self, emu: Pca9685Emulator):
        self.emu, self.calls, self.closed = emu, [], False

    def i2c_rdwr(self, *msgs) -> None:
        self.calls.append(
            [(m.addr, bool(m.flags & 1), bytes(m) if not m.flags & 1 else len(m)) for m in msgs]
        )
        if len(msgs) == 2:
            buf = bytearray(len(msgs[1]))
            self.emu.writeto_then_readfrom(msgs[0].addr, bytes(msgs[0]), buf)
            ctypes.memmove(msgs[1].buf, bytes(buf), len(buf))
        elif msgs[0].flags & 1:
            buf = bytearray(len(msgs[0]))
            self.emu.readfrom_into(msgs[0].addr, buf)
            ctypes.memmove(msgs[0].buf, bytes(buf), len(buf))
        else:
            self.emu.writeto(msgs[0].addr, bytes(msgs[0]))

    def write_quick(self, address: int) -> None:
        self.calls.append(("quick", address))
        self.emu.writeto(address, b"")

    def read_byte(self, address: int) -> int:
        self.calls.append(("read_byte", address))
        buf = bytearray(1)
        self.emu.readfrom_into(address, buf)
        return buf[0]

    def close(self) -> None:
        self.closed = True


def test_smbus_i2c_transfers(emu):
    fake = FakeSMBus(emu)
    i2c = SMBusI2C(1, smbus=fake)
    assert i2c.try_lock() and not i2c.try_lock()
    i2c.unlock()
    i2c.writeto(ADDR, bytearray(b"\xff\x00\x20\xff"), start=1, end=3)  # only [0x00, 0x20]: MODE1 = AI
    assert fake.calls[-1] == [(ADDR, False, b"\x00\x20")] and emu.register(0) == 0x20
    buf = bytearray(4)
    i2c.writeto_then_readfrom(ADDR, b"\xfe", buf, in_start=1, in_end=3)  # PRE_SCALE, then MODE1
    assert fake.calls[-1] == [(ADDR, False, b"\xfe"), (ADDR, True, 2)] and buf == bytearray(
        [0, 0x1E, 0x20, 0]
    )
    i2c.readfrom_into(ADDR, buf, end=1)  # the pointer moved on to MODE2
    assert buf[0] == 0x04
    i2c.writeto(ADDR, b"")  # a probe is a quick write
    assert fake.calls[-1] == ("quick", ADDR)
    with pytest.raises(OSError):
        i2c.writeto(0x41, b"\x00")
    assert i2c.scan() == [0x40]  # 0x50..0x5F probed by reading a byte, the rest by quick writes
    assert ("read_byte", 0x50) in fake.calls and ("quick", 0x40) in fake.calls
    i2c.deinit()
    assert fake.closed
    with pytest.raises(OSError):
        i2c.writeto(ADDR, b"\x00")


def test_bus_through_smbus_i2c(emu):
    b = Pca9685Bus(_config(), i2c=SMBusI2C(1, smbus=FakeSMBus(emu)))
    b.open()
    b.torque([7], True)
    b.write_goals([7], np.array([1800.0]))
    assert emu.prescale == 121 and emu.pulse_us(7) == pytest.approx(1800.0, abs=5.0)
