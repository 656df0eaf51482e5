"""A running session seen live: `rig calibrate --sim --time-scale 20` in its own process (the public CLI),
`live_mirror` beside it pushing into PostgreSQL, `rig serve` on that database and headless Chromium on the
session's page. What a person would see: the session appears, its counter advances hold by hold, and it
ends complete with its calibration and report; the store holds exactly what the folder holds."""

from __future__ import annotations

import re
import sqlite3
import statistics
import subprocess
import time
from datetime import datetime, timezone

import psycopg
from selenium.webdriver.common.by import By
from selenium.webdriver.support import expected_conditions
from selenium.webdriver.support.ui import WebDriverWait

from rig.lab.mirror import live_mirror

from .browser import navigate, screenshot
from .conftest import RIG, no_traceback, rig
from .test_push import local_counts, stored_counts

PROGRESS = re.compile(r"^(\d+) of (\d+)$")


def hold_commit_times(folder) -> dict[int, datetime]:
    """Distinct hold count -> when the local file committed that hold."""
    with sqlite3.connect(f"file:{folder}/session.sqlite?mode=ro", uri=True) as db:
        rows = db.execute("SELECT step, min(written_utc) FROM segment WHERE phase = 'hold' GROUP BY step "
                          "ORDER BY min(id)").fetchall()
    return {k + 1: datetime.fromisoformat(w.replace("Z", "+00:00")) for k, (_, w) in enumerate(rows)}


def test_a_running_session_is_watched_live_in_a_browser(tmp_path, pg_url, serve, browser):
    out = tmp_path / "live"
    site = serve(pg_url)
    log: list[str] = []
    seen: list[tuple[int, datetime]] = []
    with live_mirror(out, pg_url, rig="bench-1", echo=log.append) as mirror:
        proc = subprocess.Popen([*RIG, "calibrate", "--sim", "--time-scale", "20", "--out", out, "--no-progress"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:                      # the session appears in the list
            browser.get(site.base + "/?status=running")
            links = browser.find_elements(By.CSS_SELECTOR, "#sessions a[href^='/session/']")
            if links:
                break
            time.sleep(0.3)
        assert links, f"the running session never appeared in the list; mirror: {log}"
        assert browser.find_element(By.CSS_SELECTOR, "#sessions td.status").text == "running"
        navigate(browser, links[0])
        shot_mid = False
        while time.monotonic() < deadline:
            text = browser.find_element(By.ID, "progress").text
            match = PROGRESS.match(text)
            if match and (not seen or int(match.group(1)) != seen[-1][0]):
                seen.append((int(match.group(1)), datetime.now(timezone.utc)))
                if not shot_mid and 8 <= seen[-1][0] <= 14:
                    screenshot(browser, "lab-live-session-running")
                    shot_mid = True
            if browser.find_element(By.ID, "status").text != "running" and seen and seen[-1][0] == 20:
                break
            time.sleep(0.1)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 0, err
    assert mirror.outcome.complete, log
    counts = [k for k, _ in seen]
    assert counts == sorted(counts) and len(set(counts)) >= 8, counts       # it advanced, hold by hold
    assert counts[-1] == 20 and int(PROGRESS.match(browser.find_element(By.ID, "progress").text).group(2)) == 20
    WebDriverWait(browser, 20).until(                                       # the page reloads with the report
        expected_conditions.presence_of_element_located((By.CSS_SELECTOR, "#calibration tbody tr")))
    assert browser.find_element(By.ID, "status").text == "complete"
    assert len(browser.find_elements(By.CSS_SELECTOR, "#holds tbody tr")) == 20
    assert browser.find_element(By.ID, "verdict").text == "PASS"
    assert browser.find_elements(By.CSS_SELECTOR, "#calibration tbody tr")
    assert browser.find_elements(By.CSS_SELECTOR, "#hold-plot .scatterlayer .point")
    screenshot(browser, "lab-live-session-complete")
    commits = hold_commit_times(out)
    delays = [(when - commits[k]).total_seconds() for k, when in seen if k in commits and k > seen[0][0]]
    print(f"page saw holds {commits and len(delays)} times; delay after the local commit: median "
          f"{statistics.median(delays):.2f} s, max {max(delays):.2f} s")
    assert statistics.median(delays) < 2.0
    assert stored_counts(pg_url, out.name) == local_counts(out)
    again = rig("push", out, "--store", pg_url, "--rig", "bench-1")
    assert again.returncode == 0 and "up to date" in again.stdout, again.stdout + again.stderr
    with psycopg.connect(pg_url) as conn:
        rig_name, status = conn.execute("SELECT r.name, s.status FROM sessions s JOIN rigs r ON r.id = s.rig_id"
                                        ).fetchone()
    assert (rig_name, status) == ("bench-1", "complete")
    no_traceback(again)
