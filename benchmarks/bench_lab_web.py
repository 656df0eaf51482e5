"""The lab's web page: first view of a store of 10 000 sessions (target <= 1 s) and how soon a hold of a
running session is visible (target <= 2 s after the rig commits it). Prints JSON.

- A PostgreSQL server (Debian's package) started here; 10 000 synthetic session rows (500 units, 8 rigs, a
  year of start times, every status, 5 of them running) inserted directly with SQL into the lab's tables.
  `rig serve` runs on it; times: the server's answer to GET / (to the last byte, first and median of 10),
  and headless Chromium's first view (a fresh profile: navigation start to the load event, as the browser's
  Navigation Timing reports it), first and median of 5 fresh tabs.
- A real session: `rig calibrate --sim --time-scale 20` in its own process, `live_mirror` beside it, `rig
  serve` and Chromium on the session's page reading the counter every 50 ms; for every hold after the page
  opened, the delay from the hold's commit in the session file to the counter showing it.

Usage: python benchmarks/bench_lab_web.py [--sessions 10000]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from datetime import datetime, timezone
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from selenium.webdriver.common.by import By  # noqa: E402

from rig.lab.mirror import live_mirror  # noqa: E402
from rig.lab.pg import connect  # noqa: E402
from tests.lab.browser import start_browser, stop_browser  # noqa: E402
from tests.lab.conftest import Served  # noqa: E402
from tests.lab.pgserver import PgServer  # noqa: E402

RIG = [sys.executable, "-m", "rig.cli"]
SYNTHETIC = """
INSERT INTO rigs (name) SELECT 'rig-' || g FROM generate_series(1, 8) g;
INSERT INTO operators (name) SELECT 'operator-' || g FROM generate_series(1, 10) g;
INSERT INTO units (serial, board) SELECT 'UNIT-' || lpad(g::text, 4, '0'), 'bsn' FROM generate_series(1, 500) g;
INSERT INTO sessions (key, name, unit_id, rig_id, operator_id, host, started_utc, status, verdict, ended_utc,
                      planned, holds, first_hold_utc, last_hold_utc, last_seen_utc)
SELECT md5(g::text)::uuid, 'session-' || lpad(g::text, 5, '0'), 1 + g %% 500, 1 + g %% 8, 1 + g %% 10, 'bench',
       t, s, CASE s WHEN 'complete' THEN 'PASS' WHEN 'rejected' THEN 'FAIL' END,
       CASE WHEN s = 'running' THEN NULL ELSE t + interval '3 minutes' END, 20,
       CASE WHEN s IN ('complete', 'rejected') THEN 20 ELSE g %% 20 END, t, t + interval '2 minutes', t
FROM (SELECT g, timestamptz '2025-11-01' + g * interval '52 minutes' AS t,
             CASE WHEN g > %(n)s - 5 THEN 'running' WHEN g %% 17 = 0 THEN 'rejected' WHEN g %% 41 = 0 THEN 'failed'
                  WHEN g %% 53 = 0 THEN 'aborted' ELSE 'complete' END AS s
      FROM generate_series(1, %(n)s) g) x;
"""


def first_view(server_url: str, sessions: int) -> dict:
    url = server_url
    conn = connect(url)
    with conn.transaction():
        for statement in SYNTHETIC.split(";"):
            if statement.strip():
                conn.execute(statement, {"n": sessions})
    conn.execute("ANALYZE")
    conn.close()
    site = Served(url)
    try:
        http = []
        for _ in range(10):
            t0 = time.perf_counter()
            body = urllib.request.urlopen(site.base + "/", timeout=30).read()
            http.append(time.perf_counter() - t0)
        assert f"{sessions} sessions".encode() in body
        views = []
        for _ in range(5):
            browser = start_browser()
            try:
                browser.get(site.base + "/")
                timing = browser.execute_script(
                    "const t = performance.getEntriesByType('navigation')[0];"
                    "return [t.domContentLoadedEventEnd, t.loadEventEnd];")
                rows = len(browser.find_elements(By.CSS_SELECTOR, "#sessions tbody tr"))
                count = browser.find_element(By.ID, "count").text
            finally:
                stop_browser(browser)
            views.append({"dom_ready_s": timing[0] / 1000, "load_s": timing[1] / 1000, "rows_shown": rows,
                          "count_text": count})
    finally:
        site.stop()
    return {"sessions": sessions, "http_first_s": http[0], "http_median_s": statistics.median(http),
            "browser_first_view_load_s": views[0]["load_s"],
            "browser_median_load_s": statistics.median(v["load_s"] for v in views),
            "browser_first_view_dom_ready_s": views[0]["dom_ready_s"], "rows_shown": views[0]["rows_shown"],
            "count_text": views[0]["count_text"], "target_s": 1.0}


def live(url: str, work: Path) -> dict:
    out = work / "live"
    site = Served(url)
    browser = start_browser()
    seen: list[tuple[int, datetime]] = []
    try:
        with live_mirror(out, url, echo=lambda _: None):
            proc = subprocess.Popen([*RIG, "calibrate", "--sim", "--time-scale", "20", "--out", out, "--no-progress"],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            key = None
            while key is None and proc.poll() is None:
                body = urllib.request.urlopen(site.base + "/?status=running", timeout=10).read().decode()
                found = re.search(r"/session/([0-9a-f-]{36})", body)
                key = found.group(1) if found else None
                time.sleep(0.05)
            browser.get(f"{site.base}/session/{key}")
            opened = datetime.now(timezone.utc)
            end_by = None
            while True:
                text = browser.find_element(By.ID, "progress").text
                m = re.match(r"(\d+) of", text)
                if m and (not seen or int(m.group(1)) != seen[-1][0]):
                    seen.append((int(m.group(1)), datetime.now(timezone.utc)))
                if proc.poll() is not None:
                    end_by = end_by or time.monotonic() + 10
                    if (seen and seen[-1][0] >= 20) or time.monotonic() > end_by:
                        break
                time.sleep(0.05)
            proc.wait()
    finally:
        stop_browser(browser)
        site.stop()
    with sqlite3.connect(f"file:{out}/session.sqlite?mode=ro", uri=True) as db:
        rows = db.execute("SELECT min(written_utc) FROM segment WHERE phase = 'hold' GROUP BY step ORDER BY min(id)"
                          ).fetchall()
    commits = {k + 1: datetime.fromisoformat(w.replace("Z", "+00:00")) for k, (w,) in enumerate(rows)}
    delays = [(when - commits[k]).total_seconds() for k, when in seen if k in commits and commits[k] > opened]
    return {"holds": len(commits), "holds_measured": len(delays), "delay_median_s": statistics.median(delays),
            "delay_max_s": max(delays), "within_2_s": sum(d <= 2.0 for d in delays), "target_s": 2.0,
            "poll_s": {"mirror": 0.2, "page": 0.5, "this_benchmark": 0.05}}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sessions", type=int, default=10_000)
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="rig-lab-web-"))
    os.environ["RIG_LOCK_DIR"] = str(work / "locks")
    server = PgServer()
    server.start()
    out = {"cpu_count": os.cpu_count(), "loadavg_before": os.getloadavg()}
    try:
        out["first_view"] = first_view(server.createdb("big"), args.sessions)
        out["live"] = live(server.createdb("live"), work)
        out["loadavg_after"] = os.getloadavg()
    finally:
        server.destroy()
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
