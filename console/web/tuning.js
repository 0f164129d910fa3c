// The Tuning page: the thesis' slider window. A slider for every numeric
// field of a settings file, within the range docs/settings.md documents
// (GET /api/tuning's "reference", made from the loader's own table), and a
// switch for every block. Each change is one POST /api/tuning/set; the
// server checks it again and the page shows what the server holds.
// Uses post(), getJson(), downloadLink(), deviceAlarm(), $, text(),
// makeChart() and followLive() of console.js.
"use strict";

const tuning = { fields: [], built: false, lastLogLength: -1, shownSaved: "" };
window.hapticlab.tuningPoints = 0;  // for the browser tests

// Many ranges span decades (a mass of 1 g..10 kg, a stiffness of 0..1e5
// N/m): such sliders move on a log scale, the others linearly. The number
// box beside each takes any allowed value.
function sliderScale(f) {
  const low = f.min_exclusive ? f.max * 1e-4 : f.min;
  if (low > 0 && f.max / low >= 100) {
    return { toSlider: (v) => Math.log(Math.max(v, low) / low) / Math.log(f.max / low),
             fromSlider: (u) => low * Math.pow(f.max / low, u) };
  }
  return { toSlider: (v) => (v - f.min) / (f.max - f.min), fromSlider: (u) => f.min + u * (f.max - f.min) };
}

const valueAt = (settings, path) => path.split(".").reduce((o, k) => (o === undefined ? undefined : o[k]), settings);
const roundForDisplay = (v) => Number(v.toPrecision(4));

async function setField(field, value) {
  const ok = await post("/api/tuning/set", { field, value });
  await refreshTuning();  // the server's value: on a refusal, the control goes back
  return ok;
}

function buildSliders(reference, settings) {
  const blocks = new Map();
  for (const f of reference) {
    const dot = f.path.lastIndexOf(".");
    const block = dot < 0 ? "" : f.path.slice(0, dot);
    if (!blocks.has(block)) blocks.set(block, []);
    blocks.get(block).push(f);
  }
  let html = "";
  for (const [block, fields] of blocks) {
    const switchable = valueAt(settings, block + ".enabled") !== undefined;
    html += `<div class="block"><h4>${switchable ? `<label><input type="checkbox" data-enable="${text(block)}"> ` : ""}` +
            `${text(block || "general")}${switchable ? "</label>" : ""}</h4>`;
    for (const f of fields) {
      const name = f.path.slice(f.path.lastIndexOf(".") + 1);
      const range = `${f.min_exclusive ? ">" : "≥"} ${f.min}, ≤ ${f.max}`;
      html += `<div class="field" title="${text(f.path)}: ${range} (default ${f.default})">${text(name)}<br>` +
              `<input type="range" min="0" max="1000" data-slider="${text(f.path)}"> ` +
              `<input type="number" min="${f.min}" max="${f.max}" step="any" data-number="${text(f.path)}"></div>`;
    }
    html += "</div>";
  }
  $("tuning-sliders").innerHTML = html;
  tuning.fields = reference;
  for (const box of document.querySelectorAll("[data-enable]"))
    box.addEventListener("change", () => setField(box.dataset.enable + ".enabled", box.checked));
  for (const f of reference) {
    const scale = sliderScale(f);
    const slider = document.querySelector(`[data-slider="${f.path}"]`);
    const number = document.querySelector(`[data-number="${f.path}"]`);
    slider.addEventListener("input", () => { number.value = roundForDisplay(scale.fromSlider(slider.value / 1000)); });
    slider.addEventListener("change", () => {
      // The slider's ends are the range's ends; an exclusive lower end is never sent.
      let v = scale.fromSlider(slider.value / 1000);
      if (f.min_exclusive && v <= f.min) v = sliderScale(f).fromSlider(0.001);
      setField(f.path, Math.min(f.max, roundForDisplay(v)));
    });
    // An emptied box is not a 0: nothing is sent until a number is typed.
    number.addEventListener("change", () => { if (number.value.trim() !== "") setField(f.path, Number(number.value)); });
  }
}

function showSettings(settings) {
  for (const box of document.querySelectorAll("[data-enable]"))
    box.checked = Boolean(valueAt(settings, box.dataset.enable + ".enabled"));
  for (const f of tuning.fields) {
    const v = valueAt(settings, f.path);
    const slider = document.querySelector(`[data-slider="${f.path}"]`);
    const number = document.querySelector(`[data-number="${f.path}"]`);
    if (document.activeElement !== number) number.value = roundForDisplay(v);
    if (document.activeElement !== slider) slider.value = Math.round(1000 * sliderScale(f).toSlider(v));
  }
}

async function refreshTuning() {
  let t;
  try { t = await getJson("/api/tuning"); } catch (e) { return; }
  if (!tuning.built) {
    tuning.built = true;
    for (const task of t.tasks) $("tuning-task").add(new Option(task, task));
    for (const name of t.study_settings) $("tuning-from").add(new Option(name, name));
    // Start from the undegraded device when the study has it (the usual control).
    if (t.study_settings.includes("High Fidelity")) $("tuning-from").value = "High Fidelity";
    buildSliders(t.reference, t.settings);
  }
  showSettings(t.settings);
  let state = t.running ? `free trial ${t.free_trial} of ${text(t.task)} (from ${text(t.from)}) running` : "no free trial running";
  if (t.loop) state += ` — loop ${t.loop.rate_Hz.toFixed(0)} Hz, period p99 ${t.loop.p99_period_ms.toFixed(3)} ms`;
  $("tuning-state").innerHTML = state + (t.error ? ` <span class="err">${text(t.error)}</span>` : "");
  deviceAlarm(t);
  if (JSON.stringify(t.saved) !== tuning.shownSaved) {
    tuning.shownSaved = JSON.stringify(t.saved);
    $("tuning-saved").replaceChildren(...t.saved.flatMap((f) => [" ", downloadLink("/tuning/" + f, f)]));
  }
  if (t.log.length !== tuning.lastLogLength) {
    tuning.lastLogLength = t.log.length;
    $("tuning-log").innerHTML = "<tr><th>UTC</th><th>free trial</th><th>loop time s</th><th>field</th><th>from</th><th>to</th></tr>" +
      t.log.slice().reverse().map((e) => `<tr><td>${text(e.utc)}</td><td>${e.free_trial}</td><td>${e.loop_t_s.toFixed(3)}</td>` +
        `<td>${text(e.field)}</td><td>${text(e.from)}</td><td>${text(e.to)}</td></tr>`).join("");
  }
}

$("tuning-start").addEventListener("click", async () => {
  await post("/api/tuning/start", { task: $("tuning-task").value, from: $("tuning-from").value });
  refreshTuning();
});
$("tuning-stop").addEventListener("click", async () => { await post("/api/tuning/stop", {}); refreshTuning(); });
$("tuning-save").addEventListener("click", async () => { await post("/api/tuning/save", { name: $("tuning-name").value }); refreshTuning(); });
$("tuning-log-link").append(downloadLink("/tuning/tuning-log.csv", "tuning-log.csv"));
refreshTuning();
setInterval(refreshTuning, 1000);

// The "tuning" events of the page's one stream (console.js).
followLive("tuning", "free_trial", [makeChart("tplot0", "Left instrument"), makeChart("tplot1", "Right instrument")],
           "tuningPoints", () => {});
