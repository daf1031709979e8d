/* alpaca-zwo pointing model card (issue 40, docs/pointing-model.md): the points of the model built from syncs
 * on app.js's sky chart (where each was taken), their residuals, the fitted TPoint terms with their 1σ and the
 * RMS, with Clear and an on/off switch. Self-contained: it adds its own card after the sky's and its own
 * layer (#sky-pointing) above skychart.js's, re-added when app.js rebuilds the chart (Turn). It reads
 * GET …/pointing-model every 15 s and after a sync or a change; changes are POSTs like every control.
 */
"use strict";

(function () {
  const hook = window.alpacaZwo;
  const $ = (id) => document.getElementById(id);
  const SVG = "http://www.w3.org/2000/svg";
  const REFRESH_MS = 15000;
  const url = hook.base + "/pointing-model";
  let model = null;

  function el(tag, attrs, parent, text) {
    const node = tag in { g: 1, circle: 1, title: 1 } ? document.createElementNS(SVG, tag) : document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, v);
    if (text !== undefined) node.textContent = text;
    if (parent) parent.append(node);
    return node;
  }

  function arcsec(value) {
    if (value === null || value === undefined) return "–";
    return Math.abs(value) >= 120 ? (value / 60).toFixed(1) + "′" : value.toFixed(1) + "″";
  }

  function buildCard() {
    const card = el("section", { class: "card pointing-card", "aria-labelledby": "pm-h" });
    el("h2", { id: "pm-h" }, card, "Pointing model");
    el("p", { id: "pm-summary", class: "muted small", "aria-live": "polite" }, card);
    const row = el("p", {}, card);
    const label = el("label", {}, row);
    el("input", { type: "checkbox", id: "pm-enabled" }, label);
    label.append(" Apply the model ");
    el("button", { type: "button", id: "pm-clear", class: "ghost" }, row, "Clear");
    el("p", { id: "pm-refusal", class: "note hidden", role: "status" }, card);
    const terms = el("table", { class: "tbl", id: "pm-terms", "aria-label": "Fitted terms" }, card);
    terms.append(headRow(["Term", "Value", "± 1σ"]));
    el("tbody", { id: "pm-terms-body" }, terms);
    const list = el("details", {}, card);
    el("summary", {}, list, "Points and residuals");
    const table = el("table", { class: "tbl", "aria-label": "Sync points" }, list);
    table.append(headRow(["Synced (UTC)", "Pier", "Residual RA·cosδ", "Residual Dec"]));
    el("tbody", { id: "pm-points" }, table);
    el("p", { class: "muted small" }, card,
      "Every sync adds a point; the markers on the chart show where. Clear it after a new polar alignment.");
    const sky = document.querySelector(".sky-card");
    if (sky) sky.after(card);
    else document.querySelector("main").append(card);
    $("pm-enabled").addEventListener("change", (ev) => change({ enabled: ev.target.checked }));
    $("pm-clear").addEventListener("click", () => {
      if (confirm("Forget every point of the pointing model?")) change({ clear: true });
    });
  }

  function headRow(names) {
    const head = document.createElement("thead");
    const tr = el("tr", {}, head);
    for (const name of names) el("th", {}, tr, name);
    return head;
  }

  function row(body, cells) {
    const tr = el("tr", {}, body);
    for (const cell of cells) el("td", {}, tr, cell);
  }

  function render() {
    if (!model) return;
    const n = model.points.length;
    $("pm-summary").textContent = n === 0 ? "No points yet: every sync adds one." :
      n + " point" + (n === 1 ? "" : "s") + ", RMS " + arcsec(model.rms_arcsec) + " (" + model.mode + ")" +
      (model.enabled ? "" : ": switched off, GoTos use the last sync only");
    $("pm-enabled").checked = model.enabled;
    $("pm-refusal").textContent = model.last_refusal;
    $("pm-refusal").classList.toggle("hidden", !model.last_refusal);
    const terms = $("pm-terms-body");
    terms.replaceChildren();
    for (const t of model.terms) row(terms, [t.name, arcsec(t.arcsec), arcsec(t.sigma_arcsec)]);
    const list = $("pm-points");
    list.replaceChildren();
    for (const p of model.points) {
      row(list, [p.time.replace("T", " ").replace("+00:00", ""), p.pier < 0 ? "through the pole" : "normal",
        arcsec(p.residual_arcsec[0]), arcsec(p.residual_arcsec[1])]);
    }
    draw();
  }

  function draw() {
    const svg = $("sky");
    if (!svg || !model) return;
    let layer = $("sky-pointing");
    if (!layer) {
      layer = el("g", { id: "sky-pointing", "aria-hidden": "true" });
      const chart = $("sky-chart");
      if (chart) chart.after(layer);
      else svg.append(layer);
    }
    layer.replaceChildren();
    for (const p of model.points) {
      if (p.alt < hook.MIN_ALT) continue;
      const [x, y] = hook.project(p.az, p.alt);
      const mark = el("circle", { cx: x.toFixed(2), cy: y.toFixed(2), r: 3, class: "sky-pm" }, layer);
      el("title", {}, mark, "Sync point: residual " + arcsec(Math.hypot(...p.residual_arcsec)));
    }
  }

  async function refresh() {
    try {
      model = await hook.request(url);
      render();
    } catch (err) {
      $("pm-summary").textContent = "Pointing model not read: " + err.message;
    }
  }

  async function change(body) {
    try {
      model = await hook.post(url, body);
      render();
      hook.message(body.clear ? "Pointing model cleared." : "Pointing model " + (model.enabled ? "on." : "off."), "info");
    } catch (err) {
      hook.message("Pointing model: " + err.message, "error", $("pm-enabled").closest("p"));
      refresh();
    }
  }

  function start() {
    buildCard();
    refresh();
    setInterval(refresh, REFRESH_MS);
    hook.onStatus(() => {
      if (!$("sky-pointing")) draw(); // the chart was rebuilt (Turn)
    });
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
