// The sessions list: running sessions' progress, ETA and status refreshed every second.
"use strict";
(function () {
  async function refresh() {
    const rows = Array.from(document.querySelectorAll("#sessions tbody tr.status-running"));
    if (!rows.length) return;
    const keys = rows.map(r => r.dataset.key).join(",");
    try {
      const data = await lab.get("/api/progress?keys=" + encodeURIComponent(keys));
      for (const p of data.sessions) {
        const row = document.querySelector('#sessions tr[data-key="' + CSS.escape(p.key) + '"]');
        if (!row) continue;
        lab.text(row.querySelector(".progress"), lab.progress(p));
        lab.text(row.querySelector(".eta"), p.eta_s == null ? "" : Math.round(p.eta_s) + " s");
        lab.text(row.querySelector(".status"), p.status);
        lab.text(row.querySelector(".verdict"), p.verdict || "");
        row.className = "status-" + p.status;
      }
    } catch (e) { /* the next tick tries again */ }
  }
  setInterval(refresh, 1000);
})();
