/* alpaca-zwo in the field (issue 31): one line near the top when the clock or the site needs a person.
 *
 * - This device's clock against the server's, measured on every status poll (the server's time at the
 *   middle of the request's round trip; the sample with the shortest round trip of the last few wins).
 *   More than 2 s apart: "The server's clock is 3 h 0 min behind this phone's" and a button,
 *   Use this device's time, which sends this device's time, carried forward by half the round trip, and
 *   shows the mount's clock as read back by the server.
 * - The server keeping the mount's clock (its own is not synchronised) is said here too.
 * - While the site is still the factory default, the line offers this device's position (browsers give
 *   it only to secure pages: the same explanation as the Site form's button).
 * Built on app.js's hook (window.alpacaZwo), like handset.js.
 */
"use strict";

(function () {
  const hook = window.alpacaZwo;
  if (!hook) return;
  const $ = (id) => document.getElementById(id);
  const TOLERANCE_S = 2;
  const SAMPLES = 8;
  const fl = { samples: [], status: null, busy: false };

  // "3 h 0 min", "12 min 5 s", "4.2 s": as the server words a clock difference (timekeeping.py's
  // describe_difference), rounded to its last unit, so 10,799.6 s reads "3 h 0 min", not "2 h 59 min".
  function difference(seconds) {
    const s = Math.abs(seconds);
    if (s < 59.95) return s.toFixed(1) + " s";
    const total = Math.round(s);
    if (total < 3600) return Math.floor(total / 60) + " min " + (total % 60) + " s";
    const minutes = Math.round(s / 60);
    if (minutes < 48 * 60) return Math.floor(minutes / 60) + " h " + (minutes % 60) + " min";
    const hours = Math.round(s / 3600);
    return Math.floor(hours / 24) + " d " + (hours % 24) + " h";
  }

  const deviceWord = () => (navigator.maxTouchPoints > 0 ? "phone's" : "device's");

  // The server's clock minus this device's, in seconds, from the best recent sample (null: none yet).
  function measure(s) {
    const timing = s.client_timing;
    if (!timing) return null;
    const rtt = timing.received - timing.sent;
    const offset = (Date.parse(s.time.utc) - (timing.sent + timing.received) / 2) / 1000;
    fl.samples.push({ offset, rtt });
    if (fl.samples.length > SAMPLES) fl.samples.shift();
    return fl.samples.reduce((best, x) => (x.rtt < best.rtt ? x : best)).offset;
  }

  function bestRoundTrip() {
    return fl.samples.length ? Math.min(...fl.samples.map((x) => x.rtt)) : 0;
  }

  function show(id, on) {
    $(id).classList.toggle("hidden", !on);
  }

  function render(s) {
    fl.status = s;
    const offset = measure(s);
    const wrong = offset !== null && Math.abs(offset) > TOLERANCE_S;
    const clock = s.time || {};
    let text = "";
    if (wrong) {
      text = "The server's clock is " + difference(offset) + " " + (offset < 0 ? "behind" : "ahead of") +
        " this " + deviceWord() + ".";
    }
    if (clock.source === "mount") {
      text += (text ? " " : "") + "The server keeps the mount's clock: " + clock.reason + ".";
    }
    const site = s.site || {};
    const gps = site.gps;
    const defaultSite = Boolean(site.default) && !(gps && gps.site_from_gps);
    setText("clock-line", text);
    show("btn-device-time", wrong);
    setText("site-line", defaultSite ? "The site is still the default (Greenwich): where is the telescope?" : "");
    show("btn-device-site", defaultSite && hook.canLocate());
    show("field-note", defaultSite && fl.tip);
    show("clock-row", Boolean(text));
    show("site-row", defaultSite);
    show("field-line", Boolean(text) || defaultSite);
    setText("time-source", sourceText(clock));
    $("time-source").title = clock.reason || "";
    setText("time-reason", clock.reason ? "Time source: " + sourceText(clock) + ": " + clock.reason + ". Host clock: " +
      clock.host_status + "." : "");
    setText("site-source", gps ? gpsText(gps) : (site.default ? "default (Greenwich): not set yet" : "set in the settings"));
  }

  function setText(id, text) {
    const el = $(id);
    if (el.textContent !== text) el.textContent = text;
  }

  function sourceText(clock) {
    const names = { host: "this computer's clock", mount: "the mount's clock", client: "set by a client or this page" };
    const host = clock.host_synchronised === false ? "not synchronised" : clock.host_synchronised ? "synchronised" : "status unknown";
    const last = clock.host_last_synchronised ? ", last synchronised " + clock.host_last_synchronised.replace("T", " ").replace(/\.\d+Z$/, " UTC") : "";
    return (names[clock.source] || clock.source || "\u2013") + " (host clock " + host + last + ")";
  }

  function gpsText(gps) {
    if (gps.site_from_gps) return "site from GPS (" + gps.fix + " fix)";
    if (!gps.connected) return "GPS: gpsd not reached" + (gps.last_error ? " (" + gps.last_error + ")" : "");
    if (gps.fix === "3D") return "GPS: 3D fix held " + (gps.fix_held_s || 0).toFixed(0) + " s";
    return "GPS: waiting for a 3D fix";
  }

  async function useDeviceTime() {
    if (fl.busy) return;
    fl.busy = true;
    const button = $("btn-device-time");
    button.disabled = true;
    try {
      const reply = await hook.post(hook.base + "/action/time",
        { utc: new Date().toISOString(), round_trip_ms: Math.round(bestRoundTrip()) });
      fl.samples = []; // the server's clock has moved: measure afresh
      if (reply.mount_set && reply.mount_utc) {
        hook.message("Time set from this device. The mount's clock reads " + reply.mount_utc.slice(11, 19) +
          " UTC (" + difference(reply.mount_difference_s) + " from the server's, within the mount's whole seconds).", "info");
      } else if (reply.mount_set) {
        hook.message("Time set from this device and sent to the mount.", "info");
      } else {
        hook.message("The server's time is set from this device; the mount gets it when it is connected.", "info");
      }
    } catch (err) {
      hook.message("Setting the time failed: " + err.message, "error", $("clock-row"));
    } finally {
      button.disabled = false;
      fl.busy = false;
      hook.poll(true);
    }
  }

  // The first-run site form sits in the line itself: latitude, longitude and elevation where the prompt is,
  // and this device's position only where the browser can answer (https or localhost).
  function useDevicePosition() {
    const note = $("field-note");
    const explain = (text) => { note.textContent = text; fl.tip = Boolean(text); note.classList.toggle("hidden", !text); };
    explain("");
    navigator.geolocation.getCurrentPosition((p) => {
      $("fs-lat").value = p.coords.latitude.toFixed(6);
      $("fs-lon").value = p.coords.longitude.toFixed(6);
      if (p.coords.altitude !== null) $("fs-elev").value = p.coords.altitude.toFixed(0);
      saveSite();
    }, (err) => explain(hook.geoErrorText(err, "here")), { enableHighAccuracy: true, timeout: 20000 });
  }

  async function saveSite(ev) {
    if (ev) ev.preventDefault();
    const site = { latitude: Number($("fs-lat").value), longitude: Number($("fs-lon").value),
      elevation: Number($("fs-elev").value) };
    try {
      const reply = await hook.post(hook.base + "/settings", { site });
      hook.message(hook.siteSaved(reply), "info");
      hook.poll(true);
    } catch (err) {
      hook.message("Site not saved: " + err.message, "error", $("form-first-site"));
    }
  }

  function start() {
    $("btn-device-time").addEventListener("click", useDeviceTime);
    $("btn-device-site").addEventListener("click", useDevicePosition);
    $("form-first-site").addEventListener("submit", saveSite);
    if (!hook.canLocate()) {
      $("field-note").textContent = hook.geoInsecureText("here");
      fl.tip = true;
    }
    hook.onStatus(render);
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
