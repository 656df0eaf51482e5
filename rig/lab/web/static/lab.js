// Helpers of the lab's pages. Everything shown is set as text (textContent), never as HTML.
"use strict";
const lab = {
  json(id) {
    const el = document.getElementById(id);
    return el ? JSON.parse(el.textContent) : null;
  },
  text(el, value) { if (el) el.textContent = value == null ? "" : String(value); },
  eta(p) { return p.eta_s == null ? "" : "ETA " + Math.round(p.eta_s) + " s"; },
  progress(p) { return p.holds + " of " + (p.planned == null ? "?" : p.planned); },
  async get(url) {
    const r = await fetch(url, {cache: "no-store"});
    if (!r.ok) throw new Error(url + ": " + r.status);
    return r.json();
  },
  // plotly reads a few HTML-like tags in its labels: user text goes in with them written as entities
  plain(s) { return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;"); },
  plotly() { return typeof Plotly !== "undefined"; },
};
