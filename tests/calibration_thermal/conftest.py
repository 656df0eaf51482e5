"""The thermal tests import their simulated units (thermal_synth) and the comparison beside them."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
