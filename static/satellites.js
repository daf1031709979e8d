/* alpaca-zwo satellites (issue 41): keep TLE sets, list their passes in the site's time, follow one.
 *
 * The server does every computation (SGP4, the limits, the pier side); this script shows its answers
 * from /setup/api/telescope/N/satellites and sends the person's choices. The list is read when the page
 * opens and after each change; while a follow runs its progress is read every two seconds.
 * Built on app.js's hook (window.alpacaZwo), like fieldline.js.
 */
"use strict";

(function () {
  const hook = window.alpacaZwo;
  if (!hook) return;
  const $ = (id) => document.getElementById(id);
  const api = hook.base + "/satellites";
  let following = false;

  // "22:15:42" of an instant's site time ("2018-05-15T22:15:42+01:00").
  const clock = (instant) => (instant ? instant.site.slice(11, 19) : "\u2013");
  const day = (instant) => instant.site.slice(0, 10);

  function cell(row, text, className) {
    const td = document.createElement("td");
    td.textContent = text;
    if (className) td.className = className;
    row.append(td);
    return td;
  }

  function followButton(number, name) {
    const button = document.createElement("button");
    button.type = "button";
    button.textContent = "Follow";
    button.addEventListener("click", async () => {
      try {
        render(await hook.post(api + "/follow", { number }));
        hook.message("Following " + name + ": the mount goes to where the pass begins.", "info");
        hook.poll(true);
      } catch (err) {
        hook.message("Follow " + name + " failed: " + err.message, "error", button);
      }
    });
    return button;
  }

  function passRow(body, sat, p, first) {
    const row = document.createElement("tr");
    cell(row, first ? sat.name + (sat.warning ? " \u26a0" : "") : "").title = sat.warning || "";
    cell(row, day(p.rise) + " " + clock(p.rise) + " \u2192 " + clock(p.set));
    cell(row, p.max_altitude.toFixed(0) + "\u00b0 at " + clock(p.culmination));
    let part = clock(p.enters) + "\u2013" + clock(p.side_until || p.leaves);
    if (p.side) part += " (" + p.side + ")";
    if (p.flip) {  // a meridian flip mid-pass, then the second leg on the other side
      part += ", flip " + p.flip.gap_s + " s, " + clock(p.flip.resumes) + "\u2013" +
        clock(p.flip.until || p.leaves) + " (" + p.flip.side + ")";
      if (p.flip.note) part += ": then " + p.flip.note;
    } else if (p.side_note) part += ": then " + p.side_note;
    if (p.keyhole) part += "; alt-az: too fast near the zenith";
    cell(row, part, "small");
    const last = document.createElement("td");
    if (first) last.append(followButton(sat.number, sat.name));
    row.append(last);
    body.append(row);
  }

  function render(view) {
    const body = $("sat-passes");
    body.replaceChildren();
    for (const sat of view.satellites) {
      if (!sat.passes.length) {
        const row = document.createElement("tr");
        cell(row, sat.name + (sat.warning ? " \u26a0" : "")).title = sat.warning || "";
        cell(row, "no pass over the allowed sky in the next " + view.hours + " h").colSpan = 3;
        row.append(document.createElement("td"));
        body.append(row);
      }
      sat.passes.forEach((p, i) => passRow(body, sat, p, i === 0));
    }
    $("sat-zone").textContent = view.satellites.length ? "Times in the site's zone: " + view.site_zone + "." : "";
    showProgress(view.progress, view.following);
  }

  function showProgress(progress, running) {
    following = running;
    const line = $("sat-progress");
    line.classList.toggle("hidden", !progress);
    if (!progress) return;
    let text = progress.name + ": " + progress.phase;
    if (progress.error_arcmin !== null) text += ", off by " + progress.error_arcmin.toFixed(1) + "\u2032";
    if (progress.rms_arcmin !== null) text += " (RMS " + progress.rms_arcmin.toFixed(2) + "\u2032)";
    if (progress.ended) text += ", ended: " + progress.ended;
    line.textContent = text;
  }

  async function load() {
    try {
      render(await hook.request(api));
    } catch (err) {
      hook.message("Reading the satellites failed: " + err.message, "error");
    }
  }

  async function keep(text) {
    try {
      render(await hook.post(api, { tle: text }));
      hook.message("Kept.", "info");
      $("tle-text").value = "";
    } catch (err) {
      hook.message("Keeping the TLE failed: " + err.message, "error");
    }
  }

  function start() {
    $("form-tle").addEventListener("submit", (event) => {
      event.preventDefault();
      keep($("tle-text").value);
    });
    $("tle-file").addEventListener("change", async () => {
      const file = $("tle-file").files[0];
      if (file) keep(await file.text());
      $("tle-file").value = "";
    });
    load();
    setInterval(async () => {
      if (!following) return;
      try {
        const view = await hook.request(api + "?hours=1");
        showProgress(view.progress, view.following);
      } catch (err) {
        /* the status line says when the server is unreachable */
      }
    }, 2000);
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
