"""Re-analysing an archive on Dask distributed: `rig batch calibrate|discrepancy --store URL --where ...`.

Each task gets the store's address and a session key, reads the session itself on the worker (so the data
never travels through the scheduler), runs the project's own analysis (`rig.pipeline.calibrate_session`, judged
by the limits the session's rig was configured with; `rig.discrepancy.analyze`) and returns a small JSON result;
the client writes the results back to the store as they arrive, under one run id. A re-calibration is stored
beside the rig's own, never over it. A session that cannot be analysed is a result too (ok = false, the
reason), never a crash of the batch. A LocalCluster is started unless a scheduler address is given.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import math
import signal
import tempfile
import threading
import time
import warnings
from dataclasses import asdict
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from rig.discrepancy import analyze
from rig.lab.stores import open_store
from rig.pipeline import calibrate_session
from rig.pipeline.writing import write_session_calibration
from rig.report.calibration_report import evaluate

KINDS = ("calibrate", "discrepancy")
CHUNK_MAX = 16                 # sessions per task at most
_STORES: dict[str, object] = {}


def run_id() -> str:
    """A run's id: its start time in UTC to the millisecond (sorts in time order)."""
    return datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S%f")[:-3] + "Z"


def analyse_one(store_url: str, key: str, kind: str, options: dict) -> dict:
    """On a worker: one session's analysis as {key, ok, document (JSON), calibration (JSON or None), summary}."""
    t0 = time.perf_counter()
    try:
        store = _STORES.get(store_url)
        if store is None:
            store = _STORES[store_url] = open_store(store_url)
        session = store.session_data(key)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            if kind == "calibrate":
                document, calibration, summary = _calibrate(session, options)
            else:
                document, calibration, summary = _discrepancy(session, options)
        ok, error = True, None
    except Exception as exc:           # the session's problem, reported as its result
        document, calibration, ok = json.dumps({"error": f"{type(exc).__name__}: {exc}"}), None, False
        summary = error = f"{type(exc).__name__}: {exc}"
    verdict = json.loads(document).get("verdict") if ok else None
    return {"key": key, "ok": ok, "document": document, "calibration": calibration, "summary": summary,
            "error": error, "verdict": verdict, "seconds": time.perf_counter() - t0}


def analyse_many(store_url: str, keys: list[str], kind: str, options: dict) -> list[dict]:
    """On a worker: a chunk of sessions (fewer, larger tasks keep the scheduler out of the way)."""
    return [analyse_one(store_url, key, kind, options) for key in keys]


def _calibrate(session, options: dict) -> tuple[str, str, str]:
    """The session calibrated again and judged by the limits its rig was configured with (as the rig judged it,
    `procedures.orchestrator`): the calibration file carries its verdict, the result its checks."""
    method = options.get("method", "joint")
    result = calibrate_session(session, method=method, settle_s=0.0)
    unit = session.meta.get("unit") or {}
    limits = (session.meta.get("config") or {}).get("limits")
    evaluation = evaluate(session, result.sensors, gravity=session.gravity, field_uT=session.field_uT, limits=limits)
    verdict = evaluation.verdict
    with tempfile.TemporaryDirectory(prefix="rig-batch-") as out:
        path = write_session_calibration(out, result, gravity=session.gravity, field_uT=session.field_uT,
                                         unit_serial=unit.get("serial"), board=unit.get("board"),
                                         extra={"source": {"batch": True, "method": method,
                                                           "session": session.source}, "verdict": verdict},
                                         session=session)
        calibration = Path(path).read_text()
    summary = f"verdict {verdict}: " + "; ".join(line for line in result.summary if not line.startswith(" "))
    doc = {"summary": summary, "verdict": verdict, "failing": evaluation.failing(),
           "checks": [asdict(c) for c in evaluation.checks], "warnings": result.warnings, "method": method}
    return json.dumps(_finite(doc)), calibration, summary


def _discrepancy(session, options: dict) -> tuple[str, None, str]:
    session.meta = {k: v for k, v in session.meta.items() if k != "truth"}    # the analysis runs blind
    report = analyze(session, replay=options.get("replay"))
    findings = report.get("findings") or []
    names = [f"{f.get('effect')} ({f.get('sensor')})" for f in findings]
    report["summary"] = "findings: " + (", ".join(names) if names else "none")
    return json.dumps(_finite(report)), None, report["summary"]


def _finite(value):
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, np.ndarray):
        return _finite(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


@contextlib.contextmanager
def ctrl_c_left_to_this_process():
    """Processes started here ignore SIGINT (the disposition survives their exec, and Python then installs no
    KeyboardInterrupt of its own): Ctrl-C reaches the whole process group, and each Dask worker that took it
    printed its traceback on the user's terminal. This process stops and closes the cluster itself. The price: a
    Ctrl-C in the second the cluster takes to start is not seen (a blocked signal would be held, not lost, but
    the workers do not keep a mask)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def run_batch(store, store_url: str, kind: str, keys: list[str], *, scheduler: str | None = None,
              workers: int | None = None, options: dict | None = None, echo=print) -> dict:
    """Run `kind` over `keys` on Dask and save every result to `store`; a summary of the run."""
    from dask.distributed import Client, LocalCluster, as_completed

    options = options or {}
    run = run_id()
    logging.getLogger("distributed").setLevel(logging.CRITICAL)
    cluster = None
    if scheduler:
        client = Client(scheduler, timeout="10s")
    else:
        with ctrl_c_left_to_this_process():
            cluster = LocalCluster(n_workers=workers or 2, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.CRITICAL)
        client = Client(cluster)
    try:
        n_workers = len(client.scheduler_info()["workers"])
        plural = "s" if n_workers != 1 else ""
        echo(f"{kind}: {len(keys)} sessions on {n_workers} Dask worker{plural} ({scheduler or 'a local cluster'}), "
             f"run {run}")
        client.run(_warm)                      # imports done before the clock starts
        t0 = time.perf_counter()
        size = max(1, min(CHUNK_MAX, len(keys) // (n_workers * 8)))
        chunks = [keys[i:i + size] for i in range(0, len(keys), size)]
        futures = client.map(analyse_many, [store_url] * len(chunks), chunks, kind=kind, options=options, pure=False)
        chunk_of = {f.key: c for f, c in zip(futures, chunks)}
        failed, done, verdicts = [], 0, {}
        for future in as_completed(futures):
            try:
                results = future.result()
            except Exception as exc:            # a worker died: its sessions are named, the rest go on
                results = [{"key": key, "ok": False, "calibration": None, "error": f"worker lost: {exc}",
                            "document": json.dumps({"error": f"worker lost: {exc}"})} for key in chunk_of[future.key]]
            for result in results:
                store.save_result(result["key"], kind, run, result["ok"], result["document"], result["calibration"],
                                  _digest(result["calibration"]))
                done += 1
                if not result["ok"]:
                    failed.append({"session": result["key"], "error": result["error"]})
                elif result.get("verdict"):
                    verdicts.setdefault(result["verdict"], []).append(result["key"])
        seconds = time.perf_counter() - t0
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return {"schema": "rig-batch/1", "kind": kind, "run": run, "sessions": len(keys), "ok": done - len(failed),
            "failed": failed, "verdicts": {v: len(k) for v, k in sorted(verdicts.items())},
            "verdict_fail": verdicts.get("FAIL", []), "workers": n_workers, "seconds": seconds,
            "sessions_per_s": len(keys) / seconds if seconds > 0 else None}


def _warm() -> None:
    """Run on every worker before the clock starts: this module (and so the analysis) imported there."""


def _digest(text: str | None) -> str | None:
    if text is None:
        return None
    return hashlib.sha256(text.encode()).hexdigest()
