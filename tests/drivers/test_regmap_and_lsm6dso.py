"""Register-map descriptors, and the LSM6DSO driver byte by byte (scripted buses) and against its emulator."""

from __future__ import annotations

import numpy as np
import pytest

from drivers import FifoOverrun, WrongIdentity
from drivers.lsm6dso import LSM6DSO, LSM6DSRegisters as R
from drivers.regmap import RegisterMap, Reg, ROBit, RWBit, RWBits
from fixtures.buses import FakeSMBus, FakeSpiDev
from fixtures.chips.lsm6dso import LSM6DSOEmulator
from fixtures.sources import ConstantSource
from rig.clock import SimClock
from tests.drivers.conftest import expected_protocol

A = 0x6A


class Toy(RegisterMap):
    chip = "TOY"
    CTRL, STATUS = Reg(0x10), Reg(0x11, access="r")
    mode = RWBits(3, CTRL, 4)
    enable = RWBit(CTRL, 0)
    ready = ROBit(STATUS, 7)


class Memory:
    def __init__(self, values):
        self.values, self.log = dict(values), []

    def read(self, reg):
        self.log.append(("r", reg))
        return self.values[reg]

    def write(self, reg, value):
        self.log.append(("w", reg, value))
        self.values[reg] = value

    def where(self, reg):
        return f"toy register 0x{reg:02X}"


def test_field_descriptors_read_modify_write_and_whole_register_puts():
    mem = Memory({0x10: 0b1000_0001, 0x11: 0x80})
    regs = Toy(mem)
    assert regs.mode == 0 and regs.enable == 1 and regs.ready == 1
    regs.mode = 5
    assert mem.values[0x10] == 0b1101_0001                     # other bits kept (read-modify-write)
    mem.log.clear()
    regs.put(Toy.CTRL, mode=2, enable=1)
    assert mem.log == [("w", 0x10, 0b0010_0001)]                 # one write, unnamed bits zero
    assert Toy.NAMES == {0x10: "CTRL", 0x11: "STATUS"}


def test_field_errors_name_chip_register_and_field():
    regs = Toy(Memory({0x10: 0, 0x11: 0}))
    with pytest.raises(ValueError, match=r"TOY: CTRL.mode = 9 does not fit 3 bit"):
        regs.put(Toy.CTRL, mode=9)
    with pytest.raises(ValueError, match=r"TOY: CTRL has no field 'ready'"):
        regs.put(Toy.CTRL, ready=1)
    with pytest.raises(AttributeError, match="read-only"):
        regs.ready = 0


def word(tag: int, x: int, y: int, z: int) -> list[int]:
    out = [tag << 3]
    for v in (x, y, z):
        out += list((v & 0xFFFF).to_bytes(2, "little"))
    return out


START = [
    ("r", A, 0x0F, 0x6C),
    ("w", A, 0x12, 0x05, None),          # CTRL3_C SW_RESET | IF_INC
    ("r", A, 0x12, 0x04),                # SW_RESET cleared
    ("w", A, 0x12, 0x84, None),          # BOOT | IF_INC
    ("w", A, 0x12, 0x44, None),          # BDU | IF_INC
    ("r", A, 0x63, 0xF6),                # INTERNAL_FREQ_FINE = -10: the oscillator 1.5 % slow
    ("w", A, 0x09, 0x44, None),          # FIFO_CTRL3 BDR_GY = BDR_XL = 104 Hz
    ("w", A, 0x10, 0x48, None),          # CTRL1_XL 104 Hz, FS_XL = 10 (4 g)
    ("w", A, 0x11, 0x4C, None),          # CTRL2_G 104 Hz, FS_G = 11 (2000 dps)
    ("w", A, 0x0A, 0x06, None),          # FIFO_CTRL4 continuous
    ("rb", A, 0x3A, 2, [0, 0]),          # turn-on data dropped (none here)
    ("rb", A, 0x3A, 2, [2, 0]),
    ("rb", A, 0x78, 14, word(1, 10, 20, 30) + word(2, 1, 2, 3)),
]


def test_start_up_sequence_uses_declared_fields(sleeps):
    with expected_protocol("i2c", START) as bus:
        imu = LSM6DSO(bus, sleep=sleeps)
        imu.start()
    assert sleeps[:2] == [0.05, 0.05]
    assert imu.accel.read_raw() == (1, 2, 3) and imu.gyro.read_raw() == (10, 20, 30)
    assert imu.gyro.settings()["rate_hz"] == pytest.approx(104.0 * (1 - 10 * 0.0015), rel=1e-12)
    assert imu.settings()["odr_hz"] == 104.0


def test_wrong_who_am_i_names_the_register(sleeps):
    with expected_protocol("i2c", [("r", A, 0x0F, 0x6A)]) as bus:
        with pytest.raises(WrongIdentity, match=r"LSM6DSO at I2C address 0x6A, register 0x0F WHO_AM_I: read 0x6A"):
            LSM6DSO(bus, sleep=sleeps).start()


def test_fifo_drain_reads_four_words_per_burst_and_sorts_by_tag(sleeps):
    words = [word(1, i, 0, 0) if i % 2 else word(2, i, 0, 0) for i in range(6)]
    steps = [("rb", A, 0x3A, 2, [6, 0]), ("rb", A, 0x78, 28, sum(words[:4], [])),
             ("rb", A, 0x78, 14, sum(words[4:], []))]
    with expected_protocol("i2c", steps) as bus:
        got = LSM6DSO(bus, sleep=sleeps).read_fifo()
    assert [s[0] for s in got["accel"]] == [0, 2, 4] and [s[0] for s in got["gyro"]] == [1, 3, 5]


def test_fifo_overrun_raises_with_the_drained_samples(sleeps):
    steps = [("rb", A, 0x3A, 2, [1, 0x48]), ("rb", A, 0x78, 7, word(2, -5, 0, 7))]
    with expected_protocol("i2c", steps) as bus:
        with pytest.raises(FifoOverrun, match="FIFO_STATUS2: FIFO overrun") as err:
            LSM6DSO(bus, sleep=sleeps).read_fifo()
    assert err.value.samples["accel"] == [(-5, 0, 7)]


def test_unsupported_settings_list_the_allowed_values():
    with pytest.raises(ValueError, match=r"LSM6DSO: unsupported output data rate 100 Hz; allowed: 12.5, 26, 52, 104"):
        LSM6DSO(object(), odr_hz=100)


@pytest.mark.parametrize("interface", ["i2c", "spi"])
@pytest.mark.parametrize("range_g,range_dps", [(2, 125), (16, 1000), (8, 500)])
def test_driver_against_emulator_gives_the_physical_input(interface, range_g, range_dps):
    clock = SimClock()
    accel, gyro = np.array([1.5, -4.0, 9.80665]), np.array([0.2, -0.1, 0.05])
    emu = LSM6DSOEmulator(ConstantSource(accel), ConstantSource(gyro, temperature=31.5), clock)
    if interface == "i2c":
        bus = FakeSMBus()
        bus.attach(0x6B, emu)
        imu = LSM6DSO(bus, 0x6B, accel_range_g=range_g, gyro_range_dps=range_dps, sleep=clock.sleep)
    else:
        bus = FakeSpiDev(emu)
        bus.open(0, 2)
        bus.mode, bus.max_speed_hz = 3, 10_000_000
        imu = LSM6DSO(bus, cs=2, accel_range_g=range_g, gyro_range_dps=range_dps, sleep=clock.sleep)
    imu.start()
    clock.sleep(0.05)
    a = np.array(imu.accel.read_raw()) * imu.accel.settings()["scale"]
    g = np.array(imu.gyro.read_raw()) * imu.gyro.settings()["scale"]
    lsb_a, lsb_g = imu.accel.settings()["scale"], imu.gyro.settings()["scale"]
    assert np.allclose(a, accel, atol=lsb_a) and np.allclose(g, gyro, atol=lsb_g)
    assert imu.read_temperature() == pytest.approx(31.5, abs=1 / 256)


def test_every_sample_reaches_the_host_through_the_fifo():
    """Read late and irregularly: the FIFO still hands over one sample per output period, none twice."""
    clock = SimClock()

    class Ramp(ConstantSource):
        def sense(self, t):
            return np.array([0.0, 0.0, 10.0 * t])

    emu = LSM6DSOEmulator(Ramp(), ConstantSource(), clock)
    bus = FakeSMBus()
    bus.attach(0x6A, emu)
    imu = LSM6DSO(bus, odr_hz=208, gyro_range_dps=125, sleep=clock.sleep)
    imu.start()
    imu.read_fifo()
    zs = []
    for dt in (0.013, 0.05, 0.002, 0.3, 0.02):
        clock.sleep(dt)
        zs += [s[2] for s in imu.read_fifo()["accel"]]
    steps = np.diff(zs)
    assert len(zs) == pytest.approx(0.385 * 208, abs=2)
    assert np.all(steps > 0) and np.ptp(steps) <= 1           # equally spaced samples of a ramp, in order
