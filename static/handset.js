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
  const MAX_QUERY = 80; // the server's limit: longer text is no name or coordinates
  const TOO_LONG = "That is longer than any name or coordinates (80 characters at most): type a name such as " +
    "Vega, M31 or Omega Centauri, or coordinates such as 5h35m \u22125\u00b023\u2032.";
  const REFRESH_MS = 5000; // the selection's Alt/Az and limits, while it is shown
  const RATE_WINDOW_MS = 6000; // the approach rate is measured over this much recent time
  const ARRIVED_DEG = 0.05; // within this of the target at the end = arrived (else: stopped short)
  const KIND_WORDS = { slew: "Slewing to", park: "Parking at", "find home": "Going home to", "slew to alt/az": "Slewing to" };
  const SYNC_NOT_UP = "Sync needs the telescope centred on it; it is not up";
  const PIER_WORDS = { pierEast: "east (looking west)", pierWest: "west (looking east)", pierUnknown: "unknown" };

  const hs = {
    matches: [],
    active: -1, // the match Enter takes: the first only when the server is confident, else one the user chose
    confident: false,
    note: null, // the server's note on the last search (ambiguous coordinates, several matches, satellites)
    selected: null, // the /object description of the selection
    pending: null, // {verb, id} waiting for Confirm
    ours: null, // {name, kind} of the slew this page started, to name it on arrival
    seen: null, // the running motion seen in the feed: {kind, target, name}
    approach: [], // [ms, degrees left]
    stopping: null, // {acked: ms} from a tap on STOP until the mount is at rest (acked: 0 until it has the stop)
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

  // "2026-11-26T19:02:00+09:00" (the server's site time) → "19:02": the clock as read at the site.
  function siteClock(iso) {
    return iso ? iso.slice(11, 16) : "\u2013";
  }

  function where(pos) {
    return "RA " + hook.fmtHours(pos.ra) + ", Dec " + hook.fmtDeg(pos.dec) +
      " (Alt " + hook.fmtDeg(pos.alt) + ", Az " + hook.fmtAz(pos.az) + ")";
  }

  // ------------------------------------------------------------------ search

  // "M31 · Andromeda Galaxy — galaxy, mag 3.4": the name it matched by (or its best other name) beside the title.
  function matchText(m) {
    const other = m.matched || (m.common_names && m.common_names[0]) || (m.aliases && m.aliases[0]) || "";
    return m.name + (other && other !== m.name ? " \u00b7 " + other : "") + " \u2014 " + m.kind +
      (m.magnitude !== null && m.magnitude !== undefined ? ", mag " + m.magnitude.toFixed(1) : "");
  }

  function renderMatches() {
    const list = $("find-list");
    list.replaceChildren();
    hs.matches.forEach((m, i) => {
      const li = document.createElement("li");
      li.setAttribute("role", "option");
      li.id = "find-opt-" + i;
      li.setAttribute("aria-selected", String(i === hs.active));
      // The option itself takes the tap (a button inside an option is a control inside a control: axe's
      // nested-interactive); the keyboard stays in the search field (arrows, Enter), as a combobox's does.
      li.textContent = matchText(m);
      li.addEventListener("click", () => select(m.id));
      list.append(li);
    });
    const open = hs.matches.length > 0;
    show("find-list", open);
    $("find").setAttribute("aria-expanded", String(open));
    if (open && hs.active >= 0) $("find").setAttribute("aria-activedescendant", "find-opt-" + hs.active);
    else $("find").removeAttribute("aria-activedescendant");
  }

  async function search(text) {
    const seq = ++hs.searchSeq;
    const q = text.trim();
    hs.query = null;
    hs.confident = false;
    hs.note = null;
    if (!q || q.length > MAX_QUERY) {
      hs.matches = [];
      renderMatches();
      setFindNote(q ? TOO_LONG : "");
      return hs.matches;
    }
    try {
      const data = await hook.request("/setup/api/objects?q=" + encodeURIComponent(q));
      if (seq !== hs.searchSeq) return hs.matches; // a newer keystroke won
      hs.matches = data.matches.slice(0, MAX_MATCHES);
      hs.query = text;
      hs.confident = Boolean(data.confident) && hs.matches.length > 0;
      hs.note = data.note || null;
      hs.active = hs.confident ? 0 : -1;
      // A question (which reading of these coordinates?) or a reason for nothing shows at once;
      // "several match" only when Enter cannot choose.
      const coordinates = hs.matches.length > 1 && hs.matches[0].id.startsWith("radec:");
      setFindNote(!hs.matches.length ? hs.note || nothingFound(q) : coordinates ? hs.note : "");
    } catch (err) {
      if (seq !== hs.searchSeq) return hs.matches;
      hs.matches = [];
      setFindNote(err.message);
    }
    renderMatches();
    return hs.matches;
  }

  function nothingFound(q) {
    return "Nothing found for \u201c" + q + "\u201d: try a name (Vega, Orion Nebula), a catalogue number " +
      "(M42, NGC 2070, C80, HIP 71683) or coordinates (5h35m \u22125\u00b023\u2032).";
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
        const n = hs.matches.length;
        hs.active = hs.active < 0 ? (ev.key === "ArrowDown" ? 0 : n - 1) : (hs.active + (ev.key === "ArrowDown" ? 1 : -1) + n) % n;
        renderMatches();
      } else if (ev.key === "Escape") {
        hs.matches = [];
        renderMatches();
      } else if (ev.key === "Enter") {
        ev.preventDefault();
        clearTimeout(hs.searchTimer);
        // Enter takes the match chosen with the arrow keys, or the first when the server is sure it is the
        // one meant ("Vega", "M31"); otherwise it says why not and leaves the choice to the person.
        if (hs.query !== input.value) await search(input.value);
        const chosen = hs.matches[hs.active];
        if (chosen) select(chosen.id);
        else if (hs.matches.length) setFindNote((hs.note || "Several objects match.") + " Use \u2193 and Enter, or tap one.");
      }
    });
  }

  // ------------------------------------------------------------------ selection

  // from: "chart" when tapped or chosen on the sky chart (a phone then shows the card as a sheet over the page).
  async function select(id, from) {
    hook.clearMessages(); // what they said was about the last object, or what was done before it
    hs.matches = [];
    renderMatches();
    cancelConfirm();
    const typed = $("find").value;
    try {
      const obj = keepName(await hook.request(hook.base + "/object?id=" + encodeURIComponent(id)), typed);
      hs.selected = obj;
      $("find").value = obj.name;
      renderSelection();
      placeCard(from === "chart" && PHONE.matches);
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
        hs.selected = keepName(fresh, hs.selected.name);
        renderSelection();
      }
    } catch (_) { /* the status poll reports an unreachable server */ }
  }

  // The name the person used when it is one of the object's common names and the catalogue's name is a
  // designation ("Omega Centauri", not "NGC 5139"; "LMC" stays "Large Magellanic Cloud"): the card, the GoTo
  // messages, the progress and arrival lines and so the log keep it; the designation stays on the card's
  // second line.
  function keepName(obj, typed) {
    const fold = (t) => (t || "").normalize("NFKD").replace(/[\u0300-\u036f]/g, "").toLowerCase().replace(/\s+/g, " ").trim();
    const designation = /\d/.test(obj.name);
    const named = designation && (obj.common_names || []).find((n) => fold(n) === fold(typed));
    if (named && named !== obj.name) {
      obj.designation = obj.name;
      obj.name = named;
    }
    return obj;
  }

  function fact(dl, term, value, cls) {
    const dt = document.createElement("dt");
    dt.textContent = term;
    const dd = document.createElement("dd");
    dd.textContent = value;
    if (cls) dd.className = cls;
    dl.append(dt, dd);
  }

  const EVENT_WORDS = { rise: "rises", transit: "highest", set: "sets" };
  const ZONE_SOURCE = { site: "", server: ", the server's zone", longitude: " from the longitude, no daylight saving" };

  // Tonight as it happens, in the site's clock with its zone named once (the server gives the zone of
  // the site's own coordinates, daylight saving included): from dark (the Sun 18° down) to dawn, the
  // object's rise, highest point and set in between, in time order, and its best time while it is dark.
  function tonightText(o) {
    if (o.never_up) return "never rises here";
    const t = o.tonight;
    if (!t) return "\u2013";
    const now = Date.now();
    const items = [[t.start, Date.parse(t.start) <= now + 60000 ? (t.dark ? "dark now" : "darkest now")
      : (t.dark ? "dark " : "darkest ") + siteClock(t.start)]];
    for (const e of t.events) items.push([e.at, EVENT_WORDS[e.what] + " " + siteClock(e.at)]);
    items.push([t.end, (t.dark ? "dawn " : "brightening ") + siteClock(t.end)]);
    if (t.best) { // the highest it stands while dark: said at the event it falls on, else on its own
      const best = "(" + t.best_altitude.toFixed(0) + "\u00b0, best)";
      const at = items.find((i) => i[0] === t.best);
      if (at) at[1] += " " + best;
      else items.push([t.best, "best " + siteClock(t.best) + " (" + t.best_altitude.toFixed(0) + "\u00b0)"]);
    }
    items.sort((x, y) => Date.parse(x[0]) - Date.parse(y[0]));
    const plan = items.map((i) => i[1]).join(" \u00b7 ") + (t.best ? "" : " \u00b7 not up while it is dark");
    return (t.dark ? "" : "no full darkness tonight: ") + plan +
      " (" + (o.site_zone || "site time") + (ZONE_SOURCE[o.site_zone_source] || "") + ")";
  }

  function times(dl, o) {
    fact(dl, "Tonight", tonightText(o));
  }

  function renderSelection() {
    const o = hs.selected;
    show("selection", Boolean(o));
    if (!o) return;
    $("sel-name").textContent = o.name;
    const names = [...(o.designation ? [o.designation] : []), ...(o.common_names || []).filter((n) => n !== o.name).slice(0, 2),
      ...(o.aliases || []).filter((a) => !a.startsWith("HIP")).slice(0, 2)];
    $("sel-kind").textContent = o.kind + (o.magnitude !== null && o.magnitude !== undefined ? " \u00b7 magnitude " + o.magnitude.toFixed(1) : "") +
      (names.length ? " \u00b7 " + names.join(", ") : "");
    const dl = $("sel-facts");
    dl.replaceChildren();
    fact(dl, "Alt / Az", hook.fmtDeg(o.altitude) + " / " + hook.fmtAz(o.azimuth));
    fact(dl, "RA / Dec", hook.fmtHours(o.ra) + " / " + hook.fmtDeg(o.dec));
    // The server's verdict, from the very check its GoTo runs first: the limit that blocks, by name
    // (the server's horizon and minimum altitude, the mount's horizon and stored altitude limits, now and
    // when the slew would land), or what the mount's state needs; refreshed with the card as the sky turns.
    const verdict = o.verdict || {};
    const up = Boolean(verdict.reachable);
    fact(dl, "Limits", verdict.says || "\u2013", up ? "yes" : "bad");
    if (o.phase) fact(dl, "Phase", o.phase.words + ", " + o.phase.lit_percent.toFixed(0) + "% lit");
    times(dl, o);
    fact(dl, "GoTo lands", o.destination_side_of_pier ? "pier " + PIER_WORDS[o.destination_side_of_pier] : "\u2013 (mount not connected)");
    goButton(o, up);
  }

  // A target under the allowed sky gets no GoTo that must be refused: the button says when it comes up
  // ("Not up: rises 00:28", the server's words in the site's clock) and takes no tap, and the card's
  // refresh turns it back into GoTo once it is up. Sync goes with it: a sync says the telescope is centred
  // on the target now, which the limits keep it from being while the target is not up. Other refusals
  // (parked, not connected, the mount's upper limit) keep a GoTo whose refusal says what to do.
  function goButton(o, up) {
    const button = $("btn-goto");
    const notUp = o.not_up;
    button.disabled = Boolean(notUp);
    button.textContent = notUp ? notUp.words : "GoTo";
    button.classList.toggle("not-up", Boolean(notUp));
    button.classList.toggle("caution", !up && !notUp);
    const sync = $("btn-sync");
    sync.disabled = Boolean(notUp);
    sync.classList.toggle("not-up", Boolean(notUp));
    if (notUp) {
      sync.title = SYNC_NOT_UP;
      sync.setAttribute("aria-label", SYNC_NOT_UP);
    } else {
      sync.removeAttribute("title");
      sync.removeAttribute("aria-label");
    }
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
    if (verb === "goto") {
      hs.ours = { name: o.name, started: Date.now() };
      hs.stopping = null; // a new GoTo ends the wait for the last stop's rest: its progress takes the line
    }
    let reply;
    try {
      reply = await postRaw(hook.base + "/" + verb, body);
    } catch (err) {
      hs.ours = before;
      hook.message(err.message, "error", $("btn-goto"));
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
      hook.message((verb === "goto" ? "GoTo " : "Sync on ") + o.name + " refused: " + words, "error", $("btn-goto"));
      setArrival("", "");
      return;
    }
    hs.selected = keepName(Object.assign({}, o, reply.data), o.name);
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
    show("arrival-close", Boolean(text));
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

  // STOP is honest through braking: the mount keeps moving for a second or more after it has the stop, and
  // Alpaca's Slewing (the status's "slewing") stays true until it is at rest. So a stop pressed here shows
  // "Stopping…" from the tap, and the line says where the mount came to rest only from a reading taken
  // after the mount acknowledged the stop and with Slewing false; a slew stopped from elsewhere waits
  // for rest the same way before it says where the mount is.
  function stopPressed() {
    hs.stopping = { acked: 0 };
    braking("Stopping\u2026");
  }

  function stopAcknowledged(ok) {
    if (!hs.stopping) return;
    if (ok) hs.stopping.acked = Date.now();
    else {
      hs.stopping = null; // the stop did not reach the mount: the status line and STOP's error say so
      show("progress", false);
    }
  }

  function braking(text) {
    $("progress").textContent = text;
    show("progress", true);
    setArrival("", "");
  }

  /** A reading to judge the stop by: the poll was sent after the mount acknowledged it. */
  function afterTheStop(s) {
    const stop = hs.stopping;
    return Boolean(stop && stop.acked && s.client_timing && s.client_timing.sent >= stop.acked);
  }

  function onStatus(s) {
    const m = s.motion;
    if (hs.stopping && !afterTheStop(s)) return; // "Stopping…" until a reading the stop can be judged by
    const running = Boolean(m && m.active && s.connected);
    if (running && !hs.stopping) {
      progress(s, m);
      return;
    }
    if (s.connected && s.slewing && (hs.stopping || (hs.seen && m && m.error))) {
      braking(hs.stopping ? "Stopping: the mount has the stop and is braking\u2026" : "Stopping: the mount is braking\u2026");
      return;
    }
    show("progress", false);
    if (hs.seen && m) ended(s, m, hs.seen, Boolean(hs.stopping));
    else if (hs.stopping) setArrival("Stopped" + (s.position ? ": at rest at " + where(s.position) : "") + ".", "");
    hs.stopping = null;
    hs.seen = null;
    hs.approach = [];
  }

  function progress(s, m) {
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
  }

  // How a motion ended, said once the mount is at rest; byStop: the STOP pressed on this page ended it.
  function ended(s, m, seen, byStop) {
    if (hs.ours && hs.ours.started <= seen.since) hs.ours = null; // a newer GoTo keeps its name
    const pos = s.position;
    const what = seen.name || (seen.kind === "park" ? "the park position" : seen.kind === "find home" ? "home" : "the target");
    const left = pos && seen.target ? separation(pos.ra, pos.dec, seen.target.ra, seen.target.dec) : null;
    if (!m.error && (left === null || left <= ARRIVED_DEG || seen.kind !== "slew")) {
      const verb = seen.kind === "park" ? "Parked" : seen.kind === "find home" ? "At home" : "Arrived at " + what;
      setArrival(verb + (pos ? ": " + where(pos) : "") + ".", "ok");
      return;
    }
    const short = "Stopped before reaching " + what + (left !== null ? ", " + fmtAngle(left) + " away" : "");
    const rest = pos ? ". At rest at " + where(pos) + "." : ".";
    if (byStop && m.error === "stopped") {
      setArrival(short + rest, ""); // what the person asked for: said plainly, not as a fault
      return;
    }
    const why = m.error === "stopped" ? "another program (or another page) stopped it"
      : m.error === "replaced" ? "another slew replaced it" : m.error || "the mount stopped short";
    setArrival(short + ", because " + why + rest, "bad");
  }

  // ------------------------------------------------------------------ the phone's sheet

  // On a phone the chart is far from the hand controller: an object chosen on the chart gets its card (with
  // GoTo and Sync) in the dock above the motion line and STOP, and the chart is kept in view above
  // it, so a tap on a star and its GoTo are on one screen. × or a search puts the card back in place.
  const PHONE = window.matchMedia("(max-width: 720px)");
  function placeCard(asSheet) {
    const card = $("selection");
    const inSheet = card.parentElement === $("sheet-slot");
    if (asSheet && !inSheet) $("sheet-slot").append(card);
    else if (!asSheet && inSheet) $("find-note").after(card);
    if (asSheet) keepChartInView();
  }

  // The chart and the line under it (what a tap chose, "Select these coordinates") above the sheet.
  function keepChartInView() {
    const top = $("sky").getBoundingClientRect().top;
    const below = $("sky-offer") || $("sky");
    const bottom = below.getBoundingClientRect().bottom;
    const sheetTop = $("sheet-slot").getBoundingClientRect().top;
    if (top < 0 || bottom > sheetTop) window.scrollBy(0, top - Math.max(4, (sheetTop - (bottom - top)) / 2));
  }

  // ------------------------------------------------------------------ start

  function start() {
    if (!$("find")) return;
    bindSearch();
    bindButtons();
    $("sel-close").addEventListener("click", () => placeCard(false));
    $("arrival-close").addEventListener("click", () => setArrival("", ""));
    PHONE.addEventListener("change", () => { if (!PHONE.matches) placeCard(false); });
    hook.onStatus(onStatus);
    document.addEventListener("alpaca-zwo-stop", stopPressed);
    document.addEventListener("alpaca-zwo-stop-sent", (ev) => stopAcknowledged(ev.detail.ok));
    setInterval(refreshSelection, REFRESH_MS);
  }

  // The sky chart (skychart.js) selects a star or object tapped on the chart through this.
  hook.select = select;
  hook.closeCard = () => placeCard(false);

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
