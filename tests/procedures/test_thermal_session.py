"""A thermal session on the simulated rig and fake chamber: the soak judged from the chips' thermometers ends when the
die truly settles, each step is an ordinary session, the model is written, the chamber is left safe, and a chamber
that stops answering ends the run by name (exit 3) with everything kept, which `resume` finishes."""

import json
import signal
from dataclasses import replace

import numpy as np
import pytest

from fixtures.world.heat import curves_at
from procedures.orchestrator import RigSpec
from procedures.soak import soak, SoakSettings
from procedures.thermal_session import MANIFEST, soak_settings
from rig.commands.thermal_run import SimulatedThermalRig, builtin_thermal_config, run_thermal_to
from rig.errors import StopSignal
from rig.store import SessionStore
from rig.io.calibration_json import read_calibration, temperature_models_from_calibration, triads_from_calibration

SETTINGS = SoakSettings(slope_c_per_min=0.1, window_s=60.0, poll_s=5.0, min_soak_s=120.0, max_soak_s=7200.0)


def short_config(steps_c, direction="up"):
    config = builtin_thermal_config()
    config.thermal = replace(config.thermal, steps_c=list(steps_c), direction=direction, orientations=9, hold_s=1.5,
                             sim_hysteresis=False)
    config.schedule.rate_hz = 50.0
    config.schedule.mag_every = 1
    config.limits = {}
    return config


def true_settling_time(fake, start_s: float, end_s: float, threshold_c_per_min: float) -> float:
    """From the fake chamber's own die trajectory: the first time after which the die's slope stays below the
    threshold (checked until `end_s`, long after the soak)."""
    t = np.arange(start_s, end_s, 1.0)
    slope = np.gradient(fake.die_at(t), t) * 60.0
    above = np.flatnonzero(np.abs(slope) >= threshold_c_per_min)
    return float(t[above[-1] + 1]) if above.size else start_s


@pytest.mark.parametrize("set_points,settings", [((40.0, 10.0), SETTINGS),
                                                 ((30.0, 15.0), soak_settings(builtin_thermal_config()))],
                         ids=["slope-0.1", "built-in"])
def test_a_soak_ends_within_ten_percent_of_when_the_die_truly_settles(set_points, settings):
    config = short_config([10.0, 40.0])
    spec = RigSpec(True, 3, None)
    with SimulatedThermalRig(config, spec) as hw, hw.build_rig(config, spec) as rig, hw.chamber() as chamber:
        rig.board.start()
        chamber.ramp_rate(None)
        soaks = [soak(chamber, rig.board.read_temperature, hw.clock, sp, settings) for sp in set_points]
        hw.clock.sleep(4000.0)                # the truth's trajectory long after the last soak
        horizon = hw.clock.now()
        for k, done in enumerate(soaks):
            end = soaks[k + 1].start_s if k + 1 < len(soaks) else horizon
            truth = true_settling_time(hw.fake, done.start_s, end, settings.slope_c_per_min)
            assert truth - done.start_s > settings.min_soak_s       # the die's own settling decided, not the floor
            assert abs(done.end_s - truth) <= 0.10 * (truth - done.start_s), (done.to_dict(), truth)
            assert abs(done.die_c - hw.fake.die_at(done.end_s)) < 0.05     # the chips read the die


def test_a_thermal_session_records_a_session_per_step_fits_the_model_and_leaves_the_chamber_safe(tmp_path):
    config = short_config([15.0, 35.0])
    made = []

    def hardware(config, spec):
        made.append(SimulatedThermalRig(config, spec))
        return made[-1]

    lines = []
    out = tmp_path / "thermal"
    code = run_thermal_to(out, config, sim=True, seed=5, progress=False, echo=lambda s, err=False: lines.append(s),
                          open_hardware=hardware)
    assert code == 0, lines
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["status"] == "complete" and [s["status"] for s in manifest["steps"]] == ["complete"] * 2
    steps = manifest["steps"]
    table = [read_calibration(out / s["folder"] / "calibration.json")["table_time_s"] for s in steps]
    assert manifest["table_time_s"] == pytest.approx(sum(table), abs=0.01)
    soaked = sum(x["duration_s"] for s in steps for x in s["soaks"])
    assert manifest["chamber_time_s"] > soaked + sum(table)          # each step's moves and set-up lie beyond holds
    assert any("table time" in line and "chamber time" in line for line in lines)
    fake = made[0].fake
    for s in steps:                  # the step's die temperature is the chamber's die, read by the chips
        at_soak_end = float(fake.die_at(s["soaks"][-1]["end_s"]))
        assert abs(s["die_c"]["mean"] - at_soak_end) < 0.15          # settled: a few hundredths of a C per step
        assert abs(at_soak_end - (s["set_point_c"] + fake.params.die_self_heating_c)) < 1.0
    assert not fake.state.running and fake.state.set_point == pytest.approx(fake.profile.ambient_c)

    doc = read_calibration(out / "calibration.json")
    models = temperature_models_from_calibration(doc, out / "calibration.json")
    assert set(models) >= {"accel", "gyro"}
    gyro = models["gyro"]
    assert gyro.valid_c == pytest.approx((steps[0]["die_c"]["mean"], steps[1]["die_c"]["mean"]))
    for s in steps:                  # the model at each step's die temperature against the world's truth there
        truth = json.loads((out / s["folder"] / "truth.json").read_text())
        k = truth["sensors"]["gyro"]["counts_per_unit"]
        physical = truth["physical"]["gyro"]
        _, B_true = curves_at(made[0].effects, "gyro", physical["H"], physical["B"], s["die_c"]["mean"])
        cal = triads_from_calibration(read_calibration(out / s["folder"] / "calibration.json"))["gyro"]
        assert np.all(np.abs(gyro.B_at(s["die_c"]["mean"]) - B_true * k) < 5 * cal.B_std + 1e-9), s["folder"]


class ChamberDiesAtSecondSoak(SimulatedThermalRig):
    """The chamber stops answering once the first step is recorded: the rig built for the second soak is the third
    (first soak, first step's session, second soak)."""

    built = 0

    def build_rig(self, config, spec):
        self.built += 1
        if self.built == 3:
            self.fake.faults.stop_answering()
        return super().build_rig(config, spec)


def test_a_chamber_that_stops_answering_ends_the_run_by_name_and_resume_finishes_it(tmp_path):
    config = short_config([10.0, 30.0, 50.0])
    out = tmp_path / "thermal"
    said = []
    code = run_thermal_to(out, config, sim=True, seed=2, progress=False, echo=lambda s, err=False: said.append(s),
                          open_hardware=ChamberDiesAtSecondSoak)
    assert code == 3, said
    assert any("chamber" in line and "no valid response" in line for line in said), said
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["status"] == "failed" and "chamber" in manifest["status_reason"]
    assert [s["status"] for s in manifest["steps"]] == ["complete", "soaking", "pending"]
    kept = (out / manifest["steps"][0]["folder"] / "calibration.json").read_bytes()

    code = run_thermal_to(out, None, resume=True, progress=False, echo=lambda s, err=False: said.append(s),
                          open_hardware=SimulatedThermalRig)
    assert code == 0, said
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["status"] == "complete" and manifest["runs"] == 2
    assert [s["status"] for s in manifest["steps"]] == ["complete"] * 3
    assert (out / manifest["steps"][0]["folder"] / "calibration.json").read_bytes() == kept
    assert len(manifest["steps"][1]["soaks"]) == 1              # the soak cut short by the fault is not counted
    assert "temperature_model" in read_calibration(out / "calibration.json")["sensors"]["gyro"]


class StoppedWhileSoaking(SimulatedThermalRig):
    """SIGTERM arrives while the first soak reads the chips' thermometer."""

    def build_rig(self, config, spec):
        rig = super().build_rig(config, spec)
        read = rig.board.temperature
        calls = []

        def stopping():
            calls.append(1)
            if len(calls) == 10:
                raise StopSignal(signal.SIGTERM)
            return read()

        rig.board.temperature = stopping
        return rig


def test_a_stop_signal_while_soaking_leaves_the_chamber_safe_and_the_session_resumable(tmp_path):
    config = short_config([20.0, 40.0])
    made = []

    def hardware(config, spec):
        made.append(StoppedWhileSoaking(config, spec))
        return made[-1]

    said = []
    code = run_thermal_to(tmp_path / "t", config, sim=True, seed=1, progress=False,
                          echo=lambda s, err=False: said.append(s), open_hardware=hardware)
    assert code == 128 + signal.SIGTERM, said
    manifest = json.loads((tmp_path / "t" / MANIFEST).read_text())
    assert manifest["status"] == "aborted" and "SIGTERM" in manifest["status_reason"]
    fake = made[0].fake
    assert not fake.state.running                                         # made safe on the way out
    assert fake.state.set_point == pytest.approx(fake.profile.ambient_c)
    assert any(f"rig resume {tmp_path / 't'}" in line for line in said)


def test_thermal_options_are_refused_by_name_before_anything_is_made(tmp_path):
    from click.testing import CliRunner

    from rig.cli import main

    plain = tmp_path / "plain.toml"
    plain.write_text('[unit]\nboard = "bsn"\n')
    runner = CliRunner()
    result = runner.invoke(main, ["calibrate", "--thermal", "--config", str(plain), "--out", str(tmp_path / "a")])
    assert result.exit_code == 2 and "[thermal]" in result.output and not (tmp_path / "a").exists()
    no_chamber = tmp_path / "no-chamber.toml"
    no_chamber.write_text('[unit]\nboard = "bsn"\n[thermal]\nsteps_c = [10.0, 30.0]\n')
    result = runner.invoke(main, ["calibrate", "--config", str(no_chamber), "--out", str(tmp_path / "b")])
    assert result.exit_code == 2 and "[chamber]" in result.output and not (tmp_path / "b").exists()
    bad = tmp_path / "bad.toml"
    bad.write_text('[thermal]\ndirection = "sideways"\n[chamber]\n')
    result = runner.invoke(main, ["calibrate", "--config", str(bad), "--out", str(tmp_path / "c")])
    assert result.exit_code == 2 and "direction" in result.output and str(bad) in result.output


class StoppedMidStep(SimulatedThermalRig):
    """SIGINT arrives while the first step's session records (the rig built second: after the first soak's)."""

    built = 0

    def build_rig(self, config, spec):
        rig = super().build_rig(config, spec)
        self.built += 1
        if self.built == 2:
            read, calls = rig.board.temperature, []

            def stopping():
                calls.append(1)
                if len(calls) == 15:
                    raise StopSignal(signal.SIGINT)
                return read()

            rig.board.temperature = stopping
        return rig


def test_a_step_stopped_mid_session_is_soaked_again_and_finished_by_the_orchestrators_resume(tmp_path):
    config = short_config([15.0, 35.0])
    out = tmp_path / "t"
    said = []
    code = run_thermal_to(out, config, sim=True, seed=8, progress=False, echo=lambda s, err=False: said.append(s),
                          open_hardware=StoppedMidStep)
    assert code == 128 + signal.SIGINT, said
    manifest = json.loads((out / MANIFEST).read_text())
    first = manifest["steps"][0]
    assert manifest["status"] == "aborted" and first["status"] == "aborted"
    with SessionStore.open(out / first["folder"]) as store:
        held = len(store.completed_holds())
    assert 0 < held < 9

    code = run_thermal_to(out, None, resume=True, progress=False, echo=lambda s, err=False: said.append(s),
                          open_hardware=SimulatedThermalRig)
    assert code == 0, said
    manifest = json.loads((out / MANIFEST).read_text())
    first = manifest["steps"][0]
    assert [s["status"] for s in manifest["steps"]] == ["complete"] * 2 and len(first["soaks"]) == 2
    with SessionStore.open(out / first["folder"]) as store:
        assert len(store.resume_times()) == 1 and len(store.completed_holds()) == 9     # resumed, not restarted
