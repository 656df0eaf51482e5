// A unit's history: B and the diagonal of H of each sensor over time, with their standard deviations; every
// point marked by the rig that calibrated it (one symbol per rig, named in the legend).
"use strict";
(function () {
  const data = lab.json("history-data");
  if (!lab.plotly() || !data || !data.calibrations.length) return;
  const SYMBOLS = ["circle", "square", "diamond", "triangle-up", "cross", "x", "star", "triangle-down", "pentagon",
                   "hexagon", "triangle-left", "triangle-right"];
  const rigs = Array.from(new Set(data.calibrations.map(c => c.rig))).sort();
  const symbolOf = Object.fromEntries(rigs.map((r, i) => [r, SYMBOLS[i % SYMBOLS.length]]));
  const sensors = new Set();
  data.calibrations.forEach(c => Object.keys(c.sensors).forEach(s => sensors.add(s)));
  for (const s of sensors) {
    const unit = (data.calibrations.find(c => c.sensors[s] && c.sensors[s].unit) || {sensors: {}}).sensors[s];
    const u = unit && unit.unit ? unit.unit : "unit";
    for (const part of ["B", "H"]) {
      const traces = [];
      const rows = data.calibrations.filter(c => c.sensors[s] && c.sensors[s][part]);
      for (let i = 0; i < 3; i++) {
        const pick = (m) => m == null ? null : (part === "B" ? m[i] : m[i][i]);
        traces.push({
          x: rows.map(c => c.started_utc), y: rows.map(c => pick(c.sensors[s][part])),
          error_y: {type: "data", array: rows.map(c => pick(c.sensors[s][part + "_std"])), visible: true},
          text: rows.map(c => lab.plain(c.session) + " on rig " + lab.plain(c.rig)), customdata: rows.map(c => c.rig),
          hovertemplate: "%{text}<br>%{y}<extra></extra>",
          marker: {symbol: rows.map(c => symbolOf[c.rig]), size: 9,
                   line: {width: rows.map(c => c.drift && c.drift[s] && c.drift[s].flagged ? 3 : 0), color: "red"}},
          mode: "lines+markers", type: "scatter", name: part === "B" ? "B" + "xyz"[i] : "H" + "xyz"[i] + "xyz"[i],
          legendgroup: "axes",
        });
      }
      for (const r of rigs) {            // the legend's key to the symbols: no points of their own
        traces.push({x: [null], y: [null], mode: "markers", type: "scatter", name: "rig " + lab.plain(r),
                     marker: {symbol: symbolOf[r], size: 9, color: "#4a5560"}, legendgroup: "rigs",
                     hoverinfo: "skip"});
      }
      const ytitle = part === "B" ? "B (counts)" : "diagonal of H (" + u + " per count)";
      Plotly.newPlot("history-" + s + "-" + part, traces,
                     {title: {text: s + ": " + ytitle, font: {size: 13}}, margin: {t: 30, b: 40},
                      xaxis: {type: "date"}, yaxis: {title: {text: ytitle}}},
                     {displaylogo: false, responsive: true});
    }
  }
})();
