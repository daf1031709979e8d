/* alpaca-zwo: night mode and the dimmer, applied before the first paint.
 *
 * Loaded as a blocking script in <head> (the page's Content-Security-Policy allows no inline script), so
 * the stored choice is on <html> before the body is drawn: a page opened at the telescope in the dark
 * never flashes its day colours. app.js binds the Night mode button and the Brightness slider to the same keys.
 */
"use strict";

(function () {
  const root = document.documentElement;
  let night = null;
  let dim = null;
  try {
    night = localStorage.getItem("alpaca-zwo-night");
    dim = localStorage.getItem("alpaca-zwo-dim");
  } catch (_) { /* storage disabled: day mode, full brightness */ }
  if (night === "1") root.classList.add("night");
  const percent = Number(dim);
  // A filter on the root element dims everything, STOP included, and keeps position: fixed working.
  if (percent >= 20 && percent < 100) {
    root.style.setProperty("--dim", String(percent / 100));
    root.classList.add("dimmed");
  }
})();
