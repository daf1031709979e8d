/* alpaca-zwo owner's survey (issue 39 item 5, docs/survey.md): one button in Diagnostics.
 *
 * Built on app.js's hook (window.alpacaZwo: base, post, message). The server refuses in words while the
 * mount moves and does all the work; this file asks, shows the verdict and offers the report file.
 */
"use strict";

(function () {
  const hook = window.alpacaZwo;
  if (!hook) return;
  const $ = (id) => document.getElementById(id);
  const STATE_WORDS = { settled: "settled", narrowed: "narrowed", open: "open", unexpected: "unexpected" };

  function showVerdict(data) {
    const list = $("survey-verdict");
    list.replaceChildren();
    for (const v of data.verdicts) {
      const item = document.createElement("li");
      item.dataset.switch = v.switch;
      item.dataset.state = STATE_WORDS[v.state] || v.state;
      item.textContent = v.line;
      list.appendChild(item);
    }
    const stopped = data.stopped ? " It stopped early: " + data.stopped : "";
    $("survey-status").textContent = "Surveyed " + data.mount + ": " + data.exchanges + " questions asked." + stopped;
    const link = $("survey-download");
    link.href = hook.base + "/survey.txt";
    link.classList.remove("hidden");
  }

  async function run() {
    const button = $("survey-run");
    button.disabled = true;
    $("survey-status").textContent = "Surveying the mount\u2026";
    try {
      showVerdict(await hook.post(hook.base + "/survey"));
    } catch (err) {
      $("survey-status").textContent = ""; // the refusal beside the button says why, once
      hook.message("The survey did not run: " + err.message, "error", button);
    } finally {
      button.disabled = false;
    }
  }

  function start() {
    $("survey-run").addEventListener("click", run);
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
