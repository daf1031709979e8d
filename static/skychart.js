/* alpaca-zwo sky chart (issue 25 item 2, issue 33 item 6): stars to V 4.5, constellation lines, deep-sky
 * objects, Sun, Moon and planets on app.js's all-sky alt-az chart (#sky, layer #sky-chart under the telescope
 * and target markers), their labels, the legend, the selection, tap-to-select and the keyboard.
 *
 * The server computes every place (GET …/sky: PyEphem topocentric apparent alt/az, the GoTo's frame); this
 * file asks for the lists once and for the places every 30 s, and draws them with app.js's project(), which
 * also turns the chart for the hemisphere (docs/objects.md). Labels are placed by one pass that keeps them
 * off each other, the chart's own lettering, the meridian and flip lines and the bright dots; a label with
 * no free place is left out (the object is still tappable and announced). The legend is drawn with the
 * chart's own elements and classes, so it cannot disagree with it. A tap within TAP_PX of an object
 * selects it through handset.js (window.alpacaZwo.select); a tap on empty sky offers that point's J2000
 * RA/Dec. With the chart focused, the arrow keys move a choice between the bright objects (announced in
 * the status line under the chart) and Enter selects it.
 */
"use strict";

(function () {
  const hook = window.alpacaZwo;
  const $ = (id) => document.getElementById(id);
  const SVG = "http://www.w3.org/2000/svg";
  const REFRESH_MS = 30000; // a star moves 0.125° in 30 s: under a pixel of the chart at phone width
  const TAP_PX = 12; // touch-friendly: a fingertip is ~10 mm
  const LABEL_MAG = 1.0; // names for the brightest stars only (about 15 of them, the half above the horizon)
  const DSO_LABEL_MAG = 6.0; // names for the deep-sky showpieces with a name (the Magellanic Clouds, M31, ω Cen, 47 Tuc …)
  const DSO_NUMBER_MAG = 3.5; // … and for those known by number only when this bright (NGC 6231)
  const KEY_MAG = 2.0; // the keyboard moves between the bodies, stars to this magnitude and the labelled deep-sky objects
  const D2R = Math.PI / 180;
  const COMPASS = ["N", "NNE", "NE", "ENE", "E", "ESE", "SE", "SSE", "S", "SSW", "SW", "WSW", "W", "WNW", "NW", "NNW"];

  const chart = {
    stars: null, lines: null, places: null, dsos: [], dsoPlaces: [], bodies: [], latitude: null, lst: null, utc: null,
    time: null, selected: null, items: [], cursor: null,
  };

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

  function fmtMag(mag) {
    return mag === null || mag === undefined ? "" : ", magnitude " + mag.toFixed(1);
  }

  // ---------------------------------------------------------------- symbols (the chart and its legend)

  function scopeSymbol(g) {
    el("circle", { cx: 0, cy: 0, r: 5.5 }, g);
    for (const [x1, y1, x2, y2] of [[-10, 0, -6, 0], [6, 0, 10, 0], [0, -10, 0, -6], [0, 6, 0, 10]]) {
      el("line", { x1, y1, x2, y2 }, g);
    }
  }

  /** A deep-sky object's symbol, ``r`` chart units across half its size: the kind by shape, not colour. */
  function dsoSymbol(g, shape, r) {
    if (shape === "galaxy") el("ellipse", { cx: 0, cy: 0, rx: r, ry: +(r * 0.55).toFixed(2) }, g);
    else if (shape === "nebula" || shape === "dark") el("rect", { x: -r, y: -r, width: 2 * r, height: 2 * r }, g);
    else el("circle", { cx: 0, cy: 0, r }, g);
    if (shape === "globular") el("path", { d: "M" + -r + " 0H" + r + "M0 " + -r + "V" + r }, g);
    if (shape === "planetary") el("path", { d: "M" + -r * 1.6 + " 0H" + -r + "M" + r + " 0H" + r * 1.6 + "M0 " + -r * 1.6 + "V" + -r + "M0 " + r + "V" + r * 1.6 }, g);
  }

  function dsoRadius(sizeDeg) {
    return Math.max(1.4, Math.min(12, (sizeDeg / 2) * (hook.R / 90)));
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

  function starFound(s) {
    if (s[4]) return ["star:" + s[4], s[4], "star"];
    const designation = (s[5] || "").split(";")[0];
    return ["hip:" + s[0], designation || "HIP " + s[0], "star"];
  }

  function drawStars(layer, visible, labels, keep) {
    const g = el("g", { class: "sky-stars" }, layer);
    chart.stars.forEach((star, i) => {
      if (!visible[i]) return;
      const [alt, az] = chart.places[i];
      const [x, y] = xy(alt, az);
      const r = starRadius(star[3]);
      el("circle", { cx: x, cy: y, r, class: alt < 0 ? "sky-star below" : "sky-star",
        "data-hip": star[0], "data-name": star[4] || "" }, g);
      if (star[3] <= 2.5 && alt > 0) keep.push(box(x - r, y - r, x + r, y + r));
      if (star[4] && star[3] <= LABEL_MAG && alt > 0) labels.push({ text: star[4], x, y, r, cls: "sky-star-name", rank: 2 + star[3] });
      const [id, name, kind] = starFound(star);
      if (alt > 0 && star[3] <= KEY_MAG) chart.items.push({ id, name, kind, alt, az, mag: star[3], x, y });
    });
  }

  function drawDsos(layer, labels, keep) {
    const g = el("g", { class: "sky-dsos" }, layer);
    chart.dsos.forEach((d, i) => {
      const place = chart.dsoPlaces[i];
      if (!place || place[0] < hook.MIN_ALT) return;
      const [alt, az] = place;
      const [x, y] = xy(alt, az);
      const r = dsoRadius(d[8]);
      const node = el("g", { class: "sky-dso " + d[4] + (alt < 0 ? " below" : ""), "data-id": d[0],
        transform: "translate(" + x + " " + y + ")" }, g);
      dsoSymbol(node, d[4], r);
      el("title", {}, node).textContent = d[1] + (d[2] && d[2] !== d[1] ? " (" + d[2] + ")" : "");
      const numbered = /^(NGC|IC) /.test(d[2]);
      const shown = numbered ? d[7] !== null && d[7] <= DSO_NUMBER_MAG : d[7] === null || d[7] <= DSO_LABEL_MAG || d[8] >= 2;
      if (alt > 0 && shown) {
        labels.push({ text: d[2], x, y, r: Math.min(r, 4), cls: "sky-dso-name", rank: 10 + (d[7] === null ? 6 : d[7]) });
        keep.push(box(x - Math.min(r, 3), y - Math.min(r, 3), x + Math.min(r, 3), y + Math.min(r, 3)));
        chart.items.push({ id: d[0], name: d[1] + (d[2] !== d[1] ? " (" + d[2] + ")" : ""), kind: d[3], alt, az, mag: d[7], x, y });
      }
    });
  }

  function drawBodies(layer, labels, keep) {
    const g = el("g", { class: "sky-bodies" }, layer);
    for (const b of chart.bodies) {
      if (b.alt < hook.MIN_ALT) continue;
      const [x, y] = xy(b.alt, b.az);
      const big = b.name === "Sun" || b.name === "Moon";
      const node = el("g", { class: "sky-body " + b.name.toLowerCase() + (b.alt < 0 ? " below" : ""),
        "data-id": b.id, transform: "translate(" + x + " " + y + ")" }, g);
      const r = big ? 3.2 : 1.9;
      el("circle", { cx: 0, cy: 0, r }, node);
      keep.push(box(x - r, y - r, x + r, y + r));
      labels.push({ text: b.name, x, y, r, cls: "sky-body-name", rank: big ? 0 : 1, parent: node, must: true });
      if (b.alt > 0) chart.items.push({ id: b.id, name: b.name, kind: b.name === "Sun" ? "the Sun" : b.name === "Moon" ? "the Moon" : "planet", alt: b.alt, az: b.az, mag: b.mag, x, y });
    }
  }

  // ---------------------------------------------------------------- labels

  function box(x0, y0, x1, y1) {
    return { x0, y0, x1, y1 };
  }

  function overlaps(a, b) {
    return a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
  }

  /** Does the segment cross the box? (Liang–Barsky clipping.) */
  function crosses(seg, b) {
    const [x1, y1, x2, y2] = seg;
    let t0 = 0, t1 = 1;
    const dx = x2 - x1, dy = y2 - y1;
    for (const [p, q] of [[-dx, x1 - b.x0], [dx, b.x1 - x1], [-dy, y1 - b.y0], [dy, b.y1 - y1]]) {
      if (p === 0) { if (q < 0) return false; continue; }
      const t = q / p;
      if (p < 0) { if (t > t1) return false; if (t > t0) t0 = t; } else { if (t < t0) return false; if (t < t1) t1 = t; }
    }
    return true;
  }

  /** Move a centred text (.sky-small) so its box is the box given. */
  function putCentred(t, b, dx, dy) {
    const bb = t.getBBox();
    t.setAttribute("x", ((b.x0 + b.x1) / 2 - dx).toFixed(2));
    t.setAttribute("y", (b.y0 - dy + (Number(t.getAttribute("y")) - bb.y)).toFixed(2));
  }

  /** Where app.js's movable lettering goes: each ring's altitude beside the meridian where no line crosses it
   * (below the zenith, else above it, right or left of the meridian), "pole" beside its mark. */
  function placeChartLetters(svg, taken, free) {
    const spots = [];
    for (const t of svg.querySelectorAll(".ring-label")) {
      const r = Number(t.getAttribute("data-ring"));
      const bb = t.getBBox();
      const [w, h] = [bb.width || 10, bb.height || 7];
      spots.push([t, 0, 0, [[2, r - 1 - h], [-2 - w, r - 1 - h], [2, -r + 1], [-2 - w, -r + 1], [2, r + 1], [-2 - w, r + 1]]
        .map(([x0, y0]) => box(x0, y0, x0 + w, y0 + h))]);
    }
    const pole = svg.querySelector("#sky-pole");
    const poleText = pole && pole.querySelector("text");
    const at = pole && /translate\(([-\d.]+) ([-\d.]+)\)/.exec(pole.getAttribute("transform") || "");
    if (poleText && at) {
      const [px, py] = [Number(at[1]), Number(at[2])];
      const bb = poleText.getBBox();
      const [w, h] = [bb.width || 12, bb.height || 7];
      const around = [];
      for (const d of [4, 7, 11]) {
        around.push([px + d, py - h / 2], [px - d - w, py - h / 2], [px - w / 2, py - d - h], [px - w / 2, py + d],
          [px + d * 0.7, py - d * 0.7 - h], [px - d * 0.7 - w, py - d * 0.7 - h], [px + d * 0.7, py + d * 0.7], [px - d * 0.7 - w, py + d * 0.7]);
      }
      spots.push([poleText, px, py, around.map(([x0, y0]) => box(x0, y0, x0 + w, y0 + h))]);
    }
    for (const [t, dx, dy, candidates] of spots) {
      const b = candidates.find((c) => free(c)) || candidates[0];
      putCentred(t, b, dx, dy);
      taken.push(b);
    }
  }

  /** The chart's own lettering and lines (app.js): compass letters, "pole", meridian, flip line. */
  function fixedObstacles() {
    const svg = $("sky");
    const inverse = svg.getScreenCTM();
    const boxes = [];
    const segments = [];
    if (!inverse) return { boxes, segments };
    const m = inverse.inverse();
    for (const t of svg.querySelectorAll("text")) {
      if (t.closest("#sky-chart") || t.closest(".hidden") || t.closest("#sky-pole") || t.classList.contains("ring-label")) continue;
      const r = t.getBoundingClientRect();
      if (!r.width) continue;
      const a = new DOMPoint(r.left, r.top).matrixTransform(m), b = new DOMPoint(r.right, r.bottom).matrixTransform(m);
      boxes.push(box(a.x - 0.5, a.y - 0.5, b.x + 0.5, b.y + 0.5));
    }
    for (const line of svg.querySelectorAll(".sky-meridian")) {
      segments.push([+line.getAttribute("x1"), +line.getAttribute("y1"), +line.getAttribute("x2"), +line.getAttribute("y2")]);
    }
    for (const poly of svg.querySelectorAll(".sky-flip")) {
      const pts = (poly.getAttribute("points") || "").trim().split(/\s+/).filter(Boolean).map((p) => p.split(",").map(Number));
      for (let i = 1; i < pts.length; i++) segments.push([...pts[i - 1], ...pts[i]]);
    }
    return { boxes, segments };
  }

  /** Put each label where it collides with nothing placed before it; bodies first, then bright stars, then
   * deep-sky objects. Returns the number left out. */
  function placeLabels(layer, labels, keep) {
    const group = el("g", { class: "sky-names" }, layer);
    const { boxes, segments } = fixedObstacles();
    const taken = boxes.concat(keep);
    const outer = ((90 - hook.MIN_ALT) / 90) * hook.R - 1;
    const free = (b, self) => taken.every((t) => t === self || !overlaps(t, b)) && segments.every((s) => !crosses(s, b)) &&
      [[b.x0, b.y0], [b.x1, b.y0], [b.x0, b.y1], [b.x1, b.y1]].every(([x, y]) => Math.hypot(x, y) < outer);
    placeChartLetters($("sky"), taken, free);
    let dropped = 0;
    labels.sort((a, b) => a.rank - b.rank);
    for (const label of labels) {
      const text = el("text", { x: 0, y: 0, class: label.cls }, label.parent || group);
      text.textContent = label.text;
      let w = 0, h = 0, base = 0, lead = 0; // lead: the box can start left of x (a J's hook in some fonts)
      try {
        const bb = text.getBBox();
        w = bb.width; h = bb.height; base = -bb.y; lead = -bb.x;
      } catch (_) { /* not rendered */ }
      if (!w) { w = label.text.length * 3.1; h = 6.5; base = 5; }
      const own = keep.find((k) => Math.abs((k.x0 + k.x1) / 2 - label.x) < 0.01 && Math.abs((k.y0 + k.y1) / 2 - label.y) < 0.01);
      let spot = null;
      for (const gap of [1, 3.5, 7, 10.5]) {
        const d = label.r + gap;
        const c = d * 0.72;
        for (const [x0, y0] of [[label.x + d, label.y - h / 2], [label.x - d - w, label.y - h / 2],
          [label.x - w / 2, label.y - d - h], [label.x - w / 2, label.y + d], [label.x + c, label.y - c - h],
          [label.x + c, label.y + c], [label.x - c - w, label.y - c - h], [label.x - c - w, label.y + c]]) {
          const b = box(x0, y0, x0 + w, y0 + h);
          if (free(b, own)) { spot = b; break; }
        }
        if (spot) break;
      }
      if (!spot) {
        text.remove();
        dropped += 1;
        continue;
      }
      taken.push(spot);
      const dx = label.parent ? label.x : 0, dy = label.parent ? label.y : 0; // bodies' labels sit in their group
      text.setAttribute("x", (spot.x0 + lead - dx).toFixed(2));
      text.setAttribute("y", (spot.y0 + base - dy).toFixed(2));
    }
    group.dataset.dropped = String(dropped);
    return dropped;
  }

  // ---------------------------------------------------------------- the selection and the keyboard choice

  function placeMark(id, cls, r, place) {
    const layer = $("sky-chart");
    if (!layer) return;
    let mark = $(id);
    if (!place || place[0] < hook.MIN_ALT) {
      if (mark) mark.remove();
      return;
    }
    if (!mark) mark = el("circle", { id, r, class: cls }, layer);
    const [x, y] = xy(...place);
    mark.setAttribute("cx", x);
    mark.setAttribute("cy", y);
  }

  function placeSelection() {
    placeMark("sky-selected", "sky-selected", 4.5, selectedPlace());
  }

  function placeCursor() {
    const item = chart.cursor && chart.items.find((i) => i.id === chart.cursor);
    placeMark("sky-cursor", "sky-cursor", 6.5, item && document.activeElement === $("sky") ? [item.alt, item.az] : null);
  }

  function draw() {
    const layer = $("sky-chart");
    if (!layer || !chart.places) return;
    layer.replaceChildren();
    chart.items = [];
    const visible = chart.places.map(([alt]) => alt >= hook.MIN_ALT);
    const labels = [], keep = [];
    drawLines(layer, visible);
    drawDsos(layer, labels, keep);
    drawStars(layer, visible, labels, keep);
    drawBodies(layer, labels, keep);
    placeLabels(layer, labels, keep);
    placeSelection();
    placeCursor();
    syncLegend();
    if (chart.time) layer.dataset.time = chart.time; // the instant the places are for (tests read it)
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

  /** Where the selection is now: the chart's own place for a star, deep-sky object or body, else its apparent RA/Dec. */
  function selectedPlace() {
    const obj = chart.selected;
    if (!obj) return null;
    const body = chart.bodies.find((b) => b.id === obj.id);
    if (body) return [body.alt, body.az];
    const i = chart.stars && chart.places ? chart.stars.findIndex((s) => starFound(s)[0] === obj.id) : -1;
    if (i >= 0) return chart.places[i];
    const j = chart.dsos.findIndex((d) => d[0] === obj.id);
    if (j >= 0 && chart.dsoPlaces[j]) return chart.dsoPlaces[j];
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
        chart.dsos = answer.catalogue.dsos || [];
      }
      chart.places = answer.stars;
      chart.dsoPlaces = answer.dsos || [];
      chart.bodies = answer.bodies;
      chart.latitude = answer.latitude;
      chart.time = answer.time;
      draw();
    } catch (_) { /* the status poll reports an unreachable server */ }
  }

  // ---------------------------------------------------------------- the legend

  // Each entry is drawn with the chart's own symbols and classes: [key, [[classes, draw, word], ...], label].
  const LEGEND = [
    ["scope", [["sky-scope", scopeSymbol, "tracking"], ["sky-scope slewing", scopeSymbol, "slewing"],
      ["sky-scope idle", scopeSymbol, "not tracking"], ["sky-scope danger", scopeSymbol, "below limits"]], "telescope:"],
    ["trail", [["sky-trail", (g) => el("polyline", { points: "-8,4 -3,-1 3,1 8,-4" }, g)]], "its recent path"],
    ["target", [["sky-target", (g) => el("circle", { cx: 2, cy: 0, r: 5 }, g)], ["sky-path", (g) => el("line", { x1: -9, y1: 0, x2: -3, y2: 0 }, g)]], "GoTo target"],
    ["selected", [["sky-selected", (g) => el("circle", { cx: 0, cy: 0, r: 4.5 }, g)]], "selected"],
    ["cursor", [["sky-cursor", (g) => el("circle", { cx: 0, cy: 0, r: 6.5 }, g)]], "chosen with the keys"],
    ["stars", [["sky-star", (g) => { el("circle", { cx: -4, cy: 0, r: 2.2 }, g); el("circle", { cx: 3, cy: 1, r: 1.2 }, g); el("circle", { cx: 7, cy: -2, r: 0.6 }, g); }]], "stars to magnitude 4.5"],
    ["lines", [["sky-line", (g) => el("path", { d: "M-8 3L-1 -2L8 1" }, g)]], "constellations"],
    ["dso", [["sky-dso galaxy", (g) => dsoSymbol(g, "galaxy", 5), "galaxy"], ["sky-dso open", (g) => dsoSymbol(g, "open", 4), "cluster"],
      ["sky-dso globular", (g) => dsoSymbol(g, "globular", 4), "globular"], ["sky-dso nebula", (g) => dsoSymbol(g, "nebula", 3.5), "nebula"],
      ["sky-dso planetary", (g) => dsoSymbol(g, "planetary", 2.5), "planetary"], ["sky-dso dark", (g) => dsoSymbol(g, "dark", 3.5), "dark nebula"]], "deep sky:"],
    ["bodies", [["sky-body sun", (g) => el("circle", { cx: 0, cy: 0, r: 3.2 }, g), "Sun"], ["sky-body moon", (g) => el("circle", { cx: 0, cy: 0, r: 3.2 }, g), "Moon"],
      ["sky-body planet", (g) => el("circle", { cx: 0, cy: 0, r: 1.9 }, g), "planets"]], ""],
    ["horizon", [["sky-horizon", (g) => el("path", { d: "M-9 4Q0 -6 9 4" }, g)]], "horizon (0\u00b0)"],
    ["rings", [["sky-ring", (g) => el("path", { d: "M-9 4Q0 -6 9 4" }, g)]], "30\u00b0 and 60\u00b0 altitude"],
    ["ground", [["sky-ground-key", (g) => { el("rect", { x: -9, y: -1, width: 18, height: 8, class: "sky-ground" }, g); el("path", { d: "M-9 -1H9", class: "sky-floor" }, g); }]], "below your horizon limits"],
    ["mlimit", [["sky-mlimit", (g) => el("path", { d: "M-9 4Q0 -6 9 4" }, g)]], "the mount's altitude limits"],
    ["meridian", [["sky-meridian", (g) => el("line", { x1: 0, y1: -8, x2: 0, y2: 8 }, g)]], "meridian"],
    ["flip", [["sky-flip", (g) => el("polyline", { points: "-2,-8 0,0 2,8" }, g)]], "flip limit"],
    ["pole", [["sky-pole", (g) => el("circle", { cx: 0, cy: 0, r: 2.5 }, g), "celestial pole"], ["sky-pole", (g) => el("path", { d: "M -3 0 H 3 M 0 -3 V 3" }, g), "zenith"]], ""],
  ];

  function buildLegend() {
    const list = $("sky-legend");
    if (!list) return;
    list.replaceChildren();
    for (const [key, swatches, label] of LEGEND) {
      const li = document.createElement("li");
      li.dataset.legend = key;
      const named = swatches.some((sw) => sw[2]); // "telescope: [] tracking [] slewing", else "[] meridian"
      if (label && named) li.append(label);
      for (const [cls, drawSwatch, word] of swatches) {
        const pair = document.createElement("span");
        pair.className = "pair";
        li.append(pair);
        const svg = el("svg", { class: "swatch", viewBox: "-11 -11 22 22", "aria-hidden": "true" }, pair);
        const g = el("g", { class: cls }, svg);
        drawSwatch(g);
        // Classes on the group for shapes styled as "group child" (.sky-scope circle); on the shape itself otherwise.
        if (!/^sky-(scope|dso|body|ground-key)/.test(cls)) {
          for (const child of g.children) if (!child.getAttribute("class")) child.setAttribute("class", cls);
          g.removeAttribute("class");
        }
        if (word) pair.append(word);
      }
      if (label && !named) li.append(label);
      list.append(li);
    }
    syncLegend();
  }

  /** Entries for what is drawn only sometimes (the mount's limits, a flip line off the meridian) follow the drawing. */
  function syncLegend() {
    const svg = $("sky");
    const list = $("sky-legend");
    if (!svg || !list) return;
    const flip = svg.querySelector(".sky-flip");
    const shown = {
      mlimit: Boolean(svg.querySelector("circle.sky-mlimit")),
      flip: Boolean(flip && (flip.getAttribute("points") || "").trim()),
    };
    for (const [key, on] of Object.entries(shown)) {
      const li = list.querySelector("[data-legend='" + key + "']");
      if (li) li.classList.toggle("hidden", !on);
    }
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
      hook.select(id, "chart"); // on a phone its card opens as a sheet above STOP, the chart in view
      offer("Selected " + name + ".");
    } else {
      offer(name + " (selection needs the hand controller)");
    }
  }

  /** The object a tap at chart point x, y means: within TAP_PX screen pixels, the nearest after a pull
   * towards brighter things (a fingertip is wider than the gap between Vega and zeta Lyr at phone width). */
  function nearest(x, y, scale) {
    let best = null, bestScore = Infinity;
    const consider = (alt, az, bonus, found) => {
      if (alt < hook.MIN_ALT) return;
      const [px, py] = xy(alt, az);
      const d = Math.hypot(px - x, py - y) * scale;
      if (d <= TAP_PX && d - bonus < bestScore) { bestScore = d - bonus; best = found; }
    };
    for (const b of chart.bodies) consider(b.alt, b.az, 8, [b.id, b.name]);
    (chart.stars || []).forEach((s, i) => consider(chart.places[i][0], chart.places[i][1], 1.5 * (4.5 - s[3]), starFound(s)));
    chart.dsos.forEach((d, i) => {
      if (chart.dsoPlaces[i]) consider(chart.dsoPlaces[i][0], chart.dsoPlaces[i][1], d[7] === null ? 1 : Math.max(0, 1.2 * (7 - d[7])), [d[0], d[1]]);
    });
    return best;
  }

  function offerPoint(x, y) {
    // A tap on empty sky is a new question: a phone's sheet (the last object's card) gives way to the answer.
    if (typeof hook.closeCard === "function") hook.closeCard();
    const [alt, az] = hook.unproject(x, y);
    if (alt < 0 || alt > 90) return; // below the horizon or outside the chart: nothing to point at
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

  // ---------------------------------------------------------------- the keyboard

  function describe(item) {
    return item.name + ": " + item.kind + fmtMag(item.mag) + "; altitude " + Math.round(item.alt) + "\u00b0, azimuth " +
      Math.round(item.az) + "\u00b0 (" + COMPASS[Math.round(item.az / 22.5) % 16] + "). Enter selects it.";
  }

  /** The bright object the arrow key leads to: ahead in that screen direction (within 60° of it), the
   * nearest counting sideways distance double. */
  function step(from, dx, dy) {
    let best = null, bestScore = Infinity;
    for (const item of chart.items) {
      if (item === from) continue;
      const along = (item.x - from.x) * dx + (item.y - from.y) * dy;
      const side = Math.abs((item.x - from.x) * dy - (item.y - from.y) * dx);
      if (along <= 0 || side > along * 1.75) continue;
      const score = along + 2 * side;
      if (score < bestScore) { bestScore = score; best = item; }
    }
    return best;
  }

  const ARROWS = { ArrowRight: [1, 0, "right"], ArrowLeft: [-1, 0, "left"], ArrowUp: [0, -1, "up"], ArrowDown: [0, 1, "down"] };

  function onKey(ev) {
    if (ev.altKey || ev.ctrlKey || ev.metaKey) return;
    const current = chart.items.find((i) => i.id === chart.cursor) || null;
    if ((ev.key === "Enter" || ev.key === " ") && current) {
      ev.preventDefault();
      choose(current.id, current.name);
      return;
    }
    const arrow = ARROWS[ev.key] || (ev.key === "Home" ? [0, 0, "home"] : null);
    if (!arrow) return;
    ev.preventDefault();
    if (!chart.items.length) {
      offer("No bright object is above the horizon to choose.");
      return;
    }
    const brightest = () => chart.items.slice().sort((a, b) => (a.mag ?? 99) - (b.mag ?? 99))[0];
    const selected = chart.selected && chart.items.find((i) => i.id === chart.selected.id);
    const next = !current || arrow[2] === "home" ? selected || brightest() : step(current, arrow[0], arrow[1]);
    if (!next) {
      offer("Nothing bright further " + arrow[2] + " of " + current.name + ".");
      return;
    }
    chart.cursor = next.id;
    placeCursor();
    offer(describe(next));
  }

  // ---------------------------------------------------------------- start

  function start() {
    if (!hook || !$("sky")) return;
    const svg = $("sky");
    svg.addEventListener("click", onTap);
    svg.addEventListener("keydown", onKey);
    svg.addEventListener("focus", placeCursor);
    svg.addEventListener("blur", placeCursor);
    buildLegend();
    offer("Tap a star, a planet, a deep-sky object or the sky to select it.");
    hook.onStatus((s) => {
      chart.lst = s.time && typeof s.time.lst === "number" ? s.time.lst : null;
      chart.utc = s.time && s.time.utc ? Date.parse(s.time.utc) : null;
      if (chart.selected) placeSelection(); // it moves with the sky between the star refreshes
    });
    document.addEventListener("alpaca-zwo-selected", (ev) => {
      chart.selected = ev.detail;
      placeSelection();
    });
    document.addEventListener("alpaca-zwo-sky-turned", draw); // app.js rebuilt the chart for the other way up
    document.addEventListener("alpaca-zwo-sky-geometry", () => { draw(); syncLegend(); });
    refresh();
    setInterval(refresh, REFRESH_MS);
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
