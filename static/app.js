/* alpaca-zwo setup page: polls /setup/api/.../status once a second and drives the controls.
 *
 * Plain JavaScript with no external assets: the page is used in a field with no internet.
 * Every state-changing request is a same-origin POST with a JSON body and the X-Alpaca-Zwo
 * header, which the server requires so that other web sites cannot move the telescope.
 */
"use strict";

(function () {
  const SVG = "http://www.w3.org/2000/svg";
  const POLL_MS = 1000;
  const TRAIL_POINTS = 240;

  const match = /^\/setup\/v1\/telescope\/(\d+)\/setup\/?$/.exec(location.pathname);
  const device = match ? Number(match[1]) : 0;
  const base = "/setup/api/telescope/" + device;

  const $ = (id) => document.getElementById(id);
  const state = {
    status: null,
    server: null,
    connected: false,
    trail: [],
    pollFailures: 0,
    logAfter: 0,
    traceAfter: 0,
    floorKey: "",
    flipKey: "",
    limitKey: "",
    jogging: null,
  };

  // ---------------------------------------------------------------- requests

  async function request(path, options) {
    let response;
    try {
      response = await fetch(path, Object.assign({ cache: "no-store", credentials: "same-origin" }, options));
    } catch (err) {
      throw new Error("the server cannot be reached (" + err.message + ")");
    }
    const type = response.headers.get("Content-Type") || "";
    const body = type.includes("application/json") ? await response.json() : await response.text();
    if (!response.ok) {
      const text = typeof body === "string" ? body.trim() : body.error;
      throw new Error(text || "HTTP " + response.status);
    }
    return body;
  }

  function post(path, body) {
    return request(path, {
      method: "POST",
      headers: { "Content-Type": "application/json", "X-Alpaca-Zwo": "1" },
      body: JSON.stringify(body || {}),
    });
  }

  function action(name, body) {
    return post(base + "/action/" + name, body);
  }

  // ---------------------------------------------------------------- messages

  // One message place, in STOP's bar (index.html): the page is padded by the bar's height, so a message
  // never lies over a control, and a phone's object sheet sits above it. The newest message replaces the one
  // before; every message also goes into the server's log, which is their history (the Log panel, the
  // download). A refusal caused by a control (near: the button or its form) is shown beside that control
  // instead, where the eye already is. A success fades after a few seconds and clears every error shown
  // before it (the situation they described has changed); an error stays until dismissed, replaced by a
  // newer message, or the selection changes.
  let fadeTimer = null;

  function message(text, kind, near) {
    const type = kind || "error";
    keepInLog(text, type);
    clearTimeout(fadeTimer);
    const area = $("messages");
    area.replaceChildren();
    for (const old of document.querySelectorAll(".refusal")) old.remove(); // the newest only, there too
    if (near && type === "error") {
      refusalBeside(near).textContent = text;
      return;
    }
    const box = document.createElement("div");
    box.className = "msg " + type;
    if (type === "error") box.setAttribute("role", "alert");
    const span = document.createElement("span");
    span.textContent = text;
    const close = document.createElement("button");
    close.type = "button";
    close.textContent = "\u00d7";
    close.setAttribute("aria-label", "Dismiss");
    close.title = "Dismiss";
    close.addEventListener("click", () => box.remove());
    box.append(span, close);
    area.append(box);
    if (type === "info") fadeTimer = setTimeout(() => box.remove(), 3500);
  }

  // The refusal line beside a control: a new one under its row or form.
  function refusalBeside(near) {
    const box = document.createElement("p");
    box.className = "refusal";
    box.setAttribute("role", "alert");
    besideOf(near).after(box);
    return box;
  }

  function besideOf(near) {
    return near.closest("form, .row") || near;
  }

  /** The control's next action succeeded: the refusal beside it no longer holds (a quiet success says nothing
   * in the message place, which would clear it). */
  function clearBeside(near) {
    const next = besideOf(near).nextElementSibling;
    if (next && next.classList.contains("refusal")) next.remove();
  }

  /** Clear the message place and every refusal: what they described belongs to the last selection. */
  function clearMessages() {
    clearTimeout(fadeTimer);
    $("messages").replaceChildren();
    for (const box of document.querySelectorAll(".refusal")) box.remove();
  }

  function keepInLog(text, level) {
    post("/setup/api/log", { text, level: level === "error" ? "error" : "info" }).catch(() => { /* the server is unreachable: the message says so */ });
  }

  // A control's failure said as what did not happen ("Horizon saved." → "Horizon not saved"); the reason follows.
  const FAILED = {
    "Mount connected.": "The mount did not connect", "Released the mount.": "The mount was not released",
    "Parking\u2026": "The mount did not park", "Unparked.": "The mount did not unpark",
    "Going home\u2026": "The mount did not go home", "Tracking on.": "Tracking did not turn on",
    "Tracking off.": "Tracking did not turn off", "Discovery done.": "Nothing was found",
    "Test done.": "The test was not made",
  };

  function failedText(label) {
    if (FAILED[label]) return FAILED[label];
    const done = / (saved|set|sent)\b/.exec(label);
    return done ? label.slice(0, done.index) + " not " + done[1] : label.replace(/[.\u2026]$/, "") + " did not work";
  }

  // Run a control; show its error (beside near, when given), refresh the status at once so the effect is visible.
  async function run(label, fn, quietOk, near) {
    try {
      const result = await fn();
      if (!quietOk) message(label, "info");
      else if (near) clearBeside(near);
      poll(true);
      return result;
    } catch (err) {
      message(failedText(label) + ": " + err.message, "error", near);
      return null;
    }
  }

  // ---------------------------------------------------------------- formatting

  function pad(n, width) {
    return String(n).padStart(width, "0");
  }

  function sexagesimal(value, unitsPerCircle, decimals) {
    const sign = value < 0 ? "-" : "+";
    let rest = Math.abs(value);
    let whole = Math.floor(rest);
    rest = (rest - whole) * 60;
    let minutes = Math.floor(rest);
    let seconds = (rest - minutes) * 60;
    const factor = Math.pow(10, decimals);
    seconds = Math.round(seconds * factor) / factor;
    if (seconds >= 60) { seconds -= 60; minutes += 1; }
    if (minutes >= 60) { minutes -= 60; whole += 1; }
    if (unitsPerCircle && whole >= unitsPerCircle) whole -= unitsPerCircle;
    const secText = decimals ? seconds.toFixed(decimals).padStart(3 + decimals, "0") : pad(seconds, 2);
    return { sign, whole, minutes: pad(minutes, 2), seconds: secText };
  }

  function fmtHours(h) {
    if (h === null || h === undefined) return "\u2013";
    const p = sexagesimal(((h % 24) + 24) % 24, 24, 1);
    return pad(p.whole, 2) + "h " + p.minutes + "m " + p.seconds + "s";
  }

  function fmtHa(h) {
    if (h === null || h === undefined) return "\u2013";
    const p = sexagesimal(h, 0, 0);
    return (p.sign === "-" ? "\u2212" : "+") + p.whole + "h " + p.minutes + "m " + p.seconds + "s";
  }

  function fmtDeg(d) {
    if (d === null || d === undefined) return "\u2013";
    const p = sexagesimal(d, 0, 0);
    return (p.sign === "-" ? "\u2212" : "+") + pad(p.whole, 2) + "\u00b0 " + p.minutes + "\u2032 " + p.seconds + "\u2033";
  }

  // Azimuth 0-360 in degrees, minutes, seconds (like RA/Dec; altitude uses fmtDeg).
  function fmtAz(d) {
    if (d === null || d === undefined) return "\u2013";
    const p = sexagesimal(((d % 360) + 360) % 360, 360, 0);
    return pad(p.whole, 3) + "\u00b0 " + p.minutes + "\u2032 " + p.seconds + "\u2033";
  }

  function fmtDuration(seconds) {
    if (seconds === null || seconds === undefined) return "\u2013";
    const s = Math.abs(seconds);
    if (s < 1) return (seconds * 1000).toFixed(0) + " ms";
    if (s < 90) return seconds.toFixed(1) + " s";
    if (s < 5400) return (seconds / 60).toFixed(0) + " min";
    return (seconds / 3600).toFixed(1) + " h";
  }

  function fmtMinutes(m) {
    const sign = m < 0 ? "\u2212" : "";
    const a = Math.abs(m);
    return sign + Math.floor(a / 60) + "h " + pad(Math.floor(a % 60), 2) + "m";
  }

  function setText(id, text, cls) {
    const el = $(id);
    if (el.textContent !== text) el.textContent = text;
    const wanted = cls || "";
    if (el.className !== wanted) el.className = wanted;
  }

  function yesNo(value, yesClass) {
    return value ? ["yes", yesClass || "yes"] : ["no", ""];
  }

  // ---------------------------------------------------------------- sky plot

  const R = 100; // radius of the horizon (altitude 0)
  const MIN_ALT = -10; // the plot shows a little below the horizon
  // The chart is the sky looking up, held with the horizon you face at the bottom. Facing the equator
  // (where the Sun, Moon and planets are) is the default: south at the bottom in the northern hemisphere
  // and at the equator, north at the bottom (south at the top, east on the right) in the southern;
  // "Turn" faces the pole instead (docs/objects.md, "The chart's orientation").
  const FACING_KEY = "alpaca-zwo-chart-facing";
  const view = { up: 0, latitude: null }; // up: the azimuth at the top of the chart, 0 or 180

  function project(az, alt) {
    const a = Math.max(alt, MIN_ALT);
    const r = ((90 - a) / 90) * R;
    const t = ((az - view.up) * Math.PI) / 180;
    return [-r * Math.sin(t), -r * Math.cos(t)];
  }

  /** Alt/az (degrees) of a chart point (the inverse of project above the plot's lower edge). */
  function unproject(x, y) {
    const alt = 90 - (Math.hypot(x, y) / R) * 90;
    const az = ((Math.atan2(-x, -y) * 180) / Math.PI + view.up + 720) % 360;
    return [alt, az];
  }

  function facing() {
    let stored = null;
    try { stored = localStorage.getItem(FACING_KEY); } catch (_) { /* storage disabled */ }
    return stored === "pole" ? "pole" : "equator";
  }

  /** Orient the chart for the site's latitude and the facing chosen; redraw everything if it turned. */
  function orient(latitude) {
    view.latitude = latitude;
    const north = latitude >= 0; // the equator itself: as in the north (south at the bottom)
    const up = north === (facing() === "equator") ? 0 : 180;
    const bottom = up === 0 ? "south" : "north";
    const towards = (bottom === "north") === north ? "the pole" : "the equator";
    const other = bottom === "south" ? "north" : "south";
    setText("sky-orientation", "Looking up, facing " + bottom + " (" + towards + "): " + bottom + " at the bottom, east on the " +
      (up === 0 ? "left" : "right") + ". Rings at 0\u00b0, 30\u00b0 and 60\u00b0 altitude.", "muted small");
    setText("sky-turn", "Face " + other + " (" + (towards === "the pole" ? "the equator" : "the pole") + ")", "ghost");
    // The pad faces the way the chart does: east on the chart's east side, north towards its north.
    $("jog").classList.toggle("turned", up === 180);
    if (up === view.up && sky.bg) return;
    view.up = up;
    $("sky").replaceChildren();
    state.floorKey = state.flipKey = state.limitKey = "";
    buildSky();
    if (state.status) drawSky(state.status);
    document.dispatchEvent(new CustomEvent("alpaca-zwo-sky-turned", { detail: { up } }));
  }

  function bindTurn() {
    $("sky-turn").addEventListener("click", () => {
      try { localStorage.setItem(FACING_KEY, facing() === "pole" ? "equator" : "pole"); } catch (_) { /* not kept */ }
      orient(view.latitude === null ? 0 : view.latitude);
    });
  }

  function el(tag, attrs, parent) {
    const node = document.createElementNS(SVG, tag);
    for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, v);
    if (parent) parent.append(node);
    return node;
  }

  const sky = {};

  function buildSky() {
    const svg = $("sky");
    const outer = ((90 - MIN_ALT) / 90) * R;
    sky.bg = el("circle", { cx: 0, cy: 0, r: outer, class: "sky-bg" }, svg);
    sky.ground = el("path", { class: "sky-ground", d: "" }, svg);
    el("g", { id: "sky-chart" }, svg); // stars, constellation lines, Sun, Moon, planets: skychart.js
    for (const alt of [30, 60]) {
      el("circle", { cx: 0, cy: 0, r: ((90 - alt) / 90) * R, class: "sky-ring" }, svg);
      const [, y] = project(view.up + 180, alt); // on the meridian below the zenith, clear of its line
      const label = el("text", { x: 3, y: y - 2, class: "sky-small ring-label", "data-ring": ((90 - alt) / 90) * R }, svg);
      label.textContent = alt + "\u00b0";
    }
    el("circle", { cx: 0, cy: 0, r: R, class: "sky-horizon" }, svg);
    sky.floor = el("path", { class: "sky-floor", d: "" }, svg);
    sky.mlimits = el("g", {}, svg);
    el("line", { x1: 0, y1: -R, x2: 0, y2: R, class: "sky-meridian" }, svg);
    sky.flip = el("polyline", { class: "sky-flip", points: "" }, svg);
    el("path", { d: "M -3 0 H 3 M 0 -3 V 3", class: "sky-pole" }, svg); // zenith
    sky.pole = el("g", { id: "sky-pole" }, svg);
    el("circle", { cx: 0, cy: 0, r: 2.5, class: "sky-pole" }, sky.pole);
    const poleLabel = el("text", { x: 9, y: -5, class: "sky-small" }, sky.pole);
    poleLabel.textContent = "pole";
    const labels = [["N", 0], ["E", 90], ["S", 180], ["W", 270]];
    for (const [name, az] of labels) {
      const t = ((az - view.up) * Math.PI) / 180;
      const r = outer + 8;
      const text = el("text", { x: -r * Math.sin(t), y: -r * Math.cos(t), class: "sky-label" + (name === "N" ? " north" : "") }, svg);
      text.textContent = name;
    }
    sky.trail = el("polyline", { class: "sky-trail", points: "" }, svg);
    sky.path = el("line", { class: "sky-path hidden", x1: 0, y1: 0, x2: 0, y2: 0 }, svg);
    sky.target = el("circle", { id: "sky-target", class: "sky-target hidden", cx: 0, cy: 0, r: 6 }, svg);
    sky.scope = el("g", { id: "sky-scope", class: "sky-scope hidden" }, svg);
    el("circle", { cx: 0, cy: 0, r: 5.5 }, sky.scope);
    el("line", { x1: -10, y1: 0, x2: -6, y2: 0 }, sky.scope);
    el("line", { x1: 6, y1: 0, x2: 10, y2: 0 }, sky.scope);
    el("line", { x1: 0, y1: -10, x2: 0, y2: -6 }, sky.scope);
    el("line", { x1: 0, y1: 6, x2: 0, y2: 10 }, sky.scope);
    sky.title = el("title", {}, sky.scope);
  }

  function pointsText(pairs) {
    return pairs.map(([az, alt]) => project(az, alt).map((v) => v.toFixed(2)).join(",")).join(" ");
  }

  function drawSky(s) {
    const geo = s.sky;
    if (geo.latitude !== view.latitude) orient(geo.latitude);
    const before = state.floorKey + state.flipKey + state.limitKey;
    const floorKey = JSON.stringify(geo.floor);
    if (floorKey !== state.floorKey) {
      state.floorKey = floorKey;
      const ring = pointsText(geo.floor);
      const outer = ((90 - MIN_ALT) / 90) * R;
      // Ground = the band between the plot's edge and the lowest allowed altitude (even-odd fill).
      sky.ground.setAttribute("d", "M " + ring.split(" ").join(" L ") + " Z " +
        "M " + outer + " 0 A " + outer + " " + outer + " 0 1 0 " + (-outer) + " 0 A " + outer + " " + outer + " 0 1 0 " + outer + " 0 Z");
      sky.floor.setAttribute("d", "M " + ring.split(" ").join(" L ") + " Z");
    }
    const flipKey = JSON.stringify(geo.flip_line);
    if (flipKey !== state.flipKey) {
      state.flipKey = flipKey;
      sky.flip.setAttribute("points", pointsText(geo.flip_line));
    }
    const limitKey = JSON.stringify(geo.mount_limits);
    if (limitKey !== state.limitKey) {
      state.limitKey = limitKey;
      sky.mlimits.replaceChildren();
      if (geo.mount_limits) {
        for (const alt of [geo.mount_limits.lower, geo.mount_limits.upper]) {
          if (alt !== null && alt !== undefined) el("circle", { cx: 0, cy: 0, r: ((90 - alt) / 90) * R, class: "sky-mlimit" }, sky.mlimits);
        }
      }
    }
    const [px, py] = project(geo.pole[0], geo.pole[1]);
    sky.pole.setAttribute("transform", "translate(" + px.toFixed(2) + " " + py.toFixed(2) + ")");
    if (state.floorKey + state.flipKey + state.limitKey !== before) {
      document.dispatchEvent(new Event("alpaca-zwo-sky-geometry")); // skychart.js places its labels clear of them
    }

    const pos = s.position;
    if (!pos) {
      sky.scope.classList.add("hidden");
      return;
    }
    const [x, y] = project(pos.az, pos.alt);
    sky.scope.classList.remove("hidden");
    sky.scope.setAttribute("transform", "translate(" + x.toFixed(2) + " " + y.toFixed(2) + ")");
    let cls = "sky-scope";
    if (pos.below_limit) cls += " danger";
    else if (s.slewing) cls += " slewing";
    else if (!s.tracking) cls += " idle";
    sky.scope.setAttribute("class", cls);
    sky.title.textContent = "Alt " + pos.alt.toFixed(1) + "\u00b0, Az " + pos.az.toFixed(1) + "\u00b0";

    const last = state.trail[state.trail.length - 1];
    const [lx, ly] = last ? project(last[0], last[1]) : [Infinity, Infinity];
    if (!last || Math.hypot(lx - x, ly - y) > 0.3 || !sky.trail.getAttribute("points")) {
      if (!last || Math.hypot(lx - x, ly - y) > 0.3) state.trail.push([pos.az, pos.alt]);
      if (state.trail.length > TRAIL_POINTS) state.trail.shift();
      sky.trail.setAttribute("points", pointsText(state.trail));
    }

    if (s.target && s.slewing) {
      const [tx, ty] = project(s.target.az, s.target.alt);
      sky.target.setAttribute("cx", tx.toFixed(2));
      sky.target.setAttribute("cy", ty.toFixed(2));
      sky.path.setAttribute("x1", x.toFixed(2));
      sky.path.setAttribute("y1", y.toFixed(2));
      sky.path.setAttribute("x2", tx.toFixed(2));
      sky.path.setAttribute("y2", ty.toFixed(2));
      sky.target.classList.remove("hidden");
      sky.path.classList.remove("hidden");
    } else {
      sky.target.classList.add("hidden");
      sky.path.classList.add("hidden");
    }
  }

  // ---------------------------------------------------------------- status

  function renderStatus(s) {
    state.status = s;
    state.connected = s.connected;
    const pos = s.position;
    setText("device-name", "\u2014 " + s.name);
    setText("ra", pos ? fmtHours(pos.ra) : "\u2013", "big");
    setText("dec", pos ? fmtDeg(pos.dec) : "\u2013", "big");
    setText("alt", pos ? fmtDeg(pos.alt) : "\u2013", pos && pos.below_limit ? "big bad" : "big");
    setText("az", pos ? fmtAz(pos.az) : "\u2013", "big");
    setText("lst", fmtHours(s.time.lst));
    setText("ha", pos ? fmtHa(pos.ha) : "\u2013");
    setText("jog-pos", pos ? "RA " + fmtHours(pos.ra) + "\nDec " + fmtDeg(pos.dec) + "\nAlt " + fmtDeg(pos.alt) +
      "\nAz " + fmtAz(pos.az) : "", "jog-pos mono small");

    const pierNames = { east: "east (looking west)", west: "west (looking east)", unknown: "unknown" };
    setText("pier", s.pier_side ? pierNames[s.pier_side] : "\u2013");

    if (!s.connected) {
      setText("tracking", "\u2013");
    } else if (s.tracking) {
      setText("tracking", "on, " + (s.tracking_rate_name || "?"), "yes");
    } else {
      setText("tracking", "off" + (s.tracking_stopped ? " (" + s.tracking_stopped + ")" : ""), s.tracking_stopped ? "bad" : "");
    }
    const [slewText, slewCls] = yesNo(s.slewing, "busy");
    setText("slewing", s.connected ? slewText + (s.moving_axes.length ? " (manual move)" : "") : "\u2013", slewCls);
    setText("guiding", s.connected ? (s.guiding ? "pulse guiding" : "no") + ", rate " + (s.guide_rate !== null ? s.guide_rate.toFixed(1) + "\u00d7" : "?") : "\u2013", s.guiding ? "busy" : "");
    // The mount's own park (ZWO app, ASIAIR, hand controller, or kept from before a power cut): say so,
    // since only Unpark here (or the ZWO app) lets it move again.
    const park = s.parked_by_mount ? "parked (the mount parked itself; Unpark releases it)"
      : s.at_park ? "parked" : s.at_home ? "at home" : "no";
    setText("park", s.connected ? park : "\u2013", s.at_park || s.at_home ? "yes" : "");

    setText("meridian", meridianText(s.meridian));
    setText("mer-nina", ninaAdvice(s.meridian), "muted small");
    // Name what is really driven: the built-in emulator, or the mount at the --device/config URL.
    const driven = s.link.emulated ? "built-in emulator" : s.link.url;
    setText("mount", (s.mount ? "ZWO " + s.mount.model + ", firmware " + s.mount.firmware + (s.flags.mode ? ", " + s.flags.mode : "") + " \u2014 " : "") + driven);

    const link = s.link;
    let linkText = link.state;
    if (link.state === "connected" && !s.initialised) linkText += ", initialising";
    if (link.reconnects) linkText += ", " + link.reconnects + " reconnect" + (link.reconnects > 1 ? "s" : "");
    // The exception text stays in the log and the trace: the page says what to do instead (lostText).
    setText("link", linkText + " (" + (link.emulated ? "built-in emulator" : link.url) + ")", link.state === "connected" ? "" : link.state === "closed" ? "" : "bad");
    const age = pos ? pos.age_s : null;
    const lost = lostText(s);
    setText("age", age === null ? "\u2013" : fmtDuration(age) + (lost ? ", last known position" : ""), age !== null && age > 5 && s.connected ? "bad" : "");
    setText("link-lost", lost, lost ? "lost" : "lost hidden");
    $("readout").classList.toggle("stale", Boolean(lost));
    $("sky").classList.toggle("stale", Boolean(lost));
    // The mount's state rows are as old as the position: greyed too (Link and Data age say why).
    for (const id of ["lst", "ha", "pier", "tracking", "slewing", "guiding", "park", "meridian"]) {
      $(id).classList.toggle("stale", Boolean(lost));
    }
    const utc = s.time.utc.replace("T", " ").replace(/\.\d+Z$/, " UTC");
    setText("utc", utc);

    const pill = $("link-pill");
    let pillText = "mount: " + link.state;
    let pillCls = "pill pill-off";
    if (link.state === "connected") {
      pillCls = age !== null && age > 5 ? "pill pill-warn" : "pill pill-ok";
      pillText = "mount: connected" + (age !== null ? ", " + fmtDuration(age) + " old" : "");
    } else if (link.state === "reconnecting" || link.state === "connecting") {
      pillCls = "pill pill-warn";
    }
    pill.textContent = pillText;
    pill.className = pillCls;

    const warnings = [];
    if (pos && pos.below_limit) warnings.push("The telescope is below the horizon limit (" + pos.floor.toFixed(1) + "\u00b0 here).");
    if (s.flags.low_voltage) warnings.push("The mount reports low supply voltage.");
    if (s.flags.ra_stall || s.flags.dec_stall) warnings.push("The mount reports a stalled axis.");
    if (s.connected && !s.initialised) warnings.push("Time and site have not been sent to the mount yet.");
    const w = $("warnings");
    w.textContent = warnings.join(" ");
    w.classList.toggle("hidden", warnings.length === 0);

    const offset = s.time.offset_s;
    const browserSkew = (Date.parse(s.time.utc) - Date.now()) / 1000;
    setText("clock-note", "Mount clock vs this browser: " + (browserSkew >= 0 ? "+" : "") + browserSkew.toFixed(1) + " s" +
      (Math.abs(offset) > 0.5 ? "; vs the server's clock: " + (offset >= 0 ? "+" : "") + offset.toFixed(1) + " s" : "") +
      ". LST " + fmtHours(s.time.lst) + ".", "muted small");

    for (const listener of statusListeners) {
      try { listener(s); } catch (err) { console.error(err); }
    }
    renderControls(s);
    renderClients(s.clients);
    renderBridges(s.bridges || []);
    renderSafety(s.safety);
    drawSky(s);
  }

  // The meridian as the mount will meet it, from its own settings (the server's sky.tracking_stop_deg): where
  // tracking stops, and that the mount does not flip by itself (docs/meridian.md).
  function meridianText(m) {
    const stop = m.stop_deg;
    const at = stop === 0 ? "at the meridian" : Math.abs(stop) + "\u00b0 " + (stop > 0 ? "past" : "before") + " the meridian";
    let text = "tracking stops " + at + " (" + (m.track_after || stop < 0 ? "the mount's limit" : "the mount's rule without \u201ctrack past\u201d") +
      "); the mount does not flip by itself: a GoTo past the meridian flips it";
    if (m.minutes_to_stop !== null) {
      text += m.minutes_to_stop >= 0 ? "; stops in " + fmtMinutes(m.minutes_to_stop) : "; stopped " + fmtMinutes(-m.minutes_to_stop) + " ago";
    }
    return text;
  }

  // What N.I.N.A.'s Meridian Flip settings must be for its flip to come before the mount stops tracking.
  function ninaAdvice(m) {
    const where = "For N.I.N.A. (Options \u203a Imaging \u203a Meridian Flip): ";
    const minutes = Math.round(m.stop_minutes);
    if (minutes <= 0) {
      return where + "tracking stops " + (-minutes) + " min before the meridian, so set Pause before meridian to " +
        (1 - minutes) + " min or more; N.I.N.A. then flips after the meridian.";
    }
    return where + "its flip must come before tracking stops, " + minutes + " min after the meridian: set Max minutes " +
      "after meridian to " + (minutes - 1) + " or less, and Minutes after meridian below that." +
      (minutes < 11 ? " To keep N.I.N.A.'s usual 5 and 10 min instead, tick Track past the meridian with a limit of 3\u00b0 (12 min) or more." : "");
  }

  // One plain message when the mount cannot be reached: what happened and what to try (no exception text).
  function lostText(s) {
    const link = s.link;
    const down = link.state === "reconnecting" || (link.state === "connecting" && Boolean(link.last_error));
    const age = s.position ? s.position.age_s : null;
    const silent = !down && link.state === "connected" && s.connected && age !== null && age > 10;
    if (!down && !silent) return "";
    const wifi = /^(socket|rfc2217):\/\//.test(link.url) && !link.emulated;
    const check = wifi
      ? "that this computer is still on the mount's WiFi (or the network it is on) and in range"
      : "that the USB cable is plugged in firmly at both ends (or try another cable or port)";
    return (down ? "The connection to the mount is lost" : "The mount has stopped answering") +
      "; alpaca-zwo keeps trying to reconnect." +
      (age !== null ? " The position shown is the last one known, " + fmtDuration(age) + " old." : "") +
      " Check that the mount is switched on and has power, and " + check + ".";
  }

  function renderControls(s) {
    const on = s.connected;
    $("btn-connect").classList.toggle("hidden", s.page_connected);
    $("btn-disconnect").classList.toggle("hidden", !s.page_connected);
    setText("connect-note", on ? (s.page_connected ? "" : "in use by a client") : "the mount link is closed", "muted small");
    for (const id of ["btn-park", "btn-unpark", "btn-home", "btn-track-on", "btn-track-off", "tracking-rate", "btn-setpark", "btn-time"]) {
      $(id).disabled = !on;
    }
    for (const b of document.querySelectorAll(".jogb")) b.disabled = !on || s.at_park;
    $("btn-park").disabled = !on || s.at_park;
    $("btn-unpark").disabled = !on || !s.at_park;
    $("btn-track-on").classList.toggle("active", on && s.tracking);
    $("btn-track-off").classList.toggle("active", on && !s.tracking);
    const rate = $("tracking-rate");
    if (s.tracking_rate !== null && document.activeElement !== rate) rate.value = String(s.tracking_rate);
    const guide = $("guide-rate");
    if (s.guide_rate !== null && document.activeElement !== guide && !guide.dataset.dirty) guide.value = s.guide_rate.toFixed(1);
    for (const form of document.querySelectorAll("form.mount-only")) {
      form.classList.toggle("disabled", !on);
      for (const input of form.querySelectorAll("input, select, button")) input.disabled = !on;
    }
    // Read the mount's own settings once each time the mount comes up (not on every poll).
    if (on && !state.mountSettingsLoaded && !state.mountSettingsAsked) {
      state.mountSettingsAsked = true;
      loadSettings();
    }
    if (!on) state.mountSettingsAsked = state.mountSettingsLoaded = false;
  }

  // Fill a table body with one row of text cells per item, or one muted row saying it is empty.
  function fillTable(id, columns, rows, emptyText) {
    const body = $(id);
    body.replaceChildren();
    if (!rows.length) {
      const tr = document.createElement("tr");
      const td = document.createElement("td");
      td.colSpan = columns;
      td.className = "muted";
      td.textContent = emptyText;
      tr.append(td);
      body.append(tr);
      return;
    }
    for (const row of rows) {
      const tr = document.createElement("tr");
      for (const text of row.cells) {
        const td = document.createElement("td");
        td.textContent = text;
        if (row.cls) td.className = row.cls;
        tr.append(td);
      }
      body.append(tr);
    }
  }

  function renderClients(clients) {
    const rows = clients.map((c) => ({
      cells: [c.setup_page ? "setup page (" + c.address + ")" : c.address + (c.user_agent ? " \u2014 " + c.user_agent : ""),
        c.setup_page ? "" : String(c.client_id), c.connected ? "yes" : "no", String(c.requests), fmtDuration(c.idle_s)],
      cls: c.setup_page ? "mine" : "",
    }));
    fillTable("clients", 5, rows, "no client in the last 5 minutes");
  }

  // A bridge's status() value for a cell: text as is, {time, command|message} as "time command".
  function brief(value) {
    if (value === null || value === undefined || value === "") return "\u2013";
    if (typeof value !== "object") return String(value);
    const what = value.command || value.message || value.text || value.kind || JSON.stringify(value);
    return (value.time ? String(value.time).replace(/^.*T/, "").replace(/\.\d+Z?$/, "") + " " : "") + what;
  }

  function programs(clients) {
    if (typeof clients === "number") return String(clients);
    if (!Array.isArray(clients)) return "\u2013";
    return clients.length ? clients.map((c) => (c && typeof c === "object" ? c.address || JSON.stringify(c) : String(c))).join(", ") : "none";
  }

  // Connections a bridge closed at the door (a network not allowed, not its protocol): how many, the last.
  function turnedAway(b) {
    const last = b.last_turned_away;
    if (!last) return "\u2013";
    return b.turned_away + " turned away; last " + (last.client || last.address) + ": " + (last.message || last.reason);
  }

  function renderBridges(bridges) {
    const rows = bridges.map((b) => ({
      cells: [b.name, b.enabled === false ? "no" : "yes", b.port === undefined || b.port === null ? "\u2013" : String(b.port),
        programs(b.clients || b.programs), brief(b.last_command), b.last_error ? brief(b.last_error) : turnedAway(b)],
    }));
    fillTable("bridges", 6, rows, "none running (Stellarium and shared ZWO port are set in the config file)");
  }

  let pollTimer = null;
  let polling = false;

  async function poll(immediate) {
    if (immediate) {
      clearTimeout(pollTimer);
    }
    if (polling) return;
    polling = true;
    try {
      const sent = Date.now();
      const s = await request(base + "/status");
      s.client_timing = { sent, received: Date.now() }; // fieldline.js compares this device's clock with the server's
      state.pollFailures = 0;
      renderStatus(s);
    } catch (err) {
      state.pollFailures += 1;
      const pill = $("link-pill");
      pill.textContent = "server unreachable";
      pill.className = "pill pill-bad";
      if (state.pollFailures === 3) message("Lost contact with the server: " + err.message, "error");
    } finally {
      polling = false;
      clearTimeout(pollTimer);
      pollTimer = setTimeout(poll, POLL_MS);
    }
  }

  // ---------------------------------------------------------------- controls

  // A tap on the pad is a step that shows: the move runs at least STEP_MS (5′ at 20× sidereal); a press held
  // longer stops on release. STOP, Escape, leaving the page or another press stop at once (now: true).
  const STEP_MS = 1000;

  function stopJog(now) {
    const jog = state.jogging;
    if (!jog) return;
    const left = now === true ? 0 : jog.started + STEP_MS - Date.now();
    if (left > 0) {
      if (!jog.timer) jog.timer = setTimeout(() => stopJog(true), left);
      return;
    }
    clearTimeout(jog.timer);
    state.jogging = null;
    jog.button.classList.remove("pressed");
    // The mount must stop even if this request races the press: send it regardless, quietly.
    action("move", { axis: jog.axis, rate: 0 }).catch((err) => message("Stopping the move failed: " + err.message, "error", $("jog-hint")));
  }

  function bindJog() {
    for (const button of document.querySelectorAll(".jogb[data-axis]")) {
      button.addEventListener("pointerdown", (ev) => {
        if (button.disabled) return;
        ev.preventDefault();
        if (button.setPointerCapture) {
          try { button.setPointerCapture(ev.pointerId); } catch (_) { /* not capturable: fine */ }
        }
        stopJog(true);
        const axis = Number(button.dataset.axis);
        const multiple = Number($("jog-speed").value);
        const rate = Number(button.dataset.sign) * multiple * state.server.sidereal_deg_s;
        state.jogging = { axis, button, started: Date.now(), timer: null };
        button.classList.add("pressed");
        action("move", { axis, rate }).then(() => poll(true)).catch((err) => {
          if (state.jogging && state.jogging.button === button) {
            state.jogging = null;
            button.classList.remove("pressed");
          }
          message("The move did not start: " + err.message, "error", $("jog-hint")); // under the pad
        });
      });
      for (const type of ["pointerup", "pointercancel", "lostpointercapture", "pointerleave"]) {
        button.addEventListener(type, () => {
          if (state.jogging && state.jogging.button === button) stopJog();
        });
      }
      button.addEventListener("keydown", (ev) => {
        if ((ev.key === " " || ev.key === "Enter") && !ev.repeat && !state.jogging) {
          button.dispatchEvent(new PointerEvent("pointerdown", { bubbles: true }));
        }
      });
      button.addEventListener("keyup", (ev) => {
        if (ev.key === " " || ev.key === "Enter") stopJog();
      });
    }
    window.addEventListener("blur", () => stopJog(true));
    document.addEventListener("visibilitychange", () => { if (document.hidden) stopJog(true); });
    $("jog-stop").addEventListener("click", stopMount);
    const speed = $("jog-speed");
    for (const m of state.server.jog_multiples) {
      const opt = document.createElement("option");
      opt.value = String(m);
      opt.textContent = m + "\u00d7 sidereal" + (m >= 60 ? " (" + (m * state.server.sidereal_deg_s).toFixed(2) + "\u00b0/s)" : "");
      speed.append(opt);
    }
    speed.value = "20";
    const hint = () => setText("jog-hint", "Hold a direction to move; a tap steps about " +
      fmtStep(Number(speed.value) * state.server.sidereal_deg_s * STEP_MS / 1000) + ".", "muted small");
    speed.addEventListener("change", hint);
    hint();
  }

  function fmtStep(deg) {
    return deg >= 1 ? deg.toFixed(1) + "\u00b0" : deg * 60 >= 1 ? (deg * 60).toFixed(0) + "\u2032" : (deg * 3600).toFixed(0) + "\u2033";
  }

  // STOP says whether it reached the mount: the server answers only once the stop was written to it. The
  // motion line (handset.js) says "Stopping…" from the tap and where the mount came to rest once it has.
  async function stopMount() {
    stopJog(true);
    document.dispatchEvent(new Event("alpaca-zwo-stop"));
    try {
      await action("abort");
      document.dispatchEvent(new CustomEvent("alpaca-zwo-stop-sent", { detail: { ok: true } }));
      keepInLog("STOP pressed on the page: the mount acknowledged the stop.", "info");
    } catch (err) {
      document.dispatchEvent(new CustomEvent("alpaca-zwo-stop-sent", { detail: { ok: false } }));
      message("STOP: " + err.message, "error"); // the server says whether it reached the mount
    }
    poll(true);
  }

  function bindControls() {
    $("btn-stop").addEventListener("click", stopMount);
    // Escape stops the mount from anywhere on the page, whatever has focus (a text field, the chart, a
    // list of matches): listened for before anything else, and never swallowed, so the same key still
    // closes the list it was pressed in. Stopping is the safe reading of a key pressed in a hurry.
    window.addEventListener("keydown", (ev) => {
      if (ev.key === "Escape" && !ev.repeat) stopMount();
    }, true);
    // Each control's refusal is said beside it (its row or form), where the tap was.
    const beside = (label, fn) => (ev) => run(label, fn, false, ev.currentTarget);
    $("btn-connect").addEventListener("click", beside("Mount connected.", () => action("connect")));
    $("btn-disconnect").addEventListener("click", beside("Released the mount.", () => action("disconnect")));
    $("btn-park").addEventListener("click", beside("Parking\u2026", () => action("park")));
    $("btn-unpark").addEventListener("click", beside("Unparked.", () => action("unpark")));
    $("btn-home").addEventListener("click", beside("Going home\u2026", () => action("find_home")));
    $("btn-track-on").addEventListener("click", beside("Tracking on.", () => action("tracking", { on: true })));
    $("btn-track-off").addEventListener("click", beside("Tracking off.", () => action("tracking", { on: false })));
    $("tracking-rate").addEventListener("change", (ev) =>
      run("Tracking rate set.", () => action("tracking_rate", { rate: Number(ev.target.value) }), false, ev.currentTarget));
    const guide = $("guide-rate");
    guide.addEventListener("input", () => { guide.dataset.dirty = "1"; });
    $("form-guide").addEventListener("submit", async (ev) => {
      ev.preventDefault();
      await run("Guide rate set.", () => action("guide_rate", { rate: Number(guide.value) }), false, ev.currentTarget);
      delete guide.dataset.dirty;
    });
    $("btn-setpark").addEventListener("click", async (ev) => {
      const result = await beside("Park position set to the current position.", () => action("set_park"))(ev);
      if (result) loadSettings();
    });
    $("btn-time").addEventListener("click", beside("Mount time set from this browser.",
      () => action("time", { utc: new Date().toISOString() })));
    $("btn-geo").addEventListener("click", useBrowserLocation);
  }

  // Browsers give their location only to secure pages (https, or localhost on this machine); this
  // page is usually opened as http://<address>:11111 from a phone, so say so and what to do instead.
  function geoNote(text) {
    const note = $("geo-note");
    note.textContent = text;
    note.classList.toggle("hidden", !text);
  }

  // Where the browser can answer (https, or localhost): the location buttons show only there (canLocate).
  const canLocate = () => Boolean(navigator.geolocation && window.isSecureContext);

  function geoInstead(where) {
    return " Instead, type the latitude and longitude " + (where || "above") + " (degrees; longitude east positive), " +
      "or copy them from your phone's GPS or compass app (or long-press your position in a map app), then press Save site.";
  }

  function geoInsecureText(where) {
    return "Browsers share their location only with pages opened over https or as localhost on the same " +
      "machine, and this page is " + location.origin + ", so this browser will not tell it." + geoInstead(where);
  }

  function geoErrorText(err, where) {
    return (err.code === 1 ? "This browser was not allowed to share its location."
      : "This browser could not find its location (" + err.message + ").") + geoInstead(where);
  }

  // A saved site says whether it reached the mount: the server's reply says whether the mount is connected.
  function siteSaved(reply) {
    return reply.connected ? "Site saved and sent to the mount." : "Site saved; the mount gets it when it is connected.";
  }

  function useBrowserLocation() {
    if (!navigator.geolocation || !window.isSecureContext) {
      geoNote(geoInsecureText());
      return;
    }
    geoNote("");
    navigator.geolocation.getCurrentPosition(
      (p) => {
        $("site-lat").value = p.coords.latitude.toFixed(6);
        $("site-lon").value = p.coords.longitude.toFixed(6);
        if (p.coords.altitude !== null) $("site-elev").value = p.coords.altitude.toFixed(0);
        message("Location filled in from this browser; press Save site to use it.", "info");
      },
      (err) => geoNote(geoErrorText(err)),
      { enableHighAccuracy: true, timeout: 20000 }
    );
  }

  // ---------------------------------------------------------------- settings

  function num(id) {
    return Number($(id).value);
  }

  function fillSettings(s) {
    state.settings = s;
    $("site-lat").value = s.site.latitude;
    $("site-lon").value = s.site.longitude;
    $("site-elev").value = s.site.elevation;
    $("park-mode").value = s.park.mode;
    $("park-ha").value = Number(s.park.ha_hours.toFixed(4));
    $("park-dec").value = Number(s.park.dec_deg.toFixed(4));
    $("h-min").value = s.limits.min_altitude_deg;
    $("h-profile").value = s.limits.horizon.map((p) => p[0] + " " + p[1]).join("\n");
    if (s.time) $("t-source").value = s.time.source;
    $("s-watchdog").value = s.safety.moveaxis_watchdog_s;
    $("s-shutdown").value = s.safety.on_shutdown;
    $("o-monitor").value = s.safety.monitor;
    $("o-roof").value = s.safety.roof;
    $("o-poll").value = s.safety.poll_s;
    $("o-unreachable").value = s.safety.unreachable_s;
    $("o-on-unsafe").value = s.safety.on_unsafe;
    $("d-name").value = s.device.name;
    $("d-url").value = s.device.url;
    const m = s.mount;
    state.mountSettingsLoaded = Boolean(m);
    if (m) {
      if (m.meridian) {
        $("mer-track").checked = m.meridian.track_after;
        $("mer-limit").value = m.meridian.limit_degrees;
      }
      if (m.limits_enabled !== null) $("ml-enabled").checked = m.limits_enabled;
      if (m.upper_limit !== null) $("ml-upper").value = m.upper_limit;
      if (m.lower_limit !== null) $("ml-lower").value = m.lower_limit;
      if (m.heavy_duty !== null) $("m-heavy").checked = m.heavy_duty;
      if (m.buzzer !== null) $("m-buzzer").value = String(m.buzzer);
    }
    const mode = s.mode;
    if (mode) {
      $("m-mode").value = mode.requested === "unknown" ? "equatorial" : mode.requested;
      setText("m-mode-note", mode.restart_required ? "\u26a0 " + mode.message : "In effect: " + mode.mode + " mode.");
    }
    if (!m) {
      $("mer-track").checked = s.limits.meridian_track_past;
      $("mer-limit").value = Math.round(s.limits.meridian_limit_deg);
    }
  }

  let settingsLoading = false;

  async function loadSettings() {
    if (settingsLoading) return;
    settingsLoading = true;
    try {
      fillSettings(await request(base + "/settings"));
    } catch (err) {
      message("Could not read the settings: " + err.message);
    } finally {
      settingsLoading = false;
    }
  }

  // The horizon's points, and the line of the text each came from (state.horizonLines), so that a refusal
  // of "point 1" reads as the line the person sees (comments and blank lines count).
  function parseHorizon(text) {
    const points = [];
    state.horizonLines = [];
    for (const [i, line] of text.split("\n").entries()) {
      const t = line.trim();
      if (!t || t.startsWith("#")) continue;
      const parts = t.split(/[\s,;]+/).map(Number);
      if (parts.length !== 2 || parts.some((v) => !Number.isFinite(v))) {
        throw new Error("horizon line " + (i + 1) + " is not \u201cazimuth altitude\u201d: " + t);
      }
      points.push(parts);
      state.horizonLines.push(i + 1);
    }
    return points;
  }

  function horizonWords(text) {
    return text.replace(/limits\.horizon: point (\d+)/, (_, i) => "horizon line " + (state.horizonLines[Number(i)] || Number(i) + 1))
      .replace("limits.horizon: ", "horizon: ");
  }

  // explain: the server's refusal put in the form's own words (optional).
  function saveSettings(label, build, explain) {
    return async (ev) => {
      ev.preventDefault();
      const form = ev.target;
      let body;
      try {
        body = build();
      } catch (err) {
        message(err.message, "error", form);
        return;
      }
      const send = () => post(base + "/settings", body).catch((err) => {
        throw explain ? new Error(explain(err.message)) : err;
      });
      const said = typeof label === "function"; // words from the reply (siteSaved)
      const result = await run(said ? "Site saved." : label, send, said, form);
      if (result && said) message(label(result), "info");
      if (result) fillSettings(result);
    };
  }

  // The observatory interlock: the verdict in the status list, the last answers and events by the form.
  function renderSafety(safety) {
    if (!safety) return;
    const names = { off: "off (no monitor)", unknown: "waiting for the monitor", safe: "safe", unsafe: "UNSAFE: motion refused" };
    setText("safety", names[safety.state] || safety.state, safety.state === "unsafe" ? "bad" : safety.state === "safe" ? "yes" : "");
    const parts = [];
    for (const role of ["monitor", "roof"]) {
      const d = safety[role];
      if (!d) continue;
      let line = (role === "monitor" ? "Monitor: " : "Roof: ") + (d.answer || "no answer yet");
      if (d.age_s !== null) line += ", " + fmtDuration(d.age_s) + " ago";
      if (d.error) line += " (last try: " + d.error + ")";
      parts.push(line);
    }
    setText("o-state", (safety.message || "") + (parts.length ? ". " + parts.join(". ") + "." : ""),
      safety.state === "unsafe" ? "small bad" : "small");
    const events = $("o-events");
    events.replaceChildren();
    for (const e of (safety.events || []).slice(-5)) {
      const li = document.createElement("li");
      li.textContent = e.time.replace("T", " ").replace(/\.\d+\+00:00$/, " UTC") + ": " + e.text;
      events.append(li);
    }
  }

  // Ask the monitor or roof typed in once, before saving it: its answer, or why it did not answer, under the
  // buttons (the URL as the server reads it: a missing http:// is added, as Save does).
  async function testSafetyDevice(role, field) {
    const box = $("o-test");
    box.textContent = "Asking\u2026";
    box.className = "small";
    const result = await run("Test done.", () => post("/setup/api/safety/test", { role, url: $(field).value.trim() }),
      true, $("btn-test-" + role));
    if (!result) {
      box.className = "small hidden";
      return;
    }
    const who = role === "monitor" ? "The monitor" : "The roof";
    box.textContent = result.ok
      ? who + " at " + result.url + " answered " + result.answer + ": " + (result.safe ? "motion would be allowed." : "motion would be refused.")
      : who + " at " + result.url + " did not answer: " + result.error + ".";
    box.className = "small " + (result.ok && result.safe ? "yes" : "bad");
  }

  async function findSafetyDevices() {
    const list = $("o-found");
    list.replaceChildren();
    const result = await run("Discovery done.", () => post("/setup/api/safety/discover", { host: $("o-host").value.trim() }), true,
      $("btn-find-devices"));
    if (!result) return;
    if (!result.servers.length) {
      const li = document.createElement("li");
      li.textContent = "No Alpaca server answered.";
      list.append(li);
    }
    for (const server of result.servers) {
      const li = document.createElement("li");
      li.textContent = (server.name || "Alpaca server") + " at " + server.address +
        (server.devices.length ? "" : ": no SafetyMonitor or Dome") + (server.error ? " (" + server.error + ")" : "");
      const sub = document.createElement("ul");
      for (const device of server.devices) {
        const item = document.createElement("li");
        item.textContent = device.type + " " + device.number + " “" + device.name + "” ";
        const use = document.createElement("button");
        use.type = "button";
        use.className = "ghost";
        use.textContent = device.type === "Dome" ? "Use as roof" : "Use as monitor";
        use.addEventListener("click", () => {
          $(device.type === "Dome" ? "o-roof" : "o-monitor").value = device.url;
          message("Filled in; press Save to use it.", "info");
        });
        item.append(use);
        sub.append(item);
      }
      li.append(sub);
      list.append(li);
    }
  }

  function bindSettings() {
    $("form-site").addEventListener("submit", saveSettings(siteSaved, () => ({
      site: { latitude: num("site-lat"), longitude: num("site-lon"), elevation: num("site-elev") },
    })));
    // On a page that cannot ask the browser, the button is not offered: the note says what to do instead.
    $("btn-geo").classList.toggle("hidden", !canLocate());
    if (!canLocate()) geoNote(geoInsecureText());
    $("form-time").addEventListener("submit", saveSettings("Time source saved (in effect now).", () => ({
      time: { source: $("t-source").value },
    })));
    $("form-meridian").addEventListener("submit", saveSettings("Meridian settings saved.", () => ({
      meridian: { track_after: $("mer-track").checked, limit_degrees: num("mer-limit") },
    })));
    $("form-mlimits").addEventListener("submit", saveSettings("Altitude limits saved.", () => ({
      mount_limits: { enabled: $("ml-enabled").checked, upper: num("ml-upper"), lower: num("ml-lower") },
    })));
    $("form-mode").addEventListener("submit", saveSettings(
      "Mode sent: restart the mount (switch it off and on) for it to take effect.", () => ({ mode: $("m-mode").value })));
    $("form-mount").addEventListener("submit", saveSettings("Mount settings saved.", () => ({
      heavy_duty: $("m-heavy").checked, buzzer: num("m-buzzer"),
    })));
    $("form-horizon").addEventListener("submit", saveSettings("Horizon saved.", () => ({
      limits: { min_altitude_deg: num("h-min"), horizon: parseHorizon($("h-profile").value) },
    }), horizonWords));
    $("form-park").addEventListener("submit", saveSettings("Park position saved.", () => ({
      park: { mode: $("park-mode").value, ha_hours: num("park-ha"), dec_deg: num("park-dec") },
    })));
    $("form-safety").addEventListener("submit", saveSettings("Safety settings saved.", () => ({
      safety: { moveaxis_watchdog_s: num("s-watchdog"), on_shutdown: $("s-shutdown").value },
    })));
    $("form-observatory").addEventListener("submit", saveSettings("Observatory settings saved.", () => ({
      safety: { monitor: $("o-monitor").value.trim(), roof: $("o-roof").value.trim(), poll_s: num("o-poll"),
                unreachable_s: num("o-unreachable"), on_unsafe: $("o-on-unsafe").value },
    })));
    $("btn-find-devices").addEventListener("click", findSafetyDevices);
    $("btn-test-monitor").addEventListener("click", () => testSafetyDevice("monitor", "o-monitor"));
    $("btn-test-roof").addEventListener("click", () => testSafetyDevice("roof", "o-roof"));
    $("form-device").addEventListener("submit", saveSettings("Device name saved.", () => ({
      device: { name: $("d-name").value.trim() },
    })));
    $("form-server").addEventListener("submit", async (ev) => {
      ev.preventDefault();
      const body = {
        host: $("n-host").value.trim(), port: num("n-port"), discovery_port: num("n-disc"),
        mdns: $("n-mdns").checked, location: $("n-location").value,
      };
      const result = await run("Network settings saved; restart the server to apply them.",
        () => post("/setup/api/server", body), false, ev.target);
      if (result) fillServer(result);
    });
    $("form-hosts").addEventListener("submit", async (ev) => {
      ev.preventDefault();
      const names = $("n-hosts").value.split(/[\s,]+/).filter((n) => n);
      const result = await run("Allowed host names saved (in effect now).",
        () => post("/setup/api/server", { allowed_hosts: names }), false, ev.target);
      if (result) fillServer(result);
    });
    $("form-networks").addEventListener("submit", async (ev) => {
      ev.preventDefault();
      const lines = (id) => $(id).value.split(/[\s,]+/).filter((n) => n);
      const networks = { zwo_port: lines("n-zwo-networks"), stellarium: lines("n-stellarium-networks") };
      const result = await run("Bridge networks saved (in effect now).",
        () => post("/setup/api/server", { allowed_networks: networks }), false, ev.target);
      if (result) fillServer(result);
    });
  }

  // Who may connect to the bridges: each bridge's list, and what "local" means on this machine now.
  function fillNetworks(info) {
    const networks = info.allowed_networks || {};
    $("n-zwo-networks").value = (networks.zwo_port || []).join("\n");
    $("n-stellarium-networks").value = (networks.stellarium || []).join("\n");
    $("networks-local").textContent = (info.local_networks || []).join(", ");
  }

  // The DNS-rebinding guard: the names added, those always allowed, and a warning when it is off.
  function fillHosts(info) {
    const hosts = info.allowed_hosts || [];
    $("n-hosts").value = hosts.join("\n");
    $("hosts-always").textContent = (info.host_names || ["localhost"]).join(", ");
    const off = hosts.includes("*");
    $("hosts-warning").classList.toggle("hidden", !off);
    $("hosts-star").classList.toggle("hidden", !off);
  }

  // "Connect your software": what a program on another computer uses now (the running server's port, its
  // discovery and addresses), and what a restart would change (the saved network settings).
  function fillConnect(info) {
    const c = info.connect || { addresses: [] };
    const hosts = c.only_this_machine ? [c.listening_on] : [...(c.mdns_name ? [c.mdns_name] : []), ...c.addresses];
    const name = (info.devices.find((d) => d.number === device) || { name: "Telescope " + device }).name;
    setText("connect-discovery", c.only_this_machine
      ? "alpaca-zwo listens on this computer only (" + c.listening_on + "): programs on other computers cannot reach it. " +
        "To let them, set Listen address to 0.0.0.0 under Settings \u203a Network and restart alpaca-zwo."
      : info.discovery_port
        ? "Alpaca discovery is on (UDP " + info.discovery_port + "): in N.I.N.A. (Equipment \u203a Telescope) press the " +
          "refresh button and choose \u201c" + name + "\u201d; other Alpaca programs find it the same way."
        : "Alpaca discovery is off: programs will not find alpaca-zwo by themselves; add it by hand as below.", "small");
    setText("connect-manual", "By hand (Alpaca, manual entry): host " + (hosts.length ? hosts.join(" or ") : "this computer's address") +
      ", port " + info.port + ", device type Telescope, device number " + device + ".", "small");
    const saved = info.configured;
    const pending = [];
    if (saved.port !== 0 && saved.port !== info.port) pending.push("port " + saved.port);
    if ((saved.discovery_port || null) !== (info.discovery_port || null)) {
      pending.push(saved.discovery_port ? "discovery on UDP " + saved.discovery_port : "discovery off");
    }
    if (saved.host !== c.listening_on) pending.push("listen address " + saved.host);
    setText("connect-pending", pending.length ? "Saved, in effect after a restart: " + pending.join(", ") +
      ". Until then the values above are the ones in effect." : "", pending.length ? "small bad" : "small bad hidden");
  }

  function fillServer(info) {
    state.server = info;
    fillConnect(info);
    $("n-host").value = info.configured.host;
    $("n-port").value = info.configured.port;
    $("n-disc").value = info.configured.discovery_port;
    $("n-mdns").checked = info.configured.mdns;
    $("n-location").value = info.location;
    fillHosts(info);
    fillNetworks(info);
    setText("server-line", info.manufacturer + " \u00b7 version " + info.version + " \u00b7 port " + info.port +
      (info.discovery_port ? " \u00b7 discovery on UDP " + info.discovery_port : ""), "sub");
    setText("server-info", "Alpaca API: http://" + location.host + "/api/v1/telescope/" + device + "/ \u00b7 " +
      (info.config_file ? "settings file " + info.config_file : "settings not saved to a file"), "muted small");
    setText("footer", "alpaca-zwo " + info.version + (info.location ? " \u00b7 " + info.location : ""), "muted small");
    const select = $("device-select");
    if (info.devices.length > 1) {
      select.replaceChildren();
      for (const d of info.devices) {
        const opt = document.createElement("option");
        opt.value = String(d.number);
        opt.textContent = d.number + ": " + d.name;
        select.append(opt);
      }
      select.value = String(device);
      $("device-select-wrap").classList.remove("hidden");
    }
  }

  // ---------------------------------------------------------------- diagnostics

  async function refreshTrace() {
    if (!$("trace-panel").open) return;
    try {
      const data = await request(base + "/trace?after=" + state.traceAfter);
      const body = $("trace");
      for (const e of data.entries) {
        const tr = document.createElement("tr");
        const when = new Date(e.time * 1000).toISOString().slice(11, 23);
        for (const text of [when, e.request, e.reply === null ? "(none)" : e.reply, e.duration_ms.toFixed(1), e.note]) {
          const td = document.createElement("td");
          td.textContent = text;
          tr.append(td);
        }
        body.append(tr);
        state.traceAfter = e.time;
      }
      while (body.children.length > 500) body.firstChild.remove();
    } catch (err) {
      /* the status poll reports an unreachable server */
    }
  }

  async function refreshLog() {
    if (!$("log-panel").open) return;
    try {
      const data = await request("/setup/api/log?after=" + state.logAfter);
      const pre = $("log");
      const atBottom = pre.scrollTop + pre.clientHeight >= pre.scrollHeight - 4;
      for (const e of data.entries) {
        const when = new Date(e.time * 1000).toISOString().slice(11, 19) + " UTC"; // as the download, zone named
        pre.append(when + " " + e.level.padEnd(7) + " " + e.logger + ": " + e.message + "\n");
        state.logAfter = e.seq;
      }
      while (pre.childNodes.length > 1000) pre.firstChild.remove();
      if (atBottom) pre.scrollTop = pre.scrollHeight;
    } catch (err) {
      /* as above */
    }
  }

  // ---------------------------------------------------------------- start

  // Night mode and the dimmer: night.js put the stored choice on <html> before the first paint; these
  // keep the button, the slider and storage in step with it.
  function bindNight() {
    const root = document.documentElement;
    const button = $("btn-night");
    const store = (key, value) => {
      try { localStorage.setItem(key, value); } catch (_) { /* not kept */ }
    };
    let stored = null;
    try { stored = localStorage.getItem("alpaca-zwo-night"); } catch (_) { /* storage disabled */ }
    if (stored === "1") root.classList.add("night"); // night.js did this before the first paint, unless it failed to load
    button.setAttribute("aria-pressed", String(root.classList.contains("night")));
    button.addEventListener("click", () => {
      const on = !root.classList.contains("night");
      root.classList.toggle("night", on);
      button.setAttribute("aria-pressed", String(on));
      store("alpaca-zwo-night", on ? "1" : "0");
    });
    const dim = $("dim");
    const setDim = (percent) => {
      if (percent >= 100) root.style.removeProperty("--dim");
      else root.style.setProperty("--dim", String(percent / 100));
      root.classList.toggle("dimmed", percent < 100);
      dim.value = String(percent);
      dim.setAttribute("aria-valuetext", percent + "%");
    };
    let level = 100;
    try { level = Number(localStorage.getItem("alpaca-zwo-dim") || 100); } catch (_) { /* storage disabled */ }
    setDim(level >= 20 && level <= 100 ? level : 100);
    dim.addEventListener("input", () => {
      setDim(Number(dim.value));
      store("alpaca-zwo-dim", dim.value);
    });
  }

  // The page's end is padded by the bar's height as it is now (it grows on a phone while a motion line
  // shows), so the last control can always be scrolled clear of it; nothing above moves.
  function padForTheBar() {
    const bar = document.querySelector(".stop-bar");
    const pad = () => {
      const px = Math.ceil(bar.getBoundingClientRect().height) + 8 + "px";
      document.body.style.paddingBottom = px;
      document.documentElement.style.scrollPaddingBottom = px;
    };
    if (window.ResizeObserver) new ResizeObserver(pad).observe(bar);
    pad();
  }

  // The browser's own validation bubble is grey and white whatever the page's mode (no page CSS reaches it):
  // a field the browser finds invalid is said beside its form instead, in the page's colours (red in night
  // mode), the first such field of a submission only, and focused.
  function bindValidation() {
    let said = false;
    document.addEventListener("invalid", (ev) => {
      ev.preventDefault();
      if (said) return;
      said = true;
      setTimeout(() => { said = false; }, 0);
      const field = ev.target;
      const label = field.closest("label");
      const name = label && label.firstChild ? label.firstChild.textContent.trim() : field.name || field.id;
      message(name + ": " + field.validationMessage, "error", field.form || field);
      field.focus();
    }, true);
  }

  async function start() {
    padForTheBar();
    bindNight();
    bindValidation();
    bindTurn();
    orient(0);
    $("trace-download").href = base + "/trace.txt";
    $("device-select").addEventListener("change", (ev) => {
      location.href = "/setup/v1/telescope/" + ev.target.value + "/setup";
    });
    try {
      fillServer(await request("/setup/api/server"));
    } catch (err) {
      message("Could not reach the server: " + err.message);
      state.server = { jog_multiples: [20], sidereal_deg_s: 0.0041781 };
    }
    bindJog();
    bindControls();
    bindSettings();
    await loadSettings();
    poll();
    setInterval(refreshTrace, 2000);
    setInterval(refreshLog, 2000);
    $("trace-panel").addEventListener("toggle", refreshTrace);
    $("log-panel").addEventListener("toggle", refreshLog);
  }

  // The small hook the hand controller (handset.js) and the sky chart build on; the rest stays private.
  const statusListeners = [];
  window.alpacaZwo = Object.assign(window.alpacaZwo || {}, {
    base, request, post, message, clearMessages, poll, fmtHours, fmtDeg, fmtAz,
    project, unproject, R, MIN_ALT, // the chart's projection, for skychart.js
    geoInsecureText, geoErrorText, canLocate, siteSaved, // the site from this device, for fieldline.js
    onStatus: (listener) => { statusListeners.push(listener); },
  });

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
