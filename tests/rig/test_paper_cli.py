"""`rig paper`: both tables in the JSON, the iterations the issue asks for, figures drawn."""

import json
import subprocess
import sys


def test_paper_writes_both_tables_and_figures(tmp_path):
    out = tmp_path / "paper.json"
    res = subprocess.run([sys.executable, "-m", "rig.cli", "paper", "--runs", "30", "--gyro-runs", "2",
                          "--json", str(out), "--plots", str(tmp_path / "figs")],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    data = json.loads(out.read_text())
    t1, t2 = data["table1"], data["table2"]
    assert [r["iteration"] for r in t1["rows"]] == [2, 5, 10, 15, 20, 30, 50]
    assert [r["iteration"] for r in t2["rows"]] == [2, 5, 10, 15, 20, 30, 50]
    assert 0.0 <= t1["b_within_0p1pct"] <= 1.0 and t1["runs"] == 30
    # the two-step iteration converges: its H error after 50 iterations is below its error after 2
    assert t1["rows"][-1]["ours_H_mean"] <= t1["rows"][0]["ours_H_mean"]
    assert len(list((tmp_path / "figs").glob("*.png"))) == 4
    assert "Table I" in res.stdout and "Table II" in res.stdout
