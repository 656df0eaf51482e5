// One session: progress (orientation k of n, ETA) and hold means arriving while it runs, plotted by step; once
// calibrated, the residual of every orientation; a notice while the store cannot be reached.
"use strict";
(function () {
  const data = lab.json("session-data");
  const holds = [];
  let lastSeq = 0;
  const groups = {accel: ["ax", "ay", "az"], gyro: ["gx", "gy", "gz"], mag: ["mx", "my", "mz"]};

  function cell(tr, value) { const td = document.createElement("td"); lab.text(td, value); tr.appendChild(td); }
  function fmt(v) { return v == null ? "-" : Number(v).toPrecision(6); }
  function means(h, names) { return names.map(n => fmt(h.means[n])).join(" "); }

  function addHolds(list) {
    const body = document.querySelector("#holds tbody");
    for (const h of list) {
      if (h.seq <= lastSeq) continue;
      holds.push(h);
      lastSeq = h.seq;
      const tr = document.createElement("tr");
      tr.dataset.seq = h.seq;
      cell(tr, holds.length); cell(tr, h.step); cell(tr, h.attempt); cell(tr, h.written_utc);
      cell(tr, means(h, groups.accel)); cell(tr, means(h, groups.gyro)); cell(tr, means(h, groups.mag));
      cell(tr, fmt(h.means.temp_c));
      body.appendChild(tr);
    }
  }

  function plot() {
    if (!lab.plotly() || !holds.length) return;
    const traces = [];
    let axis = 1;
    for (const [sensor, names] of Object.entries(groups)) {
      if (!holds.some(h => names.some(n => h.means[n] != null))) continue;
      for (const n of names) {
        traces.push({x: holds.map(h => h.step), y: holds.map(h => h.means[n]), name: n, mode: "markers",
                     type: "scatter", xaxis: "x" + (axis === 1 ? "" : axis), yaxis: "y" + (axis === 1 ? "" : axis)});
      }
      axis += 1;
    }
    const layout = {grid: {rows: 1, columns: axis - 1, pattern: "independent"}, margin: {t: 30, b: 40},
                    title: {text: "hold means by orientation (counts)", font: {size: 13}}, showlegend: true};
    Plotly.react("hold-plot", traces, layout, {displaylogo: false, responsive: true});
  }

  function show(p) {
    lab.text(document.getElementById("progress"), lab.progress(p));
    lab.text(document.getElementById("eta"), lab.eta(p));
    const status = document.getElementById("status");
    lab.text(status, p.status);
    status.className = "status-" + p.status;
    lab.text(document.getElementById("verdict"), p.verdict || "");
    lab.text(document.getElementById("reason"), p.reason || "");
  }

  // One plot per sensor: a static sensor's residual u_j - R_j^T v (x, y, z) and norm error by orientation, in
  // its unit; the gyroscope's rotation error by move, in deg.
  function residualPlots(r) {
    const box = document.getElementById("residual-plots");
    const said = document.getElementById("residuals-status");
    const sensors = Object.entries(r.sensors || {});
    lab.text(said, r.error ? r.error : (sensors.length ? "" : "no residuals to show"));
    if (said && !r.error && sensors.length) said.hidden = true;
    if (!box || !lab.plotly()) return;
    for (const [sensor, s] of sensors) {
      const div = document.createElement("div");
      div.id = "residuals-" + sensor;
      div.className = "plot third";
      box.appendChild(div);
      const traces = [];
      let title, ytitle, xtitle;
      if (s.residual) {
        for (let i = 0; i < 3; i++) {
          traces.push({x: s.steps, y: s.residual.map(v => v[i]), name: "residual " + "xyz"[i], mode: "lines+markers",
                       type: "scatter"});
        }
        traces.push({x: s.steps, y: s.norm_error, name: "|u| - " + Number(s.reference).toPrecision(6),
                     mode: "lines+markers", type: "scatter", line: {dash: "dot"}});
        title = sensor + ": residual by orientation";
        ytitle = s.unit;
        xtitle = "orientation (step)";
      } else {
        traces.push({x: s.moves, y: s.move_error_deg, name: "rotation error", mode: "lines+markers", type: "scatter"});
        title = sensor + ": integrated rotation error by move";
        ytitle = "deg";
        xtitle = "move (from step)";
      }
      Plotly.newPlot(div, traces, {title: {text: title, font: {size: 13}}, margin: {t: 30, b: 40},
                                   xaxis: {title: {text: xtitle}}, yaxis: {title: {text: ytitle}},
                                   legend: {orientation: "h"}}, {displaylogo: false, responsive: true});
    }
  }

  async function residuals() {
    try {
      residualPlots(await lab.get("/api/session/" + encodeURIComponent(data.key) + "/residuals"));
      lab.recovered();
    } catch (e) {
      lab.outage(e);
      lab.text(document.getElementById("residuals-status"), "the residuals could not be fetched: " + e.message +
               "; trying again");
      setTimeout(residuals, 3000);
    }
  }

  let wasRunning = data.progress.status === "running";
  async function poll() {
    try {
      const d = await lab.get("/api/session/" + encodeURIComponent(data.key) + "?after=" + lastSeq);
      lab.recovered();
      addHolds(d.holds);
      show(d.progress);
      if (d.holds.length) plot();
      if (wasRunning && d.progress.status !== "running") {
        wasRunning = false;
        setTimeout(() => window.location.reload(), 1500);   // the calibration and report are in: show them
        return;
      }
    } catch (e) {
      lab.outage(e);
    }
    setTimeout(poll, 500);
  }

  addHolds(data.holds);
  show(data.progress);
  plot();
  if (wasRunning) setTimeout(poll, 500);
  if (data.calibrated) residuals();
})();
