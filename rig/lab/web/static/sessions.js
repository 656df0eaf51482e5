// The sessions list: running sessions' progress, ETA and status refreshed every second, sessions started after
// the page was opened added at the top (first page only), and a notice while the store cannot be reached.
"use strict";
(function () {
  const live = lab.json("list-data") || {query: {}, newest: null, first_page: false};
  const body = document.querySelector("#sessions tbody");
  let newest = live.newest;

  function cell(tr, cls, value, href) {
    const td = document.createElement("td");
    if (cls) td.className = cls;
    if (href) {
      const a = document.createElement("a");
      a.href = href;
      lab.text(a, value);
      td.appendChild(a);
    } else {
      lab.text(td, value);
    }
    tr.appendChild(td);
  }

  function row(s) {
    const tr = document.createElement("tr");
    tr.dataset.key = s.key;
    tr.dataset.live = "new";
    tr.className = "status-" + s.status;
    cell(tr, "", s.started);
    cell(tr, "", s.name, "/session/" + encodeURIComponent(s.key));
    cell(tr, "", s.unit, "/unit/" + encodeURIComponent(s.unit));
    cell(tr, "", s.rig);
    cell(tr, "", s.operator);
    cell(tr, "status", s.status);
    cell(tr, "progress", lab.progress(s));
    cell(tr, "eta", s.eta_s == null ? "" : Math.round(s.eta_s) + " s");
    cell(tr, "verdict", s.verdict || "");
    return tr;
  }

  async function newSessions() {
    const params = new URLSearchParams(live.query);
    if (newest) params.set("after", newest);
    const data = await lab.get("/api/sessions?" + params.toString());
    const fresh = data.sessions.filter(s => !body.querySelector('tr[data-key="' + CSS.escape(s.key) + '"]'));
    for (const s of fresh.slice().reverse()) body.insertBefore(row(s), body.firstChild);
    if (data.sessions.length) newest = data.sessions[0].started_utc;
    const pages = Math.max(1, Math.ceil(data.total / 100));
    lab.text(document.getElementById("count"), data.total + " session" + (data.total === 1 ? "" : "s") +
             (pages > 1 ? ", page 1 of " + pages : ""));
  }

  async function progress() {
    const rows = Array.from(body.querySelectorAll("tr.status-running"));
    if (!rows.length) return;
    const data = await lab.get("/api/progress?keys=" + encodeURIComponent(rows.map(r => r.dataset.key).join(",")));
    for (const p of data.sessions) {
      const tr = body.querySelector('tr[data-key="' + CSS.escape(p.key) + '"]');
      if (!tr) continue;
      lab.text(tr.querySelector(".progress"), lab.progress(p));
      lab.text(tr.querySelector(".eta"), p.eta_s == null ? "" : Math.round(p.eta_s) + " s");
      lab.text(tr.querySelector(".status"), p.status);
      lab.text(tr.querySelector(".verdict"), p.verdict || "");
      tr.className = "status-" + p.status;
    }
  }

  async function refresh() {
    try {
      if (live.first_page) await newSessions();
      await progress();
      lab.recovered();
    } catch (e) {
      lab.outage(e);
    }
    setTimeout(refresh, 1000);
  }
  setTimeout(refresh, 1000);
})();
