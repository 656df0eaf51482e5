"""An outside project's tests, written as a firmware/driver team would against the `rig` pytest plugin.

Copied into a temporary folder and run by tests/plugin/test_installed_plugin.py with the rig wheel installed
in a fresh virtual environment; nothing here imports the rig's own test code.
"""

import struct

from pymodbus.client import ModbusTcpClient


def read_accel_g(bus, address=0x53):
    """The team's own tiny ADXL312 driver: power on, then one 6-byte burst, full resolution 2.9 mg/LSB."""
    bus.write_byte_data(address, 0x31, 0x0B)
    bus.write_byte_data(address, 0x2D, 0x08)
    raw = bytes(bus.read_i2c_block_data(address, 0x32, 6))
    return [v * 0.0029 for v in struct.unpack("<hhh", raw)]


def test_own_driver_against_an_emulated_adxl312(rig_i2c, rig_clock):
    chip = rig_i2c.place("ADXL312", 0x53, accel=[0.0, 4.903325, 8.49278])
    assert rig_i2c.bus.read_byte_data(0x53, 0x00) == EXPECTED_DEVID
    read_accel_g(rig_i2c.bus)
    rig_clock.sleep(0.05)
    x, y, z = read_accel_g(rig_i2c.bus)
    assert abs(x) < 0.01 and abs(y - 0.5) < 0.01 and abs(z - 0.866) < 0.01
    chip.faults.stuck = True                      # the emulator's fault hooks are there too
    assert read_accel_g(rig_i2c.bus) == [x, y, z]


def test_own_spi_code_against_an_emulated_lsm6dso(rig_spi):
    rig_spi.place("LSM6DSO", cs=1, gyro=[0.0, 0.0, 1.0])
    spi = rig_spi.open(1, mode=3, max_speed_hz=8_000_000)
    assert spi.xfer2([0x80 | 0x0F, 0x00])[1] == 0x6C


def test_own_modbus_client_against_the_fake_turntable(rig_turntable):
    client = ModbusTcpClient(rig_turntable.host, port=rig_turntable.port)
    assert client.connect()
    try:
        reply = client.read_holding_registers(0, count=2, device_id=1)
        assert not reply.isError() and reply.registers[0] != 0
    finally:
        client.close()


EXPECTED_DEVID = 0xE5
