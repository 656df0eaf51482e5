"""`rig export`: a stored session written to the interchange layout reads back cell for cell."""

from __future__ import annotations

import numpy as np
from synthetic_holds import hold_arrays, move_arrays

from rig.io.session_csv import read_session
from rig.io.session_writer import write_session
from rig.store import SessionStore


def test_store_to_interchange_and_back(tmp_path):
    store = SessionStore.create(tmp_path / "s", {"gravity_mps2": 9.81, "field_uT": 48.0, "operator": "ana"})
    for step in range(3):
        store.append_hold(step, **hold_arrays(step))
        if step < 2:
            store.append_move(step, **move_arrays(step))
    store.append_hold(2, **hold_arrays(2, attempt=2))
    stored = store.to_session_data()
    store.close()

    back = read_session(write_session(stored, tmp_path / "export"))
    np.testing.assert_array_equal(back.t, stored.t)
    np.testing.assert_array_equal(back.step, stored.step)
    np.testing.assert_array_equal(back.is_move, stored.is_move)
    for sensor in ("accel", "gyro", "mag"):
        np.testing.assert_array_equal(back.raw[sensor], stored.raw[sensor])
    np.testing.assert_allclose(back.q_ref, stored.q_ref, rtol=0, atol=1e-15)
    assert (back.gravity, back.field_uT, back.meta["operator"]) == (9.81, 48.0, "ana")
