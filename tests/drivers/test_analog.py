"""ADXL330 and HMC1053 (analog, through the MCP3208): counts, supply monitor, set/reset, plausibility."""

from __future__ import annotations

import pytest

from drivers import ADXL330, HMC1053, MCP3208, DeviceAbsent
from tests.drivers.conftest import expected_protocol

CMD = {0: (0x06, 0x00), 1: (0x06, 0x40), 2: (0x06, 0x80), 3: (0x06, 0xC0),
       4: (0x07, 0x00), 5: (0x07, 0x40), 6: (0x07, 0x80), 7: (0x07, 0xC0)}


def conv(channel: int, code: int) -> tuple:
    return ("x", (*CMD[channel], 0x00), [0x00, code >> 8, code & 0xFF])


def test_adxl330_start_checks_channels_then_reads_signed_counts(sleeps):
    steps = [conv(0, 2000), conv(1, 2100), conv(2, 2457), conv(0, 2048), conv(1, 1639), conv(2, 2457)]
    with expected_protocol("spi", steps) as spi:
        accel = ADXL330(MCP3208(spi), sleep=sleeps)
        accel.start()
        assert accel.read_raw() == (0, -409, 409)
    assert sleeps == [0.02]


@pytest.mark.parametrize("stuck", [0, 4095])
def test_adxl330_stuck_channel_is_absent(stuck, sleeps):
    with expected_protocol("spi", [conv(0, 2048), conv(1, stuck)]) as spi:
        with pytest.raises(DeviceAbsent, match=rf"ADXL330 Y on ADC channel 1: code {stuck} is stuck"):
            ADXL330(MCP3208(spi), sleep=sleeps).start()


def test_adxl330_supply_monitor(sleeps):
    with expected_protocol("spi", [conv(6, 2048)]) as spi:
        accel = ADXL330(MCP3208(spi, vref=3.3), supply_channel=6, supply_divider=0.5, sleep=sleeps)
        assert accel.read_supply_v() == pytest.approx(3.3)


def test_adxl330_without_supply_channel():
    with pytest.raises(ValueError, match="no supply_channel"):
        ADXL330(object()).read_supply_v()


@pytest.mark.parametrize("kw", [{"channels": (0, 1)}, {"channels": (0, 0, 1)}, {"channels": (0, 1, 8)},
                                {"supply_channel": 1}, {"supply_channel": 9}, {"supply_divider": 0}])
def test_adxl330_configuration_validation(kw):
    with pytest.raises(ValueError, match="ADXL330"):
        ADXL330(object(), **kw)


def test_adxl330_scale():
    assert ADXL330(object()).settings()["scale"] == pytest.approx(9.80665 / 409.6)


def test_hmc1053_set_reset_differencing_and_offset(sleeps):
    events = []
    steps = [conv(3, 2148), conv(4, 2000), conv(5, 2060), conv(3, 1968), conv(4, 2100), conv(5, 2040)]
    with expected_protocol("spi", steps) as spi:
        adc = MCP3208(spi)
        real_xfer = spi.xfer2
        spi.xfer2 = lambda values, *a: events.append("adc") or real_xfer(values, *a)
        mag = HMC1053(adc, set_reset=lambda p: events.append(p), settle_s=1e-4, sleep=sleeps)
        assert mag.read_raw() == (180, -100, 20)
    assert events == [+1, "adc", "adc", "adc", -1, "adc", "adc", "adc"]
    assert sleeps == [1e-4, 1e-4]
    assert mag.offset == (10.0, 2.0, 2.0)


def test_hmc1053_without_strap_driver_is_code_minus_mid(sleeps):
    with expected_protocol("spi", [conv(3, 2050), conv(4, 2040), conv(5, 2048)]) as spi:
        assert HMC1053(MCP3208(spi), sleep=sleeps).read_raw() == (2, -8, 0)


def test_hmc1053_start_stuck_channel(sleeps):
    with expected_protocol("spi", [conv(3, 2048), conv(4, 2048), conv(5, 0)]) as spi:
        with pytest.raises(DeviceAbsent, match="HMC1053 Z on ADC channel 5"):
            HMC1053(MCP3208(spi), sleep=sleeps).start()


def test_hmc1053_scale_doubles_resolution_with_set_reset():
    plain = HMC1053(MCP3208(object(), vref=3.3)).settings()["scale"]
    paired = HMC1053(MCP3208(object(), vref=3.3), set_reset=lambda p: None).settings()["scale"]
    assert plain == pytest.approx(100 / (1e-3 * 3.3 * 100 * 4096 / 3.3))
    assert paired == pytest.approx(plain / 2)
