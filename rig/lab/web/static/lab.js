// Helpers of the lab's pages. Everything shown is set as text (textContent), never as HTML.
"use strict";
class Unreachable extends Error {}
const lab = {
  json(id) {
    const el = document.getElementById(id);
    return el ? JSON.parse(el.textContent) : null;
  },
  text(el, value) { if (el) el.textContent = value == null ? "" : String(value); },
  eta(p) { return p.eta_s == null ? "" : "ETA " + Math.round(p.eta_s) + " s"; },
  progress(p) { return p.holds + " of " + (p.planned == null ? "?" : p.planned); },
  // JSON from the page's server; Unreachable when the server or the store behind it cannot be reached
  async get(url) {
    let r;
    try {
      r = await fetch(url, {cache: "no-store"});
    } catch (e) {
      throw new Unreachable("the page's server (rig serve) does not answer");
    }
    if (r.status === 503) {
      let said = null;
      try { said = (await r.json()).error; } catch (e) { /* no JSON: said stays empty */ }
      throw new Unreachable(said || "the store cannot be reached");
    }
    if (!r.ok) throw new Error(url + ": " + r.status);
    return r.json();
  },
  // plotly reads a few HTML-like tags in its labels: user text goes in with them written as entities
  plain(s) { return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;"); },
  plotly() { return typeof Plotly !== "undefined"; },
  clock(d) { return d.toISOString().slice(11, 19) + " UTC"; },

  // The notice while the store is away: shown on the first failed poll, replaced by a short "back" once one
  // succeeds again, so that a page that stopped moving says why.
  downSince: null,
  backTimer: null,
  outage(err) {
    if (!(err instanceof Unreachable)) return;
    const box = document.getElementById("store-notice");
    if (!box) return;
    if (lab.downSince == null) lab.downSince = new Date();
    clearTimeout(lab.backTimer);
    box.dataset.state = "down";
    lab.text(box, "The store cannot be reached since " + lab.clock(lab.downSince) + ": " + err.message +
             ". What this page shows is as it was then; it keeps trying (last try " + lab.clock(new Date()) + ").");
    box.hidden = false;
  },
  recovered() {
    const box = document.getElementById("store-notice");
    if (lab.downSince == null || !box) return;
    box.dataset.state = "back";
    lab.text(box, "The store is back (it could not be reached from " + lab.clock(lab.downSince) + " to " +
             lab.clock(new Date()) + "); this page is up to date again.");
    lab.downSince = null;
    lab.backTimer = setTimeout(() => { box.hidden = true; delete box.dataset.state; }, 5000);
  },
};
