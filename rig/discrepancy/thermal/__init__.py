"""What a thermal session's temperature model misses: hysteresis between its up and down sweeps and the lag of
the sensing element's temperature behind the thermometer's, named in the effects vocabulary and sized.

Entry point: `thermal_causes(sensor, steps)` with one `SweptStep` per temperature step, and `report_lines` to
print its verdict.
"""

from rig.discrepancy.thermal.causes import ALPHA, ThermalCause, ThermalCauses, report_lines, thermal_causes
from rig.discrepancy.thermal.sweeps import SweptStep

__all__ = ["ALPHA", "SweptStep", "ThermalCause", "ThermalCauses", "report_lines", "thermal_causes"]
