"""The effects vocabulary (`effects.md`, `rig-discrepancy/1`): one entry per effect, read by everything that names one.

An entry says what the effect is called, which sensors it acts on, the unit its magnitude is reported in, and who
looks for it: the discrepancy analysis of a turntable session (`family="model"`, a candidate test in
`rig.discrepancy.candidates`) or the twin of a recording (`family="noise"`, fitted from the noise statistics by
`procedures.twin.extension`), or the analysis of a thermal session's steps (`family="thermal"`,
`rig.discrepancy.thermal`: hysteresis between the sweeps, thermal lag). The simulated world's terms
(`fixtures.world.effects`) and the analysis's candidate tests register themselves against these names, one module
per effect, found by `discover`; `tests/rig/test_effects_registry.py` checks that every entry has its simulator
term, its draw range and its candidate test, or says why it has none.

A new effect: one entry here, its simulator term in `fixtures/world/effects/<name>.py` (with its realistic range)
and its candidate test in `rig/discrepancy/candidates/<name>.py`; nothing else lists effect names
(`tests/rig/test_effects_extension.py`).
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterable
from dataclasses import dataclass

from rig.units import REPORT_UNITS

TRIADS = ("accel", "gyro", "mag")
TWIN_FITS_IT = "a noise or recording effect: the twin of a recording fits it from the noise statistics"


@dataclass(frozen=True)
class EffectSpec:
    name: str
    sensors: tuple[str, ...]          # "rig": the table itself, seen by every sensor
    unit: str                         # of the magnitude; "{unit}" is the sensor's reported unit (rig.units)
    cause: str
    family: str = "model"             # "model": a candidate test on turntable sessions; "noise": the twin's;
                                      # "thermal": named from a thermal session's steps (rig.discrepancy.thermal)
    no_candidate: str = ""            # why no candidate test exists (empty: the analysis must have one)

    def unit_for(self, sensor: str, base: str | None = None) -> str:
        """The unit a magnitude on `sensor` is reported in; `base` in place of the sensor's own (a still log's
        gyro in counts, which no scale turns into deg/s: `rig.noise.still_log`)."""
        return self.unit.format(unit=base or REPORT_UNITS[sensor][0]) if "{unit}" in self.unit else self.unit

    @property
    def tested_on(self) -> tuple[str, ...]:
        """The sensors whose data carry it: a table error shows in every triad."""
        return TRIADS if self.sensors == ("rig",) else self.sensors

    def reported_sensor(self, tested_on: str) -> str:
        return "rig" if self.sensors == ("rig",) else tested_on


THERMAL_HYSTERESIS = "thermal_hysteresis"
THERMAL_LAG = "thermal_lag"
THERMAL_NAMES_IT = ("a thermal session's effect: rig.discrepancy.thermal names it from the steps' calibrations and "
                    "their sweep directions and rates, not a turntable session's regressor")


def _thermal(name: str, unit: str, cause: str) -> EffectSpec:
    return EffectSpec(name, TRIADS, unit, cause, family="thermal", no_candidate=THERMAL_NAMES_IT)


def _noise(name: str, sensors: tuple[str, ...], unit: str, cause: str) -> EffectSpec:
    return EffectSpec(name, sensors, unit, cause, family="noise", no_candidate=TWIN_FITS_IT)


# The order is the order the analysis tries them in (and lists them in its report).
EFFECTS: dict[str, EffectSpec] = {e.name: e for e in (
    EffectSpec("temperature_bias", TRIADS, "{unit} per degC", "bias tempco"),
    EffectSpec("temperature_scale", TRIADS, "ppm per degC", "sensitivity tempco"),
    EffectSpec("bias_drift", TRIADS, "{unit} per hour", "bias wander over the session"),
    EffectSpec("table_axis_misalignment", ("rig",), "deg", "table axes not orthogonal / encoder zero offsets"),
    EffectSpec("accel_scale_nonlinearity", ("accel",), "1/(m/s^2)", "second-order response"),
    EffectSpec("supply_ratiometric", ("accel",), "m/s^2 per V", "ratiometric output read against a fixed ADC reference"),
    EffectSpec("accel_scale_asymmetry", ("accel",), "percent", "different scale for positive and negative specific "
               "force (an asymmetric rest position of the proof mass)"),
    EffectSpec("gyro_g_sensitivity", ("gyro",), "deg/s per g", "proof-mass response to specific force"),
    EffectSpec("earth_rotation", ("gyro",), "deg/h", "the Earth's rotation, a real input the reference leaves out"),
    EffectSpec("time_offset", ("gyro",), "s", "latency between sensor samples and the reference"),
    EffectSpec("gyro_scale_asymmetry", ("gyro",), "percent", "different scale for positive and negative rates"),
    EffectSpec("table_magnetic_disturbance", ("mag",), "uT", "field of a motor carried by the outer gimbal"),
    EffectSpec("mag_offset_flip", ("mag",), "uT", "bridge magnetisation flipped by a strong field (set/reset)"),
    _thermal(THERMAL_HYSTERESIS, "{unit}", "bias and scale differ between the up and the down temperature sweep "
             "(package stress that relaxes only partly)"),
    _thermal(THERMAL_LAG, "s", "the sensing element's temperature lags the thermometer's (a die sensor away from "
             "the element, or the air read instead of the die)"),
    _noise("white_noise_mismatch", TRIADS, "dimensionless", "noise density other than the simulator's"),
    _noise("bias_instability", TRIADS, "{unit}", "flicker (1/f) noise of the bias"),
    _noise("rate_random_walk", TRIADS, "{unit} per sqrt(s)", "the bias integrates white noise"),
    _noise("quantisation", TRIADS, "{unit}", "coarse counts that the noise does not dither"),
    _noise("hold_not_still", ("accel", "gyro"), "deg/s", "a static pose that turns (hand tremor, a soft mount)"),
    _noise("vibration", ("accel",), "m/s^2", "linear acceleration of the holds that the gyro does not see (a motor, "
           "a fan, a vehicle), or a noise of the accelerometer's own in some poses"),
    _noise("saturation", TRIADS, "percent", "the output clips at its range"),
    _noise("warm_up", TRIADS, "{unit}", "the bias settling as the unit comes to temperature after power-on"),
)}


def effect(name: str) -> EffectSpec:
    """The vocabulary's entry; an unknown name is refused with the vocabulary listed."""
    try:
        return EFFECTS[name]
    except KeyError:
        raise ValueError(f"unknown effect {name!r}; the vocabulary is {sorted(EFFECTS)}") from None


def unit_for(name: str, sensor: str, base: str | None = None) -> str:
    return effect(name).unit_for(sensor, base)


def discover(package: str, path: Iterable[str]) -> list[str]:
    """Import every module of `package` (its `__path__`), in name order, and return their names.

    The simulator terms (`fixtures.world.effects`) and the candidate tests (`rig.discrepancy.candidates`) register
    themselves against the vocabulary when their module is imported; each package's `__init__` calls this, so a
    new effect's file is found without being listed. This loader imports the package's own modules by name
    (importlib) as its whole job: it is not an import placed in a function to dodge a loop."""
    names = sorted(m.name for m in pkgutil.iter_modules(list(path)) if not m.name.startswith("_"))
    for name in names:
        importlib.import_module(f"{package}.{name}")
    return names
