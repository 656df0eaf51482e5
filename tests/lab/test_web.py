"""The lab's web page in headless Chromium, on a PostgreSQL store filled by `rig push --all`: what a person sees
(the list and its filters, a unit's history plot with every calibration, the rig comparison naming the
misaligned rig), names typed by users shown as text and never run, and nothing but reading allowed."""

from __future__ import annotations

import signal
import urllib.request

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select

from fixtures.world.effects.table_axis_misalignment import TableAxisMisalignment

from .browser import navigate, screenshot
from .conftest import make_archive, rig

EVIL_UNIT = "<script>window.__pwned = 1</script>"
EVIL_OPERATOR = '<img src=x onerror="window.__pwned = 2">'
EVIL_SESSION = "<b onmouseover=alert(1)>name</b>"


@pytest.fixture(scope="module")
def site_store(tmp_path_factory, pg_server):
    root = tmp_path_factory.mktemp("web")
    specs = [dict(name=f"gold-{i}", unit="GOLD-W", rig="rig-" + "abc"[i % 3],
                  effects=[TableAxisMisalignment(inner_zero_deg=0.3)] if i % 3 == 2 else [],
                  start_utc=f"2026-05-{1 + i:02d}T08:00:00.000Z") for i in range(9)]
    specs += [dict(name=EVIL_SESSION.replace("/", "_"), unit=EVIL_UNIT, rig="rig-a",
                   operator=EVIL_OPERATOR, start_utc="2026-05-20T08:00:00.000Z")]
    make_archive(root, specs)
    url = pg_server.createdb("web")
    assert rig("push", "--all", root, "--store", url).returncode == 0
    return url


@pytest.fixture(scope="module")
def site(site_store):
    from .conftest import Served

    served = Served(site_store)
    yield served
    err = served.stop()
    assert "Traceback" not in err, err


def test_the_list_shows_the_sessions_and_filters_them(site, browser):
    browser.get(site.base + "/")
    assert browser.find_element(By.ID, "count").text.startswith("10 sessions")
    assert len(browser.find_elements(By.CSS_SELECTOR, "#sessions tbody tr")) == 10
    Select(browser.find_element(By.NAME, "rig")).select_by_visible_text("rig-b")
    navigate(browser, browser.find_element(By.CSS_SELECTOR, "form.filters button"))
    rigs = [td.text for td in browser.find_elements(By.CSS_SELECTOR, "#sessions tbody td:nth-child(4)")]
    assert rigs == ["rig-b"] * 3
    browser.find_element(By.NAME, "since").send_keys("05/03/2026")      # Chromium's date input: mm/dd/yyyy
    navigate(browser, browser.find_element(By.CSS_SELECTOR, "form.filters button"))
    names = [a.text for a in browser.find_elements(By.CSS_SELECTOR, "#sessions tbody td:nth-child(2) a")]
    assert names == ["gold-7", "gold-4"], browser.current_url
    screenshot(browser, "lab-sessions-filtered")


def test_user_text_is_shown_as_text_and_never_runs(site, browser):
    browser.get(site.base + "/?rig=rig-a")
    row = browser.find_element(By.CSS_SELECTOR, "#sessions tbody tr")
    cells = [td.text for td in row.find_elements(By.TAG_NAME, "td")]
    assert EVIL_UNIT in cells and EVIL_OPERATOR in cells
    assert EVIL_SESSION.replace("/", "_") in cells
    navigate(browser, row.find_element(By.CSS_SELECTOR, "td:nth-child(2) a"))
    assert browser.find_element(By.ID, "operator").text == EVIL_OPERATOR
    assert browser.find_element(By.ID, "unit").text == EVIL_UNIT
    navigate(browser, browser.find_element(By.ID, "unit"))
    assert browser.find_element(By.ID, "serial").text == EVIL_UNIT
    assert browser.execute_script("return window.__pwned === undefined && document.querySelectorAll("
                                  "'main script:not([type]), main img[src=x], main b[onmouseover]').length === 0")
    screenshot(browser, "lab-escaped-names")


def test_the_history_plot_shows_every_calibration(site, browser):
    browser.get(site.base + "/unit/GOLD-W")
    rows = browser.find_elements(By.CSS_SELECTOR, "#history tbody tr")
    assert len(rows) == 9
    rig_of_row = [tr.find_element(By.CSS_SELECTOR, "td.rig").text for tr in rows]
    for plot in ("history-accel-B", "history-gyro-H", "history-mag-B"):
        traces = browser.find_elements(By.CSS_SELECTOR, f"#{plot} .scatterlayer .trace")
        assert len(traces) == 3 + 3, plot                     # x, y, z and the key to each rig's symbol
        for trace in traces[:3]:                              # every calibration is a point on every line
            assert len(trace.find_elements(By.CSS_SELECTOR, ".points .point")) == 9, plot
        symbols = browser.execute_script(f"return document.getElementById('{plot}').data[0].marker.symbol")
        assert len(set(symbols)) == 3 and len(set(zip(symbols, rig_of_row))) == 3, (symbols, rig_of_row)
        legend = {t.text for t in browser.find_elements(By.CSS_SELECTOR, f"#{plot} .legend .legendtext")}
        assert {"rig rig-a", "rig rig-b", "rig rig-c"} <= legend, legend
    assert "(counts)" in browser.find_element(By.CSS_SELECTOR, "#history-mag-B .gtitle").text
    assert "uT per count" in browser.find_element(By.CSS_SELECTOR, "#history-mag-H .gtitle").text
    assert "-0 sigma" not in browser.find_element(By.TAG_NAME, "main").text
    screenshot(browser, "lab-unit-history")


def test_the_rig_comparison_names_the_misaligned_rig(site, browser):
    browser.get(site.base + "/rigs")
    Select(browser.find_element(By.NAME, "unit")).select_by_visible_text("GOLD-W")
    navigate(browser, browser.find_element(By.CSS_SELECTOR, "form.filters button"))
    findings = [li.text for li in browser.find_elements(By.CSS_SELECTOR, "#findings li.finding")]
    assert len(findings) == 1 and findings[0].startswith("rig rig-c:") and "misaligned" in findings[0], findings
    assert len(browser.find_elements(By.CSS_SELECTOR, "#differences tbody tr")) == 9      # 3 pairs x 3 sensors
    screenshot(browser, "lab-rig-comparison")


def test_a_session_report_shows_its_calibration_and_files(site, browser):
    browser.get(site.base + "/?unit=GOLD-W&status=complete")
    navigate(browser, browser.find_element(By.CSS_SELECTOR, "#sessions tbody td:nth-child(2) a"))
    assert browser.find_element(By.ID, "status").text == "complete"
    assert browser.find_element(By.ID, "progress").text == "12 of 12"
    assert len(browser.find_elements(By.CSS_SELECTOR, "#holds tbody tr")) == 12
    sensors = [tr.find_element(By.TAG_NAME, "td").text for tr in
               browser.find_elements(By.CSS_SELECTOR, "#calibration tbody tr")]
    assert sensors == ["accel", "gyro", "mag"]


def test_the_page_only_reads(site):
    request = urllib.request.Request(site.base + "/", data=b"x=1", method="POST")
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(request, timeout=10)
    assert refused.value.code == 405
    status, body = site.get("/session/not-a-key")
    assert status == 404 and b"no such session" in body
    status, body = site.get("/session/00000000-0000-0000-0000-000000000000/file/..%2Fetc%2Fpasswd")
    assert status == 404


def test_serve_on_a_folder_store_and_a_busy_port(tmp_path, serve):
    make_archive(tmp_path / "f", [dict(unit="F-1", rig="r", start_utc="2026-05-01T08:00:00.000Z")])
    site = serve(str(tmp_path / "f"))
    status, body = site.get("/unit/F-1")
    assert status == 200 and b"1 calibration on" in body
    done = rig("serve", "--store", tmp_path / "f", "--port", site.port, timeout=30)
    assert done.returncode == 4 and "in use" in done.stderr and "Traceback" not in done.stderr


@pytest.mark.parametrize("stop, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_serve_stopped_by_a_signal_exits_as_every_command_does(tmp_path, serve, stop, code):
    """uvicorn shuts down on SIGINT and SIGTERM and then raises the signal again; with its default handler back
    that killed the process (no line, the store not closed), and SIGHUP killed it at once."""
    make_archive(tmp_path / "f", [dict(unit="F-2", rig="r", start_utc="2026-05-01T08:00:00.000Z")])
    site = serve(str(tmp_path / "f"))
    site.proc.send_signal(stop)
    assert site.proc.wait(15) == code
    err = site.proc.stderr.read()
    assert err.strip().splitlines()[-1] == "aborted" and "Traceback" not in err, err


def test_a_sigma_that_rounds_to_zero_is_shown_as_0():
    """No change at all is p = 1, whose normal deviate is -0.0: the drift table showed "-0 sigma"."""
    import numpy as np

    from rig.lab.questions import sigma_of
    from rig.lab.web.app import _num

    nothing, _ = sigma_of(np.zeros(3), np.ones(3))
    assert _num(nothing, 2) == "0" and _num(-0.0, 2) == "0" and _num(-0.0004, 2) == "-0.0004"
    assert _num(-2.5e-7, 2) == "-2.5e-07" and _num(-1.23, 2) == "-1.2"
