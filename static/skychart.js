/* alpaca-zwo sky chart (issue 25 item 2): stars to V 4.5, constellation lines, Sun, Moon and planets on
 * app.js's all-sky alt-az chart (#sky, layer #sky-chart under the telescope and target markers), the
 * selection, and tap-to-select.
 *
 * The server computes every place (GET …/sky: PyEphem topocentric apparent alt/az, the GoTo's frame); this
 * file asks for the star list once and for the places every 30 s, and draws them with app.js's project().
 * A tap within TAP_PX of a star or body selects it through handset.js (window.alpacaZwo.select); a tap on
 * empty sky offers that point's J2000 RA/Dec (from the status feed's LST and the site's latitude, precessed
 * back from the equinox of date) as a selection of typed coordinates.
 */
"use strict";

(function () {
  const hook = window.alpacaZwo;
  const $ = (id) => document.getElementById(id);
  const SVG = "http://www.w3.org/2000/svg";
  const REFRESH_MS = 30000; // a star moves 0.125° in 30 s: under a pixel of the chart at phone width
  const TAP_PX = 12; // touch-friendly: a fingertip is ~10 mm
  const LABEL_MAG = 1.0; // names for the brightest stars only (about 15 of them, the half above the horizon)
  const D2R = Math.PI / 180;

  const chart = { stars: null, lines: null, places: null, bodies: [], latitude: null, lst: null, utc: null, selected: null };

  function el(tag, attrs, parent) {
    const node = document.createElementNS(SVG, tag);
    for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, v);
    if (parent) parent.append(node);
    return node;
  }

  function starRadius(mag) {
    return Math.max(0.45, Math.min(2.6, 1.9 - 0.3 * mag)); // chart units (the horizon's radius is 100)
  }

  function xy(alt, az) {
    return hook.project(az, alt).map((v) => +v.toFixed(2));
  }

  // ---------------------------------------------------------------- drawing

  function drawLines(layer, visible) {
    const g = el("g", { class: "sky-lines" }, layer);
    let d = "";
    for (const [i, j] of chart.lines) {
      if (!visible[i] || !visible[j]) continue;
      const [x1, y1] = xy(...chart.places[i]);
      const [x2, y2] = xy(...chart.places[j]);
      d += "M" + x1 + " " + y1 + "L" + x2 + " " + y2;
    }
    el("path", { d, class: "sky-line" }, g);
  }

  function drawStars(layer, visible) {
    const g = el("g", { class: "sky-stars" }, layer);
    const labels = el("g", { class: "sky-names" }, layer);
    chart.stars.forEach((star, i) => {
      if (!visible[i]) return;
      const [alt, az] = chart.places[i];
      const [x, y] = xy(alt, az);
      el("circle", { cx: x, cy: y, r: starRadius(star[3]), class: alt < 0 ? "sky-star below" : "sky-star",
        "data-hip": star[0], "data-name": star[4] || "" }, g);
      if (star[4] && star[3] <= LABEL_MAG && alt > 0) {
        el("text", { x: x + 2.5, y: y - 2, class: "sky-star-name" }, labels).textContent = star[4];
      }
    });
  }

  function drawBodies(layer) {
    const g = el("g", { class: "sky-bodies" }, layer);
    const taken = []; // label boxes' [x, y] in chart units: planets in conjunction get stacked labels
    for (const b of chart.bodies) {
      if (b.alt < hook.MIN_ALT) continue;
      const [x, y] = xy(b.alt, b.az);
      const big = b.name === "Sun" || b.name === "Moon";
      const node = el("g", { class: "sky-body " + b.name.toLowerCase() + (b.alt < 0 ? " below" : ""),
        "data-id": b.id, transform: "translate(" + x + " " + y + ")" }, g);
      el("circle", { cx: 0, cy: 0, r: big ? 3.2 : 1.9 }, node);
      let dy = 1.8;
      while (taken.some(([tx, ty]) => Math.abs(tx - x) < 22 && Math.abs(ty - (y + dy)) < 5.5)) dy += 5.5;
      taken.push([x, y + dy]);
      el("text", { x: big ? 4.5 : 3, y: dy, class: "sky-body-name" }, node).textContent = b.name;
    }
  }

  function placeSelection() {
    const layer = $("sky-chart");
    if (!layer) return;
    let mark = $("sky-selected");
    const place = selectedPlace();
    if (!place || place[0] < hook.MIN_ALT) {
      if (mark) mark.remove();
      return;
    }
    if (!mark) mark = el("circle", { id: "sky-selected", r: 4.5, class: "sky-selected" }, layer);
    const [x, y] = xy(...place);
    mark.setAttribute("cx", x);
    mark.setAttribute("cy", y);
  }

  function draw() {
    const layer = $("sky-chart");
    if (!layer || !chart.places) return;
    layer.replaceChildren();
    const visible = chart.places.map(([alt]) => alt >= hook.MIN_ALT);
    drawLines(layer, visible);
    drawStars(layer, visible);
    drawBodies(layer);
    placeSelection();
  }

  // ---------------------------------------------------------------- places

  /** Alt/az (°) of hour angle / declination (°) at latitude (°); azimuth from north through east. */
  function horizontal(ha, dec, lat) {
    const h = ha * D2R, d = dec * D2R, p = lat * D2R;
    const alt = Math.asin(Math.sin(p) * Math.sin(d) + Math.cos(p) * Math.cos(d) * Math.cos(h));
    const az = Math.atan2(-Math.cos(d) * Math.sin(h), Math.cos(p) * Math.sin(d) - Math.sin(p) * Math.cos(d) * Math.cos(h));
    return [alt / D2R, ((az / D2R) % 360 + 360) % 360];
  }

  /** Hour angle and declination (°) of alt/az (°) at latitude (°). */
  function equatorial(alt, az, lat) {
    const a = alt * D2R, z = az * D2R, p = lat * D2R;
    const dec = Math.asin(Math.sin(p) * Math.sin(a) + Math.cos(p) * Math.cos(a) * Math.cos(z));
    const ha = Math.atan2(-Math.sin(z) * Math.cos(a), Math.cos(p) * Math.sin(a) - Math.sin(p) * Math.cos(a) * Math.cos(z));
    return [ha / D2R, dec / D2R];
  }

  /** RA/Dec (°) of the equinox of date back to J2000 (IAU 1976 precession, Meeus ch. 21: ~0.1″ here). */
  function toJ2000(ra, dec, when) {
    const t = (when - Date.UTC(2000, 0, 1, 12)) / (36525 * 86400000);
    const arcsec = D2R / 3600;
    const zeta = (2306.2181 + (0.30188 + 0.017998 * t) * t) * t * arcsec;
    const zz = (2306.2181 + (1.09468 + 0.018203 * t) * t) * t * arcsec;
    const theta = (2004.3109 - (0.42665 + 0.041833 * t) * t) * t * arcsec;
    const a = ra * D2R - zz, d = dec * D2R;
    const A = Math.cos(d) * Math.sin(a);
    const B = Math.cos(theta) * Math.cos(d) * Math.cos(a) + Math.sin(theta) * Math.sin(d);
    const C = -Math.sin(theta) * Math.cos(d) * Math.cos(a) + Math.cos(theta) * Math.sin(d);
    return [((Math.atan2(A, B) - zeta) / D2R % 360 + 360) % 360, Math.asin(C) / D2R];
  }

  /** Where the selection is now: the chart's own place for a star or body, else its apparent RA/Dec. */
  function selectedPlace() {
    const obj = chart.selected;
    if (!obj) return null;
    const body = chart.bodies.find((b) => b.id === obj.id);
    if (body) return [body.alt, body.az];
    const i = obj.id.startsWith("star:") && chart.stars ? chart.stars.findIndex((s) => "star:" + s[4] === obj.id) : -1;
    if (i >= 0 && chart.places) return chart.places[i];
    if (chart.lst === null || chart.latitude === null || typeof obj.ra !== "number") return [obj.altitude, obj.azimuth];
    return horizontal((chart.lst - obj.ra) * 15, obj.dec, chart.latitude);
  }

  async function refresh() {
    if (document.hidden && chart.places) return;
    try {
      const answer = await hook.request(hook.base + "/sky" + (chart.stars ? "" : "?catalogue=true"));
      if (answer.catalogue) {
        chart.stars = answer.catalogue.stars;
        chart.lines = answer.catalogue.lines;
      }
      chart.places = answer.stars;
      chart.bodies = answer.bodies;
      chart.latitude = answer.latitude;
      draw();
      $("sky-chart").dataset.time = answer.time; // the instant the places are for (tests read it)
    } catch (_) { /* the status poll reports an unreachable server */ }
  }

  // ---------------------------------------------------------------- tapping

  function offerBox() {
    let box = $("sky-offer");
    if (!box) {
      box = document.createElement("div");
      box.id = "sky-offer";
      box.className = "sky-offer";
      box.setAttribute("role", "status");
      $("sky").after(box);
    }
    return box;
  }

  function offer(text, buttonText, onClick) {
    const box = offerBox();
    box.replaceChildren();
    const p = document.createElement("p");
    p.id = "sky-offer-text";
    p.textContent = text;
    box.append(p);
    if (buttonText) {
      const b = document.createElement("button");
      b.type = "button";
      b.id = "sky-offer-select";
      b.textContent = buttonText;
      b.addEventListener("click", onClick);
      box.append(b);
    }
  }

  function choose(id, name) {
    if (typeof hook.select === "function") {
      hook.select(id);
      offer("Selected " + name + ".");
    } else {
      offer(name + " (selection needs the hand controller)");
    }
  }

  /** The star or body a tap at chart point x, y means: within TAP_PX screen pixels, the nearest after a
   * pull towards brighter things (a fingertip is wider than the gap between Vega and zeta Lyr at phone width). */
  function nearest(x, y, scale) {
    let best = null, bestScore = Infinity;
    const consider = (alt, az, bonus, found) => {
      if (alt < hook.MIN_ALT) return;
      const [px, py] = xy(alt, az);
      const d = Math.hypot(px - x, py - y) * scale;
      if (d <= TAP_PX && d - bonus < bestScore) { bestScore = d - bonus; best = found; }
    };
    for (const b of chart.bodies) consider(b.alt, b.az, 8, [b.id, b.name]);
    (chart.stars || []).forEach((s, i) => {
      const found = s[4] ? ["star:" + s[4], s[4]] : ["radec:" + (s[1] / 15).toFixed(7) + "," + s[2].toFixed(6), "HIP " + s[0]];
      consider(chart.places[i][0], chart.places[i][1], 1.5 * (4.5 - s[3]), found);
    });
    return best;
  }

  function offerPoint(x, y) {
    const r = Math.hypot(x, y);
    const alt = 90 - (r / hook.R) * 90;
    if (alt < 0 || alt > 90) return; // below the horizon or outside the chart: nothing to point at
    const az = ((Math.atan2(-x, -y) / D2R) % 360 + 360) % 360;
    if (chart.lst === null || chart.latitude === null) {
      offer("Alt " + hook.fmtDeg(alt) + "  Az " + hook.fmtAz(az) + " (RA/Dec once the status is in)");
      return;
    }
    const [ha, decDate] = equatorial(alt, az, chart.latitude);
    const raDate = ((chart.lst * 15 - ha) % 360 + 360) % 360;
    const [ra, dec] = toJ2000(raDate, decDate, chart.utc || Date.now());
    const text = "RA " + hook.fmtHours(ra / 15) + "  Dec " + hook.fmtDeg(dec) + " (J2000) \u00b7 Alt " +
      hook.fmtDeg(alt) + "  Az " + hook.fmtAz(az);
    const id = "radec:" + (ra / 15).toFixed(7) + "," + dec.toFixed(6);
    const box = offerBox();
    box.dataset.ra = (ra / 15).toFixed(7);
    box.dataset.dec = dec.toFixed(6);
    box.dataset.alt = alt.toFixed(4);
    box.dataset.az = az.toFixed(4);
    offer(text, typeof hook.select === "function" ? "Select these coordinates" : null,
      () => choose(id, "RA " + hook.fmtHours(ra / 15) + " Dec " + hook.fmtDeg(dec)));
  }

  function onTap(ev) {
    const svg = $("sky");
    const ctm = svg.getScreenCTM();
    if (!ctm) return;
    const pt = new DOMPoint(ev.clientX, ev.clientY).matrixTransform(ctm.inverse());
    const found = chart.places ? nearest(pt.x, pt.y, ctm.a) : null;
    if (found) choose(found[0], found[1]);
    else offerPoint(pt.x, pt.y);
  }

  // ---------------------------------------------------------------- start

  function start() {
    if (!hook || !$("sky")) return;
    $("sky").addEventListener("click", onTap);
    offer("Tap a star, a planet or the sky to select it.");
    hook.onStatus((s) => {
      chart.lst = s.time && typeof s.time.lst === "number" ? s.time.lst : null;
      chart.utc = s.time && s.time.utc ? Date.parse(s.time.utc) : null;
      if (chart.selected) placeSelection(); // it moves with the sky between the star refreshes
    });
    document.addEventListener("alpaca-zwo-selected", (ev) => {
      chart.selected = ev.detail;
      placeSelection();
    });
    refresh();
    setInterval(refresh, REFRESH_MS);
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
