"""Questions no single session answers, asked of either store: a unit's history with its drift, the same
(golden) unit on every rig, pass/fail by day and rig.

Drift and rig-to-rig differences are judged against the uncertainties the calibrations carry (B_std,
H_std). A change of a vector or matrix is one test over its components: the sum of their squared z-scores is
chi-square with as many degrees of freedom, and its p-value is said as the equivalent number of standard
deviations of one normal variable (`sigma`), so a change is flagged when it exceeds `Z_FLAG` sigma without
the false alarms of taking the largest of nine z-scores. The largest component's z is given beside it.

Why 4 and not 3 sigma: a sensor's components are correlated and a calibration makes six such tests (B and H
of three sensors). Re-measuring one simulated unit (12 orientations, 1 s holds) with nothing changed, 3 sigma
flagged 3 of 33 consecutive pairs; 4 sigma flagged none of 66 (33 of them with 20 orientations, 2 s holds).
"""

from __future__ import annotations

from collections import defaultdict
from itertools import combinations

import numpy as np
from scipy.stats import chi2, norm

from rig.lab.records import STATUSES, CalibrationRecord, Filters, iso

Z_FLAG = 4.0
HISTORY_SCHEMA = "rig-unit-history/1"


def history(store, serial: str) -> dict:
    """Every calibration of `serial`, oldest first, one per session, each compared with the one before it."""
    entries, previous = [], None
    for record in store.calibrations(unit=serial):
        sensors = record.sensors()
        entry = {"session": record.session, "key": record.key, "started_utc": iso(record.started), "rig": record.rig,
                 "status": record.status, "source": record.source, "sensors": sensors}
        if previous is not None:
            entry["drift"] = {name: drift(previous[name], cal) for name, cal in sensors.items() if name in previous}
        entries.append(entry)
        previous = sensors
    drifted = [{"session": e["session"], "sensor": s, **d} for e in entries for s, d in e.get("drift", {}).items()
               if d["flagged"]]
    return {"schema": HISTORY_SCHEMA, "unit": serial, "calibrations": entries, "z_flag": Z_FLAG, "drifted": drifted}


def drift(before: dict, after: dict) -> dict:
    """The change of B and of H between two calibrations of one sensor, in sigma (see the module doc)."""
    out = {}
    for name in ("B", "H"):
        values = [before.get(name), before.get(f"{name}_std"), after.get(name), after.get(f"{name}_std")]
        z = zmax = None
        if all(v is not None for v in values):
            a, sa, b, sb = (np.asarray(v, dtype=float) for v in values)
            if a.shape == b.shape == sa.shape == sb.shape:
                z, zmax = sigma_of(b - a, np.hypot(sa, sb))
        out[f"{name}_z"], out[f"{name}_max_z"] = z, zmax
    known = [out[k] for k in ("B_z", "H_z") if out[k] is not None]
    out["flagged"] = bool(known) and max(known) > Z_FLAG
    return out


def sigma_of(d: np.ndarray, u: np.ndarray) -> tuple[float | None, float | None]:
    """(the chi-square test of all components as normal sigma, the largest component's |z|)."""
    d, u = np.ravel(d), np.ravel(u)
    ok = np.isfinite(d) & np.isfinite(u) & (u > 0)
    if not ok.any():
        return None, None
    z = np.abs(d[ok]) / u[ok]
    log_p = chi2.logsf(float(np.sum(z ** 2)), int(ok.sum()))
    return float(-norm.ppf(np.exp(log_p) / 2) if log_p > -700 else 38.0), float(z.max())


# -- the golden unit on every rig ------------------------------------------------------------------
def compare_rigs(store, unit: str) -> dict:
    """Per rig, the unit's mean B and H per sensor with their uncertainty; every pair of rigs compared
    (differences, their uncertainty, the rotation between the sensor frames); a rig that differs from most of
    the others is named with the likely cause: a table whose axes are misaligned rotates the accelerometer's
    and the gyroscope's frames alike; a magnetic field on the table moves the magnetometer's offset alone.
    Two rigs that differ cannot say which one is off: both are named, and a third rig settles it."""
    by_rig: dict[str, list[CalibrationRecord]] = defaultdict(list)
    for record in store.calibrations(unit=unit):
        by_rig[record.rig].append(record)
    rigs = {rig: _rig_mean(records) for rig, records in sorted(by_rig.items())}
    pairs = {}
    for a, b in combinations(rigs, 2):
        pairs[(a, b)] = {s: _difference(rigs[a][s], rigs[b][s]) for s in rigs[a] if s in rigs[b]}
    findings = []
    for rig in rigs:
        others = [r for r in rigs if r != rig]
        against = {o: pairs[(rig, o)] if (rig, o) in pairs else _reversed(pairs[(o, rig)]) for o in others}
        findings += _findings(rig, against)
    if len(rigs) == 2 and findings:
        a, b = rigs
        findings = [{"rig": f"{a} / {b}", "cause": f["cause"], "sensors": f["sensors"],
                     "text": f["text"].replace(f"rig {a}:", f"rigs {a} and {b} differ:", 1)
                     + "; with two rigs it cannot be told which one is off (calibrate the unit on a third)"}
                    for f in findings if f["rig"] == a]
    return {"schema": "rig-compare-rigs/1", "unit": unit, "z_flag": Z_FLAG,
            "rigs": [{"rig": rig, "sessions": len(by_rig[rig]), "sensors": _plain(rigs[rig])} for rig in rigs],
            "differences": [{"rigs": [a, b], "sensors": _plain(d)} for (a, b), d in pairs.items()],
            "findings": findings}


def _reversed(diffs: dict) -> dict:
    return {s: {k: (-v if k.startswith(("dB", "dH", "rotation_deg")) and not k.endswith("_u") else v)
                for k, v in d.items()} for s, d in diffs.items()}


def _rig_mean(records: list[CalibrationRecord]) -> dict:
    """Per sensor: the mean B and H of the sessions and the uncertainty of that mean (the sessions' own
    uncertainty and their scatter, whichever is larger)."""
    per: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    for record in records:
        for name, cal in record.sensors().items():
            for k in ("B", "H", "B_std", "H_std"):
                if cal.get(k) is not None:
                    per[name][k].append(np.asarray(cal[k], dtype=float))
    out = {}
    for name, values in per.items():
        entry = {"n": len(values["B"])}
        for k in ("B", "H"):
            stack = np.array(values[k])
            n = len(stack)
            own = np.sqrt(np.mean(np.array(values[f"{k}_std"]) ** 2, axis=0) / n) if len(values[f"{k}_std"]) == n \
                else np.zeros_like(stack[0])
            scatter = stack.std(axis=0, ddof=1) / np.sqrt(n) if n > 1 else np.zeros_like(stack[0])
            entry[k], entry[f"{k}_u"] = stack.mean(axis=0), np.maximum(own, scatter)
        out[name] = entry
    return out


def _difference(mine: dict, ref: dict) -> dict:
    dB, uB = mine["B"] - ref["B"], np.hypot(mine["B_u"], ref["B_u"])
    dH, uH = mine["H"] - ref["H"], np.hypot(mine["H_u"], ref["H_u"])
    # E = H_mine H_ref^-1 - I; its antisymmetric part is the rotation between the two sensor frames
    inv = np.linalg.inv(ref["H"])
    E = mine["H"] @ inv - np.eye(3)
    uE = np.sqrt((uH ** 2) @ (inv ** 2))
    pairs = ((2, 1), (0, 2), (1, 0))
    rot = np.array([(E[i, j] - E[j, i]) / 2 for i, j in pairs])
    rot_u = np.array([np.hypot(uE[i, j], uE[j, i]) / 2 for i, j in pairs])
    return {"dB": dB, "dB_u": uB, "B_z": sigma_of(dB, uB)[0], "dH": dH, "dH_u": uH, "H_z": sigma_of(dH, uH)[0],
            "rotation_deg": np.degrees(rot), "rotation_deg_u": np.degrees(rot_u), "rotation_z": sigma_of(rot, rot_u)[0]}


def _findings(rig: str, against: dict[str, dict]) -> list[dict]:
    """What sets `rig` apart: a signature seen against more than half of the other rigs (all of them when
    there is one other)."""
    def big(diffs, sensor, key):
        z = diffs.get(sensor, {}).get(key)
        return z is not None and z > Z_FLAG

    def most(test) -> list[str]:
        hits = [o for o, diffs in against.items() if test(diffs)]
        return hits if against and len(hits) * 2 > len(against) else []

    found, explained = [], set()
    inertial = sorted({s for d in against.values() for s in d if s in ("accel", "gyro")})
    rotated = most(lambda d: inertial and all(big(d, s, "rotation_z") for s in inertial))
    if rotated:
        angle = np.mean([max(float(np.linalg.norm(against[o][s]["rotation_deg"])) for s in inertial) for o in rotated])
        explained |= {s for o in rotated for s, d in against[o].items() if big(against[o], s, "rotation_z")}
        found.append({"rig": rig, "cause": "table_misalignment", "sensors": inertial, "against": rotated,
                      "text": f"rig {rig}: the {' and '.join(inertial)} frames are rotated by about {angle:.3g} deg "
                              f"against rig {', '.join(rotated)} (> {Z_FLAG:g} sigma): its table's axes are misaligned "
                              "(or its fixture holds the unit differently)"})

    def magnetic(d) -> bool:
        inertial_agree = not any(big(d, s, k) for s in inertial for k in ("B_z", "H_z", "rotation_z"))
        return "mag" in d and big(d, "mag", "B_z") and inertial_agree

    shifted = most(magnetic)
    if shifted:
        dB = np.mean([against[o]["mag"]["dB"] for o in shifted], axis=0)
        explained.add("mag")
        found.append({"rig": rig, "cause": "magnetic_environment", "sensors": ["mag"], "against": shifted,
                      "text": f"rig {rig}: the magnetometer's offset differs by {np.array2string(dB, precision=3)} "
                              f"counts against rig {', '.join(shifted)} (> {Z_FLAG:g} sigma) while its accelerometer "
                              "and gyroscope agree: a different magnetic environment (a field carried by its table, "
                              "a magnetised part near the unit)"})
    sensors = sorted({s for d in against.values() for s in d} - explained)
    for sensor in sensors:
        hits = most(lambda d: big(d, sensor, "B_z") or big(d, sensor, "H_z"))
        if hits:
            z = max(max(against[o][sensor]["B_z"] or 0, against[o][sensor]["H_z"] or 0) for o in hits)
            found.append({"rig": rig, "cause": "differs", "sensors": [sensor], "against": hits,
                          "text": f"rig {rig}: {sensor} differs from rig {', '.join(hits)} (z up to {z:.3g})"})
    return found


def _plain(value):
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


# -- pass/fail by day and rig ----------------------------------------------------------------------
def pass_fail(store, filters: Filters) -> dict:
    """Sessions per day and rig by status; `passed` is the share of finished ones (complete / complete +
    rejected) — a session that failed or was aborted has no verdict."""
    table: dict[tuple, dict] = {}
    for day, rig, status, n in store.pass_fail(filters):
        row = table.setdefault((day, rig), {"day": day.isoformat(), "rig": rig, **{s: 0 for s in STATUSES}})
        row[status] = row.get(status, 0) + int(n)
    rows = []
    for row in table.values():
        finished = row["complete"] + row["rejected"]
        row["passed"] = row["complete"] / finished if finished else None
        rows.append(row)
    return {"schema": "rig-pass-fail/1", "filters": filters.as_query(), "rows": rows}
