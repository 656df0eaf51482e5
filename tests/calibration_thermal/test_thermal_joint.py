"""The temperature model fitted in one piece to every step's hold means: as accurate as the two-stage fit, its
stated deviations honest."""

import numpy as np

from rig.calibration.thermal import fit_thermal_model
from rig.calibration.thermal.joint import fit_thermal_model_joint

from thermal_synth import G, accel_holds, errors, held_out_temps, make_unit, steps_from_holds

UNITS = 5


def test_joint_fit_matches_the_two_stage_fit_and_states_its_deviation():
    rng = np.random.default_rng(61)
    err, z = [], []
    for _ in range(UNITS):
        unit = make_unit("accel", rng)
        holds = accel_holds(unit, rng)
        two, joint = fit_thermal_model("accel", steps_from_holds(holds)), fit_thermal_model_joint("accel", holds, G)
        assert joint.B.orders == two.B.orders and joint.H.orders == two.H.orders
        for t in held_out_temps():
            err.append([errors(unit, m.B_at(t), m.H_at(t), t)["output"] for m in (two, joint)])
            cal = joint.calibration_at(t)
            z.extend((cal.B - unit.B(t)) / cal.B_std)
    two_rms, joint_rms = np.sqrt(np.mean(np.square(err), axis=0))
    assert joint_rms <= 1.1 * two_rms, (joint_rms, two_rms)
    rms_z = float(np.sqrt(np.mean(np.square(z))))
    assert 0.6 < rms_z < 1.6, rms_z
