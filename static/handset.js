/* alpaca-zwo hand controller (issue 25 items 1, 3, 4): find an object, GoTo or Sync on it, follow the slew.
 *
 * Built on the small hook app.js exposes (window.alpacaZwo: request, post, base, message, onStatus, the
 * DMS formatters), so app.js stays the status board. The server does every calculation (apparent place,
 * limits, pier side, refusals); this file only asks, shows and confirms. Nothing moves without a tap on
 * GoTo, and the Sun or a Sync never without a second tap on Confirm (the server insists: 409 until then).
 */
"use strict";

(function () {
  const hook = window.alpacaZwo;
  if (!hook) return;
  const $ = (id) => document.getElementById(id);
  const DEBOUNCE_MS = 250;
  const MAX_MATCHES = 8;
  const REFRESH_MS = 5000; // the selection's Alt/Az and limits, while it is shown
  const RATE_WINDOW_MS = 6000; // the approach rate is measured over this much recent time
  const ARRIVED_DEG = 0.05; // within this of the target at the end = arrived (else: stopped short)
  const KIND_WORDS = { slew: "Slewing to", park: "Parking at", "find home": "Going home to", "slew to alt/az": "Slewing to" };
  const PIER_WORDS = { pierEast: "east (looking west)", pierWest: "west (looking east)", pierUnknown: "unknown" };

  const hs = {
    matches: [],
    active: -1,
    selected: null, // the /object description of the selection
    pending: null, // {verb, id} waiting for Confirm
    ours: null, // {name, kind} of the slew this page started, to name it on arrival
    seen: null, // the running motion seen in the feed: {kind, target, name}
    approach: [], // [ms, degrees left]
    searchTimer: null,
    searchSeq: 0,
  };

  // ------------------------------------------------------------------ helpers

  async function postRaw(path, body) {
    let response;
    try {
      response = await fetch(path, {
        method: "POST", cache: "no-store", credentials: "same-origin",
        headers: { "Content-Type": "application/json", "X-Alpaca-Zwo": "1" },
        body: JSON.stringify(body),
      });
    } catch (err) {
      throw new Error("the server cannot be reached (" + err.message + ")");
    }
    let data = {};
    try { data = await response.json(); } catch (_) { /* no JSON: the status code says it */ }
    return { status: response.status, data };
  }

  function show(id, on) {
    $(id).classList.toggle("hidden", !on);
  }

  function separation(ra1, dec1, ra2, dec2) {
    const r = Math.PI / 180;
    const c = Math.sin(dec1 * r) * Math.sin(dec2 * r) +
      Math.cos(dec1 * r) * Math.cos(dec2 * r) * Math.cos((ra1 - ra2) * 15 * r);
    return Math.acos(Math.min(1, Math.max(-1, c))) / r;
  }

  function fmtAngle(deg) {
    if (deg >= 1) return deg.toFixed(deg >= 10 ? 0 : 1) + "\u00b0";
    if (deg >= 1 / 60) return (deg * 60).toFixed(0) + "\u2032";
    return (deg * 3600).toFixed(0) + "\u2033";
  }

  function fmtClock(iso) {
    if (!iso) return "\u2013";
    return new Date(iso).toLocaleTimeString([], { hour: "2-digit", minute: "2-digit", hourCycle: "h23" });
  }

  function where(pos) {
    return "RA " + hook.fmtHours(pos.ra) + ", Dec " + hook.fmtDeg(pos.dec) +
      " (Alt " + hook.fmtDeg(pos.alt) + ", Az " + hook.fmtAz(pos.az) + ")";
  }

  // ------------------------------------------------------------------ search

  function matchText(m) {
    return m.name + " \u2014 " + m.kind + (m.magnitude !== null && m.magnitude !== undefined ? ", mag " + m.magnitude.toFixed(1) : "");
  }

  function renderMatches() {
    const list = $("find-list");
    list.replaceChildren();
    hs.matches.forEach((m, i) => {
      const li = document.createElement("li");
      li.setAttribute("role", "option");
      li.id = "find-opt-" + i;
      li.setAttribute("aria-selected", String(i === hs.active));
      const b = document.createElement("button");
      b.type = "button";
      b.tabIndex = -1;
      b.textContent = matchText(m);
      b.addEventListener("click", () => select(m.id));
      li.append(b);
      list.append(li);
    });
    const open = hs.matches.length > 0;
    show("find-list", open);
    $("find").setAttribute("aria-expanded", String(open));
  }

  async function search(text) {
    const seq = ++hs.searchSeq;
    const q = text.trim();
    hs.query = null;
    if (!q) {
      hs.matches = [];
      renderMatches();
      setFindNote("");
      return hs.matches;
    }
    try {
      const data = await hook.request("/setup/api/objects?q=" + encodeURIComponent(q));
      if (seq !== hs.searchSeq) return hs.matches; // a newer keystroke won
      hs.matches = data.matches.slice(0, MAX_MATCHES);
      hs.query = text;
      hs.active = hs.matches.length ? 0 : -1;
      setFindNote(hs.matches.length ? "" : "Nothing found for \u201c" + q + "\u201d.");
    } catch (err) {
      if (seq !== hs.searchSeq) return hs.matches;
      hs.matches = [];
      setFindNote(err.message);
    }
    renderMatches();
    return hs.matches;
  }

  function setFindNote(text) {
    $("find-note").textContent = text;
    show("find-note", Boolean(text));
  }

  function bindSearch() {
    const input = $("find");
    input.addEventListener("input", () => {
      clearTimeout(hs.searchTimer);
      hs.searchTimer = setTimeout(() => search(input.value), DEBOUNCE_MS);
    });
    input.addEventListener("keydown", async (ev) => {
      if (ev.key === "ArrowDown" || ev.key === "ArrowUp") {
        if (!hs.matches.length) return;
        ev.preventDefault();
        hs.active = (hs.active + (ev.key === "ArrowDown" ? 1 : -1) + hs.matches.length) % hs.matches.length;
        renderMatches();
      } else if (ev.key === "Escape") {
        hs.matches = [];
        renderMatches();
      } else if (ev.key === "Enter") {
        ev.preventDefault();
        clearTimeout(hs.searchTimer);
        // Enter takes the highlighted match, or the best one for exactly what was typed.
        let chosen = hs.query === input.value ? hs.matches[hs.active] : null;
        if (!chosen) chosen = (await search(input.value))[0];
        if (chosen) select(chosen.id);
      }
    });
  }

  // ------------------------------------------------------------------ selection

  async function select(id) {
    hs.matches = [];
    renderMatches();
    cancelConfirm();
    try {
      const obj = await hook.request(hook.base + "/object?id=" + encodeURIComponent(id));
      hs.selected = obj;
      $("find").value = obj.name;
      renderSelection();
      document.dispatchEvent(new CustomEvent("alpaca-zwo-selected", { detail: obj }));
    } catch (err) {
      setFindNote(err.message);
    }
  }

  async function refreshSelection() {
    const obj = hs.selected;
    if (!obj || document.hidden) return;
    try {
      const fresh = await hook.request(hook.base + "/object?id=" + encodeURIComponent(obj.id));
      if (hs.selected && hs.selected.id === fresh.id) {
        hs.selected = fresh;
        renderSelection();
      }
    } catch (_) { /* the status poll reports an unreachable server */ }
  }

  function fact(dl, term, value, cls) {
    const dt = document.createElement("dt");
    dt.textContent = term;
    const dd = document.createElement("dd");
    dd.textContent = value;
    if (cls) dd.className = cls;
    dl.append(dt, dd);
  }

  function riseSet(o) {
    if (o.never_up) return "never rises here";
    if (o.always_up) return "always up; transit " + fmtClock(o.transit);
    return "rise " + fmtClock(o.rise) + " \u00b7 transit " + fmtClock(o.transit) + " \u00b7 set " + fmtClock(o.set);
  }

  function renderSelection() {
    const o = hs.selected;
    show("selection", Boolean(o));
    if (!o) return;
    $("sel-name").textContent = o.name;
    $("sel-kind").textContent = o.kind + (o.magnitude !== null && o.magnitude !== undefined ? " \u00b7 magnitude " + o.magnitude.toFixed(1) : "");
    const dl = $("sel-facts");
    dl.replaceChildren();
    fact(dl, "Alt / Az", hook.fmtDeg(o.altitude) + " / " + hook.fmtAz(o.azimuth));
    fact(dl, "RA / Dec", hook.fmtHours(o.ra) + " / " + hook.fmtDeg(o.dec));
    const up = o.above_limits;
    fact(dl, "Limits", up ? "above the horizon and limits" : "below the horizon or limits (" + o.horizon_floor.toFixed(1) + "\u00b0 there)",
      up ? "yes" : "bad");
    fact(dl, "Tonight", riseSet(o));
    fact(dl, "GoTo lands", o.destination_side_of_pier ? "pier " + PIER_WORDS[o.destination_side_of_pier] : "\u2013 (mount not connected)");
    $("btn-goto").classList.toggle("caution", !up);
  }

  // ------------------------------------------------------------------ GoTo, Sync, Confirm

  async function point(verb, confirm) {
    const o = hs.selected;
    if (!o) return;
    const body = { id: o.id };
    if (confirm) body.confirm = true;
    // Named before the request: a status poll can show the new slew before the POST's reply arrives,
    // and a short slew can end within that poll ("Slewing to the target", "Arrived at the target").
    const before = hs.ours;
    if (verb === "goto") hs.ours = { name: o.name, started: Date.now() };
    let reply;
    try {
      reply = await postRaw(hook.base + "/" + verb, body);
    } catch (err) {
      hs.ours = before;
      hook.message(err.message, "error");
      return;
    }
    if (verb === "goto" && reply.status !== 200) hs.ours = before;
    if (reply.status === 409 && reply.data.confirm) {
      hs.pending = { verb, id: o.id };
      $("confirm-text").textContent = reply.data.confirm;
      $("btn-confirm").textContent = "Confirm";
      show("confirm-box", true);
      $("btn-cancel").focus();
      return;
    }
    cancelConfirm();
    if (reply.status !== 200) {
      const words = reply.data.error || "HTTP " + reply.status;
      hook.message((verb === "goto" ? "GoTo " : "Sync on ") + o.name + " refused: " + words, "error");
      setArrival("", "");
      return;
    }
    hs.selected = Object.assign({}, o, reply.data);
    renderSelection();
    if (verb === "goto") {
      setArrival("", "");
      hook.message("GoTo " + o.name + " started.", "info");
    } else {
      hook.message("Synced on " + o.name + ": the mount now reads RA " + hook.fmtHours(reply.data.ra) +
        ", Dec " + hook.fmtDeg(reply.data.dec) + ".", "info");
    }
    hook.poll(true);
  }

  function cancelConfirm() {
    hs.pending = null;
    show("confirm-box", false);
  }

  function bindButtons() {
    $("btn-goto").addEventListener("click", () => point("goto", false));
    $("btn-sync").addEventListener("click", () => point("sync", false));
    $("btn-confirm").addEventListener("click", () => {
      const p = hs.pending;
      if (p && hs.selected && hs.selected.id === p.id) point(p.verb, true);
      else cancelConfirm();
    });
    $("btn-cancel").addEventListener("click", cancelConfirm);
  }

  // ------------------------------------------------------------------ progress and arrival

  function setArrival(text, cls) {
    const box = $("arrival");
    box.textContent = text;
    box.className = "arrival" + (cls ? " " + cls : "") + (text ? "" : " hidden");
  }

  function eta(left) {
    const now = performance.now();
    hs.approach.push([now, left]);
    while (hs.approach.length > 2 && now - hs.approach[0][0] > RATE_WINDOW_MS) hs.approach.shift();
    const [t0, d0] = hs.approach[0];
    const rate = (d0 - left) / ((now - t0) / 1000); // degrees per second, closing
    if (hs.approach.length < 2 || !(rate > 0.01)) return "";
    const s = left / rate;
    return s < 90 ? ", about " + Math.max(1, Math.round(s)) + " s" : ", about " + Math.round(s / 60) + " min";
  }

  function onStatus(s) {
    const m = s.motion;
    const running = Boolean(m && m.active && s.connected);
    if (running) {
      const name = m.kind === "slew" && hs.ours ? hs.ours.name : null;
      if (!hs.seen || hs.seen.kind !== m.kind) hs.approach = [];
      const since = hs.seen && hs.seen.kind === m.kind ? hs.seen.since : Date.now();
      hs.seen = { kind: m.kind, target: m.target, name, since };
      let text = (KIND_WORDS[m.kind] || "Moving to") + " " + (name || (m.kind === "park" ? "the park position" : m.kind === "find home" ? "home" : "the target"));
      if (m.target && s.position) {
        const left = separation(s.position.ra, s.position.dec, m.target.ra, m.target.dec);
        text += ": " + fmtAngle(left) + " left" + eta(left);
      }
      $("progress").textContent = text;
      show("progress", true);
      setArrival("", "");
      return;
    }
    show("progress", false);
    if (hs.seen && m) ended(s, m, hs.seen);
    hs.seen = null;
    hs.approach = [];
  }

  function ended(s, m, seen) {
    if (hs.ours && hs.ours.started <= seen.since) hs.ours = null; // a newer GoTo keeps its name
    const pos = s.position;
    const what = seen.name || (seen.kind === "park" ? "the park position" : seen.kind === "find home" ? "home" : "the target");
    const left = pos && seen.target ? separation(pos.ra, pos.dec, seen.target.ra, seen.target.dec) : null;
    if (!m.error && (left === null || left <= ARRIVED_DEG || seen.kind !== "slew")) {
      const verb = seen.kind === "park" ? "Parked" : seen.kind === "find home" ? "At home" : "Arrived at " + what;
      setArrival(verb + (pos ? ": " + where(pos) : "") + ".", "ok");
      return;
    }
    const why = m.error === "stopped" ? "it was stopped (STOP, or another program stopped it)"
      : m.error === "replaced" ? "another slew replaced it" : m.error || "the mount stopped short";
    setArrival("Stopped before reaching " + what + (left !== null ? ", " + fmtAngle(left) + " away" : "") +
      ", because " + why + (pos ? ". Now at " + where(pos) : "") + ".", "bad");
  }

  // ------------------------------------------------------------------ start

  function start() {
    if (!$("find")) return;
    bindSearch();
    bindButtons();
    hook.onStatus(onStatus);
    setInterval(refreshSelection, REFRESH_MS);
  }

  // The sky chart (skychart.js) selects a star or object tapped on the chart through this.
  hook.select = select;

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
