// A unit's history: B and the diagonal of H of each sensor over time, with their standard deviations.
"use strict";
(function () {
  const data = lab.json("history-data");
  if (!lab.plotly() || !data || !data.calibrations.length) return;
  const sensors = new Set();
  data.calibrations.forEach(c => Object.keys(c.sensors).forEach(s => sensors.add(s)));
  for (const s of sensors) {
    for (const part of ["B", "H"]) {
      const traces = [];
      for (let i = 0; i < 3; i++) {
        const rows = data.calibrations.filter(c => c.sensors[s] && c.sensors[s][part]);
        const pick = (m) => m == null ? null : (part === "B" ? m[i] : m[i][i]);
        traces.push({
          x: rows.map(c => c.started_utc), y: rows.map(c => pick(c.sensors[s][part])),
          error_y: {type: "data", array: rows.map(c => pick(c.sensors[s][part + "_std"])), visible: true},
          text: rows.map(c => lab.plain(c.session)), hovertemplate: "%{text}<br>%{y}<extra></extra>",
          marker: {line: {width: rows.map(c => c.drift && c.drift[s] && c.drift[s].flagged ? 3 : 0),
                   color: "red"}},
          mode: "lines+markers", type: "scatter", name: part === "B" ? "B" + "xyz"[i] : "H" + "xyz"[i] + "xyz"[i],
        });
      }
      Plotly.newPlot("history-" + s + "-" + part, traces,
                     {title: {text: s + ": " + (part === "B" ? "B (counts)" : "diag H"), font: {size: 13}},
                      margin: {t: 30, b: 40}, xaxis: {type: "date"}}, {displaylogo: false, responsive: true});
    }
  }
})();
