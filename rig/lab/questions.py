"""Questions no single session answers, asked of either store: a unit's history with its drift, the same
(golden) unit on every rig, pass/fail by day and rig.

A session may hold several calibrations: the rig's own and batch re-calibrations beside it. A question reads one
source (the rig's own unless asked otherwise, `records.pick_source`); the others are carried beside it.

Drift and rig-to-rig differences are judged against the uncertainties the calibrations carry (B_std,
H_std). A change of a vector or matrix is one test over its components: the sum of their squared z-scores is
chi-square with as many degrees of freedom, and its p-value is said as the equivalent number of standard
deviations of one normal variable (`sigma`), so a change is flagged when it exceeds `Z_FLAG` sigma without
the false alarms of taking the largest of nine z-scores. The largest component's z is given beside it.

A rig's own sessions are judged the same way: their scatter against the uncertainties they state (chi-square of
the deviations from their inverse-variance mean), and against the other rigs' scatter (an F test), so that a rig
that disagrees with itself is named rather than hidden behind the large uncertainty of its mean.

Why 4 and not 3 sigma: a sensor's components are correlated and a calibration makes six such tests (B and H
of three sensors). Re-measuring one simulated unit (12 orientations, 1 s holds) with nothing changed, 3 sigma
flagged 3 of 33 consecutive pairs; 4 sigma flagged none of 66 (33 of them with 20 orientations, 2 s holds).

A rig is said to disagree with itself only when its scatter is also `SCATTER_RATIO_MIN` times what its stated
uncertainties allow, and that many times the other rigs' relative scatter: a fault the model does not describe
(a field the table carries, which turns with the inner axis) makes a calibration's stated uncertainty somewhat
too small, so its sessions scatter up to about twice it with nothing changing between them; a loose holder or a
moving magnet scatters many times it.
"""

from __future__ import annotations

from collections import defaultdict
from itertools import combinations

import numpy as np
from scipy.stats import chi2, norm
from scipy.stats import f as f_dist

from rig.lab.records import RIG_SOURCE, STATUSES, CalibrationRecord, Filters, iso, pick_source

Z_FLAG = 4.0
SCATTER_RATIO_MIN = 3.0
HISTORY_SCHEMA = "rig-unit-history/1"


def history(store, serial: str, source: str = RIG_SOURCE) -> dict:
    """Every calibration of `serial` from `source` (the rig's own by default; see `records.pick_source`), oldest
    first, one per session, each compared with the one before it; the session's other calibrations (a batch
    re-calibration beside the rig's own, or the rig's own beside a batch one) are carried with it (`beside`), each
    with its verdict and its difference from this one, never in its place."""
    entries, previous = [], None
    for records in _per_session(store.calibrations(unit=serial)):
        record = pick_source(records, source)
        if record is None:
            continue
        sensors = record.sensors()
        entry = {"session": record.session, "key": record.key, "started_utc": iso(record.started), "rig": record.rig,
                 "status": record.status, "source": record.source, "verdict": record.verdict, "sensors": sensors,
                 "beside": [_beside(sensors, other) for other in records if other is not record],
                 "table": record.table}
        if previous is not None:
            entry["drift"] = {name: drift(previous[name], cal) for name, cal in sensors.items() if name in previous}
        entries.append(entry)
        previous = sensors
    drifted = [{"session": e["session"], "sensor": s, **d} for e in entries for s, d in e.get("drift", {}).items()
               if d["flagged"]]
    return {"schema": HISTORY_SCHEMA, "unit": serial, "source": source, "calibrations": entries, "z_flag": Z_FLAG,
            "drifted": drifted}


def _per_session(records: list[CalibrationRecord]) -> list[list[CalibrationRecord]]:
    """The records grouped by session, in the order the store gave them (oldest session first)."""
    groups: dict[str, list[CalibrationRecord]] = {}
    for record in records:
        groups.setdefault(record.key, []).append(record)
    return list(groups.values())


def _beside(sensors: dict, other: CalibrationRecord) -> dict:
    theirs = other.sensors()
    return {"source": other.source, "verdict": other.verdict, "sensors": theirs,
            "change": {name: drift(cal, theirs[name]) for name, cal in sensors.items() if name in theirs}}


def change(shown: CalibrationRecord, other: CalibrationRecord) -> dict:
    """Per sensor both calibrations have, how `other` differs from `shown` in sigma (`drift`)."""
    return _beside(shown.sensors(), other)["change"]


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
    return _sigma(chi2.logsf(float(np.sum(z ** 2)), int(ok.sum()))), float(z.max())


def _sigma(log_p: float) -> float:
    """A p-value (as its logarithm) as the two-sided deviation of one normal variable, never below 0."""
    if log_p <= -700:
        return 38.0
    return max(0.0, float(-norm.ppf(min(1.0, np.exp(log_p)) / 2)))


# -- the golden unit on every rig ------------------------------------------------------------------
def compare_rigs(store, unit: str, source: str = RIG_SOURCE) -> dict:
    """Per rig, the unit's mean B and H per sensor with their uncertainty, and how much its sessions scatter;
    every pair of rigs compared (differences, their uncertainty, the rotation between the sensor frames).

    A rig whose sessions scatter beyond what their own stated uncertainties allow, and beyond the other rigs'
    scatter, disagrees with itself: it is named, and its mean is compared with nobody (nor used to judge the
    others). Among the rigs that agree with themselves, one that differs from most of the others is named with
    the likely cause: a table whose axes are misaligned rotates the accelerometer's and the gyroscope's frames
    alike; a magnetic field on the table moves the magnetometer's offset alone. Two rigs that differ cannot say
    which one is off: both are named, and a third rig settles it."""
    by_rig: dict[str, list[CalibrationRecord]] = defaultdict(list)
    for records in _per_session(store.calibrations(unit=unit)):
        record = pick_source(records, source)
        if record is not None:
            by_rig[record.rig].append(record)
    rigs = {rig: _rig_mean(records) for rig, records in sorted(by_rig.items())}
    spread = {rig: _scatter(by_rig[rig]) for rig in rigs}
    findings = _self_disagreement(spread)
    unsteady = {f["rig"] for f in findings}
    pairs = {}
    for a, b in combinations(rigs, 2):
        pairs[(a, b)] = {s: _difference(rigs[a][s], rigs[b][s]) for s in rigs[a] if s in rigs[b]}
    steady = [rig for rig in rigs if rig not in unsteady]
    against = {rig: {o: pairs[(rig, o)] if (rig, o) in pairs else _reversed(pairs[(o, rig)])
                     for o in steady if o != rig} for rig in steady}
    causes = {rig: _causes(rig, against[rig]) for rig in steady}
    named = {rig for rig, (found, _) in causes.items() if found}
    differing = []
    for rig in steady:           # what else sets it apart, judged against the rigs no cause was found on
        found, explained = causes[rig]
        differing += found + _other_differences(rig, {o: d for o, d in against[rig].items() if o not in named},
                                                explained)
    if len(steady) == 2 and differing:
        a, b = steady
        differing = [{"rig": f"{a} / {b}", "cause": f["cause"], "sensors": f["sensors"],
                      "text": f["text"].replace(f"rig {a}:", f"rigs {a} and {b} differ:", 1)
                      + "; with two rigs it cannot be told which one is off (calibrate the unit on a third)"}
                     for f in differing if f["rig"] == a]
    return {"schema": "rig-compare-rigs/1", "unit": unit, "source": source, "z_flag": Z_FLAG,
            "rigs": [{"rig": rig, "sessions": len(by_rig[rig]), "sensors": _plain(rigs[rig]),
                      "scatter": _plain(spread[rig]), "compared": rig not in unsteady} for rig in rigs],
            "differences": [{"rigs": [a, b], "sensors": _plain(d)} for (a, b), d in pairs.items()],
            "findings": findings + differing}


def _scatter(records: list[CalibrationRecord]) -> dict:
    """Per sensor, for B and H: how the rig's sessions scatter against their own stated uncertainties. With the
    inverse-variance mean m of each element, chi2 = sum over sessions and elements of ((x - m) / std)^2 has
    (sessions - 1) x elements degrees of freedom if the stated deviations are right; `ratio` = sqrt(chi2 / dof) is
    how many times larger the scatter is than they allow, `sigma` the test as normal sigma (see `sigma_of`). The
    element that scatters most is named with its spread (sample deviation) and its stated deviation (RMS)."""
    per: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    units: dict[str, str] = {}
    for record in records:
        for name, cal in record.sensors().items():
            units.setdefault(name, str(cal.get("unit") or "unit"))
            for k in ("B", "H"):
                if cal.get(k) is not None and cal.get(f"{k}_std") is not None:
                    per[name][k].append((np.asarray(cal[k], dtype=float), np.asarray(cal[f"{k}_std"], dtype=float)))
    out: dict[str, dict] = {}
    for name, quantities in per.items():
        for k, pairs in quantities.items():
            if len(pairs) < 2 or len({x.shape for x, _ in pairs} | {s.shape for _, s in pairs}) != 1:
                continue
            x = np.array([v for v, _ in pairs])
            u = np.array([s for _, s in pairs])
            ok = np.all(np.isfinite(x) & np.isfinite(u) & (u > 0), axis=0)
            if not ok.any():
                continue
            x, u = x[:, ok], u[:, ok]
            w = 1.0 / u ** 2
            mean = np.sum(w * x, axis=0) / np.sum(w, axis=0)
            terms = ((x - mean) / u) ** 2
            chi, dof = float(terms.sum()), int(terms.size - terms.shape[1])
            worst = int(np.argmax(terms.sum(axis=0)))
            element = np.flatnonzero(ok)[worst]
            index = f"[{element}]" if ok.size == 3 else f"[{element // 3},{element % 3}]"
            out.setdefault(name, {})[k] = {
                "sessions": len(pairs), "chi2": chi, "dof": dof, "ratio": float(np.sqrt(chi / dof)),
                "sigma": _sigma(chi2.logsf(chi, dof)), "element": f"{k}{index}",
                "element_unit": "counts" if k == "B" else f"{units[name]}/count",
                "element_spread": float(np.std(x[:, worst], ddof=1)),
                "element_stated": float(np.sqrt(np.mean(u[:, worst] ** 2)))}
    return out


def _self_disagreement(spread: dict[str, dict]) -> list[dict]:
    """The rigs that disagree with themselves: for some sensor's B or H, their scatter exceeds what their sessions'
    stated uncertainties allow by more than `Z_FLAG` sigma, and (where other rigs calibrated the unit more than
    once) exceeds the other rigs' scatter, relative to theirs, by more than `Z_FLAG` sigma (an F test): when every
    rig scatters alike, the stated uncertainties are too small, not one rig unsteady. Both excesses must also be
    `SCATTER_RATIO_MIN` times or more (see the module's docstring)."""
    found = []
    for rig, sensors in spread.items():
        hits = []
        for sensor, quantities in sensors.items():
            for k, mine in quantities.items():
                others = [spread[o][sensor][k] for o in spread if o != rig and k in spread[o].get(sensor, {})]
                chi_o, dof_o = sum(o["chi2"] for o in others), sum(o["dof"] for o in others)
                against = None
                if dof_o:
                    ratio_o = float(np.sqrt(chi_o / dof_o))
                    F = (mine["chi2"] / mine["dof"]) / max(chi_o / dof_o, 1e-300)
                    against = {"ratio": ratio_o, "sigma": _sigma(f_dist.logsf(F, mine["dof"], dof_o))}
                mine["against_others"] = against
                relative = mine["ratio"] / against["ratio"] if against and against["ratio"] > 0 else mine["ratio"]
                if (mine["sigma"] > Z_FLAG and mine["ratio"] >= SCATTER_RATIO_MIN and relative >= SCATTER_RATIO_MIN
                        and (against is None or against["sigma"] > Z_FLAG)):
                    hits.append((sensor, k, mine))
        if not hits:
            continue
        sensors_hit = sorted({s for s, _, _ in hits})
        parts = []
        for sensor, k, m in hits:
            other = m["against_others"]
            parts.append(f"{sensor} {k} scatters {m['ratio']:.3g} times what its sessions' stated uncertainties "
                         f"allow ({m['element']}: {m['element_spread']:.3g} {m['element_unit']} from session to "
                         f"session against a stated {m['element_stated']:.2g})"
                         + (f", the other rigs' {other['ratio']:.3g} times" if other else ""))
        inertial = {(s, k) for s, k, _ in hits if s in ("accel", "gyro")}
        if inertial and all(k == "H" for _, k in inertial):
            cause = "the unit does not sit alike in every session (a loose holder or fixture)"
        elif sensors_hit == ["mag"]:
            cause = "its magnetic surroundings change from session to session (a tool or a magnet moved near it)"
        else:
            cause = "something on it changes from session to session"
        n = max(m["sessions"] for _, _, m in hits)
        found.append({"rig": rig, "cause": "inconsistent", "sensors": sensors_hit,
                      "text": f"rig {rig} disagrees with itself over its {n} sessions: " + "; ".join(parts)
                              + f" (> {Z_FLAG:g} sigma): {cause}; its mean is compared with no other rig"})
    return found


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


def _big(diffs: dict, sensor: str, key: str) -> bool:
    z = diffs.get(sensor, {}).get(key)
    return z is not None and z > Z_FLAG


def _most(against: dict[str, dict], test) -> list[str]:
    """The other rigs `test` holds against, when they are more than half of them (all of them when one)."""
    hits = [o for o, diffs in against.items() if test(diffs)]
    return hits if against and len(hits) * 2 > len(against) else []


def _causes(rig: str, against: dict[str, dict]) -> tuple[list[dict], set[str]]:
    """The known signatures that set `rig` apart from more than half of the other rigs, and the sensors they
    explain: frames rotated alike (a misaligned table) and the magnetometer's offset alone (its magnetic
    environment)."""
    found, explained = [], set()
    inertial = sorted({s for d in against.values() for s in d if s in ("accel", "gyro")})
    rotated = _most(against, lambda d: inertial and all(_big(d, s, "rotation_z") for s in inertial))
    if rotated:
        angle = np.mean([max(float(np.linalg.norm(against[o][s]["rotation_deg"])) for s in inertial) for o in rotated])
        explained |= {s for o in rotated for s, d in against[o].items() if _big(against[o], s, "rotation_z")}
        found.append({"rig": rig, "cause": "table_misalignment", "sensors": inertial, "against": rotated,
                      "text": f"rig {rig}: the {' and '.join(inertial)} frames are rotated by about {angle:.3g} deg "
                              f"against rig {', '.join(rotated)} (> {Z_FLAG:g} sigma): its table's axes are misaligned "
                              "(or its fixture holds the unit differently)"})

    def magnetic(d) -> bool:
        inertial_agree = not any(_big(d, s, k) for s in inertial for k in ("B_z", "H_z", "rotation_z"))
        return "mag" in d and _big(d, "mag", "B_z") and inertial_agree

    shifted = _most(against, magnetic)
    if shifted:
        dB = np.mean([against[o]["mag"]["dB"] for o in shifted], axis=0)
        explained.add("mag")
        found.append({"rig": rig, "cause": "magnetic_environment", "sensors": ["mag"], "against": shifted,
                      "text": f"rig {rig}: the magnetometer's offset differs by {np.array2string(dB, precision=3)} "
                              f"counts against rig {', '.join(shifted)} (> {Z_FLAG:g} sigma) while its accelerometer "
                              "and gyroscope agree: a different magnetic environment (a field carried by its table, "
                              "a magnetised part near the unit)"})
    return found, explained


def _other_differences(rig: str, against: dict[str, dict], explained: set[str]) -> list[dict]:
    """A sensor of `rig` not explained by a known cause that differs from more than half of `against` (the rigs
    no cause was found on: a difference from a misaligned table's rig says nothing of this one)."""
    found = []
    for sensor in sorted({s for d in against.values() for s in d} - explained):
        hits = _most(against, lambda d: _big(d, sensor, "B_z") or _big(d, sensor, "H_z"))
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
