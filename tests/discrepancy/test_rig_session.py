"""The discrepancy analysis on a session recorded by the whole simulated rig (drivers, buses, Modbus table),
exported to the interchange layout.

The emulated gyro samples on its own 100 Hz clock; the rig aligns its tick grid to the gyro's data-ready
edge, so there is no latency for the analysis to find (before the alignment it named a 0-10 ms
`time_offset`, depending on the phase of the two clocks). A clean session gives no finding; a hidden
g-sensitivity must be named and sized."""

import numpy as np

from fixtures.world.effects.gyro_g_sensitivity import GyroGSensitivity
from procedures.session import plan_for, record
from rig.assembly import build_sim
from rig.config import load_config
from rig.discrepancy import analyze
from rig.io.session_csv import read_session
from rig.io.session_writer import write_session
from tests.procedures.test_procedure import MemoryStore

G0 = 9.80665


class RowStore(MemoryStore):
    """Keeps the segments in order so they can be joined into one session."""

    def __init__(self):
        super().__init__()
        self.segments = []

    def append_hold(self, step, **kw):
        super().append_hold(step, **kw)
        self.segments.append(("hold", step, kw))

    def append_move(self, step, **kw):
        super().append_move(step, **kw)
        self.segments.append(("move", step, kw))


def recorded_session(effects, tmp_path):
    from rig.session_data import SessionData

    config = load_config()
    with build_sim(config, seed=11, effects=effects) as rig:
        rig.board.start()
        store = RowStore()
        record(rig, store, plan_for(config))
    parts = store.segments
    cat = lambda key: np.concatenate([kw[key] for _, _, kw in parts])  # noqa: E731
    session = SessionData(
        t=cat("t"), is_move=np.concatenate([np.full(kw["t"].size, ph == "move") for ph, _, kw in parts]),
        step=np.concatenate([np.full(kw["t"].size, j) for _, j, kw in parts]), q_ref=cat("q_ref"),
        raw={n: np.concatenate([kw["samples"][n] for _, _, kw in parts]) for n in ("accel", "gyro", "mag")},
        columns={"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"], "mag": ["mx", "my", "mz"]},
        gravity=G0, field_uT=50.0, sample_rate_hz=100.0, table_deg=cat("table_deg"), temp_c=cat("temp_c"),
        vsupply_v=cat("vsupply_v"))
    write_session(session, tmp_path / "s")
    return read_session(tmp_path / "s")


def test_clean_rig_session_has_no_finding(tmp_path):
    report = analyze(recorded_session([], tmp_path))
    assert report["findings"] == []


def test_hidden_g_sensitivity_in_a_rig_session_is_named_and_sized(tmp_path):
    Gs = np.zeros((3, 3))
    Gs[0, 2] = np.radians(0.08) / G0          # 0.08 deg/s per g on x from specific force along z
    report = analyze(recorded_session([GyroGSensitivity("gyro", Gs=Gs)], tmp_path))
    found = report["findings"]
    assert [(f["effect"], f["sensor"]) for f in found] == [("gyro_g_sensitivity", "gyro")]
    assert abs(found[0]["magnitude"] - 0.08) < 0.25 * 0.08
    assert found[0]["heldout_rms_after"] < found[0]["heldout_rms_before"]
