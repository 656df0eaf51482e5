"""The lab's page as a lab uses it, in headless Chromium: real sessions of the simulated rig (one within its
limits, one beyond them) on two rigs, pushed to PostgreSQL and re-calibrated by `rig batch`; every file of a
session downloads; the residual of every orientation and the limits with their units; the unit's history
marked by rig, the re-calibration beside the rig's own with its verdict; sessions started after the list was
opened appear in it; a store that goes away is said on the page, and so is its return."""

from __future__ import annotations

import json
import re
import sqlite3
import urllib.request

import pytest
from selenium.common.exceptions import WebDriverException
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

from .browser import navigate, screenshot
from .conftest import Served, make_archive, no_traceback, rig
from .proxy import CountingProxy
from .rig_lab import trial_lab

UNIT = "SIM-0003"
FAST = ("calibrate", "--sim", "--seed", "3", "--time-scale", "50", "--no-progress")
NEGATIVE_ZERO = re.compile(r"-0(\.0*)?\s*sigma")
LIMITS = """[limits.accel]
residual_rms_max = %g
B_std_max = 0.1
H_std_pct_max = 0.05
[limits.gyro]
residual_rms_max = 0.02
B_std_max = 0.5
H_std_pct_max = 0.2
[limits.mag]
residual_rms_max = 1.0
B_std_max = 0.5
H_std_pct_max = 0.1
"""


@pytest.fixture(scope="module")
def lab_store(tmp_path_factory, pg_server):
    """pass-1 on rig-p within the built-in limits; fail-1 on rig-f, whose accelerometer residual limit no
    calibration meets; both pushed, then re-calibrated by `rig batch` (exit 1: one re-calibration fails)."""
    root = tmp_path_factory.mktemp("lab")
    for name, rig_name, accel_rms in (("pass-1", "rig-p", 0.05), ("fail-1", "rig-f", 1e-9)):
        toml = root.parent / f"{name}.toml"
        toml.write_text(f'[schedule]\norientations = 9\n\n[store]\nrig = "{rig_name}"\n\n' + LIMITS % accel_rms)
        done = rig(*FAST, "--config", toml, "--out", root / name, timeout=300)
        no_traceback(done)
        assert done.returncode == (1 if name == "fail-1" else 0), done.stderr
    url = pg_server.createdb("weblab")
    pushed = rig("push", "--all", root, "--store", url)
    assert pushed.returncode == 0, pushed.stderr
    batch = rig("batch", "calibrate", "--store", url, "--where", f"unit={UNIT}", "--json", root.parent / "b.json",
                timeout=300)
    no_traceback(batch)
    assert batch.returncode == 1 and "FAIL" in batch.stderr, batch.stdout + batch.stderr
    assert json.loads((root.parent / "b.json").read_text())["verdicts"] == {"FAIL": 1, "PASS": 1}
    return url


@pytest.fixture(scope="module")
def lab_site(lab_store):
    served = Served(lab_store)
    yield served
    err = served.stop()
    assert "Traceback" not in err, err


def open_session(browser, site, name: str) -> None:
    browser.get(site.base + f"/?unit={UNIT}")
    link = next(a for a in browser.find_elements(By.CSS_SELECTOR, "#sessions tbody td:nth-child(2) a")
                if a.text == name)
    navigate(browser, link)


def test_a_failed_session_and_its_recalibration_both_say_fail(lab_site, browser):
    open_session(browser, lab_site, "fail-1")
    assert browser.find_element(By.ID, "verdict").text == "FAIL"
    sections = browser.find_elements(By.CSS_SELECTOR, "section.calibration")
    sources = [s.get_attribute("data-source") for s in sections]
    assert sources[0] == "rig" and len(sources) == 2 and sources[1].startswith("batch "), sources
    assert [s.find_element(By.CSS_SELECTOR, ".verdict").text for s in sections] == ["FAIL", "FAIL"]
    failing = [[td.text for td in tr.find_elements(By.TAG_NAME, "td")]
               for tr in sections[0].find_elements(By.CSS_SELECTOR, "tr.result-FAIL")]
    assert [row[:2] + row[4:6] for row in failing] == [["accel", "residual_rms_max", "m/s^2", "FAIL"]], failing
    assert [td.text for td in browser.find_elements(By.CSS_SELECTOR, "#results td.verdict")] == ["FAIL"]
    screenshot(browser, "lab-session-fail-beside")

    navigate(browser, browser.find_element(By.ID, "unit"))
    rows = browser.find_elements(By.CSS_SELECTOR, "#history tbody tr")
    shown = [(tr.find_element(By.CSS_SELECTOR, "td.rig").text, tr.find_element(By.CSS_SELECTOR, "td.verdict").text,
              tr.find_element(By.CSS_SELECTOR, "td.beside").text) for tr in rows]
    assert [(r, v) for r, v, _ in shown] == [("rig-p", "PASS"), ("rig-f", "FAIL")], shown
    assert "(PASS)" in shown[0][2] and "(FAIL)" in shown[1][2] and all("batch " in b for _, _, b in shown), shown


def test_every_file_of_a_session_downloads(lab_site, browser, tmp_path):
    open_session(browser, lab_site, "pass-1")
    links = [a.get_attribute("href") for a in browser.find_elements(By.CSS_SELECTOR, "a.download")]
    names = {re.search(r"/file/([^?]+)\?download=1$", href).group(1) for href in links}
    assert {"calibration.json", "report.md", "report.json", "session.sqlite"} <= names, names
    assert any(re.fullmatch(r"calibration-.+\.json", n) for n in names), names
    for href in links:
        with urllib.request.urlopen(href, timeout=30) as r:
            body = r.read()
            assert r.status == 200 and r.headers["Content-Disposition"].startswith("attachment"), href
        name = re.search(r"/file/([^?]+)\?", href).group(1)
        if name.endswith(".json") and name.startswith("calibration"):
            document = json.loads(body)
            assert document["unit"]["serial"] == UNIT and document["verdict"] == "PASS", name
        if name == "session.sqlite":
            assert body.startswith(b"SQLite format 3\x00")
            (tmp_path / name).write_bytes(body)
            with sqlite3.connect(tmp_path / name) as db:
                holds = db.execute("SELECT count(DISTINCT step) FROM segment WHERE phase = 'hold'").fetchone()[0]
            assert holds == 9


def test_residuals_limits_and_units_of_a_session(lab_site, browser):
    open_session(browser, lab_site, "pass-1")
    WebDriverWait(browser, 60).until(lambda b: len(b.find_elements(By.CSS_SELECTOR, "#residual-plots .plot")) == 3
                                     and b.find_elements(By.CSS_SELECTOR, "#residuals-mag .scatterlayer .point"))
    accel = browser.find_element(By.ID, "residuals-accel")
    traces = accel.find_elements(By.CSS_SELECTOR, ".scatterlayer .trace")
    assert len(traces) == 4 and all(len(t.find_elements(By.CSS_SELECTOR, ".point")) == 9 for t in traces)
    assert accel.find_element(By.CSS_SELECTOR, ".g-ytitle").text == "m/s^2"
    assert browser.find_element(By.CSS_SELECTOR, "#residuals-gyro .g-ytitle").text == "deg"
    table = browser.find_element(By.ID, "calibration")
    assert [td.text for td in table.find_elements(By.CSS_SELECTOR, "td.unit")] == ["m/s^2", "rad/s", "uT"]
    heads = [th.text for th in table.find_elements(By.TAG_NAME, "th")]
    assert "B (counts)" in heads and "H (u per count)" in heads, heads
    assert table.find_element(By.CSS_SELECTOR, "tr[data-sensor=mag] td.H .u").text == "uT per count"
    limits = browser.find_elements(By.CSS_SELECTOR, "#limits tbody tr")
    assert len(limits) == 9 and all(tr.get_attribute("class") == "result-PASS" for tr in limits)
    units = {tuple(td.text for td in tr.find_elements(By.TAG_NAME, "td"))[:2]: tr.find_elements(
        By.TAG_NAME, "td")[4].text for tr in limits}
    assert units[("mag", "residual_rms_max")] == "uT" and units[("gyro", "residual_rms_max")] == "rad per move"
    screenshot(browser, "lab-session-residuals")
    for page in ("", f"/unit/{UNIT}", f"/rigs?unit={UNIT}"):
        if page:
            browser.get(lab_site.base + page)
        assert not NEGATIVE_ZERO.search(browser.find_element(By.TAG_NAME, "main").text), page


def wait_for(browser, test, seconds: float, what: str):
    try:
        return WebDriverWait(browser, seconds, poll_frequency=0.2, ignored_exceptions=(WebDriverException,)).until(
            test)
    except Exception:
        screenshot(browser, "lab-wait-failed")
        raise AssertionError(f"{what} within {seconds} s")


def test_new_sessions_appear_and_a_lost_store_is_said(tmp_path, pg_server, browser):
    """The list adds a session pushed after it was opened (no reload); when the store goes away the page says so
    instead of freezing, and says when it is back."""
    first, stuck, second = make_archive(tmp_path / "a", [
        dict(name="first", unit="LIVE-1", rig="rig-l", start_utc="2026-06-01T08:00:00.000Z"),
        dict(name="stuck", unit="LIVE-3", rig="rig-m", start_utc="2026-06-01T09:00:00.000Z", finish=False),
        dict(name="second", unit="LIVE-2", rig="rig-l", start_utc="2026-06-02T08:00:00.000Z")])
    url = pg_server.createdb("weblive")
    for folder in (first, stuck):
        assert rig("push", folder, "--store", url).returncode == 0
    proxy = CountingProxy(pg_server.port)
    served = Served(url.replace(f"127.0.0.1:{pg_server.port}", f"127.0.0.1:{proxy.port}"))
    try:
        browser.get(served.base + "/")
        browser.execute_script("window.__opened = true")
        assert [a.text for a in browser.find_elements(By.CSS_SELECTOR, "#sessions tbody td:nth-child(2) a")] == \
            ["stuck", "first"]
        assert rig("push", second, "--store", url).returncode == 0
        wait_for(browser, lambda b: [a.text for a in b.find_elements(
            By.CSS_SELECTOR, "#sessions tbody td:nth-child(2) a")] == ["second", "stuck", "first"], 15,
            "the new session shown")
        assert browser.execute_script("return window.__opened === true")           # added, not reloaded
        assert browser.find_element(By.CSS_SELECTOR, "#sessions tbody tr[data-live=new] td.status").text == "complete"
        assert browser.find_element(By.ID, "count").text.startswith("3 sessions")
        notice = browser.find_element(By.ID, "store-notice")
        assert not notice.is_displayed()

        proxy.cut()
        wait_for(browser, lambda b: notice.is_displayed() and "cannot be reached" in notice.text, 30,
                 "the notice that the store is away")
        screenshot(browser, "lab-store-unreachable")
        proxy.restore()
        wait_for(browser, lambda b: "is back" in notice.text, 60, "the notice that the store is back")
        assert browser.execute_script("return window.__opened === true")

        navigate(browser, next(a for a in browser.find_elements(By.CSS_SELECTOR, "#sessions tbody td a")
                               if a.text == "stuck"))                     # a running session's page polls too
        assert browser.find_element(By.ID, "status").text == "running"
        progress = browser.find_element(By.ID, "progress").text
        notice = browser.find_element(By.ID, "store-notice")
        proxy.cut()
        wait_for(browser, lambda b: notice.is_displayed() and "cannot be reached" in notice.text, 30,
                 "the notice on a running session's page")
        assert browser.find_element(By.ID, "progress").text == progress     # as it was, and said to be so
        proxy.restore()
        wait_for(browser, lambda b: "is back" in notice.text, 60, "the notice that the store is back")
    finally:
        err = served.stop()
        proxy.close()
    assert "Traceback" not in err, err


def test_the_rig_comparison_names_a_rig_that_disagrees_with_itself(tmp_path, serve, browser):
    loose = next(s for s in trial_lab(tmp_path, 2) if s["name"] == "loose")
    site = serve(str(loose["store"]))
    browser.get(site.base + "/rigs?unit=GOLD")
    findings = [li.text for li in browser.find_elements(By.CSS_SELECTOR, "#findings li.finding")]
    assert len(findings) == 1 and findings[0].startswith(f"rig {loose['rig']} disagrees with itself"), findings
    rows = {tr.get_attribute("data-rig"): tr
            for tr in browser.find_elements(By.CSS_SELECTOR, "#rig-sessions tr[data-rig]")}
    assert set(rows) == {"rig-a", "rig-c", loose["rig"]}
    for name, tr in rows.items():
        cells = [td.text for td in tr.find_elements(By.TAG_NAME, "td")]
        scatter = float(cells[2].split()[0])
        if name == loose["rig"]:
            assert scatter > 3 and cells[3].startswith("no"), cells
        else:
            assert scatter < 3 and cells[3] == "yes", cells
    screenshot(browser, "lab-rig-disagrees-with-itself")
