// The operator's page: study progress (polled), session controls (POST with
// the token), live plots (server-sent events, drawn with Debian's Chart.js).
"use strict";
const $ = (id) => document.getElementById(id);
let token = sessionStorage.getItem("hapticlab-token") || "";
window.hapticlab = { livePoints: 0, liveMessages: 0 };  // for the browser tests

function show(page) {
  document.querySelectorAll("section").forEach((s) => s.classList.toggle("on", s.id === page));
  document.querySelectorAll("nav button").forEach((b) => b.classList.toggle("on", b.dataset.page === page));
}
document.querySelectorAll("nav button").forEach((b) => b.addEventListener("click", () => show(b.dataset.page)));

async function post(url, body) {
  if (!token) {
    token = prompt("Console token (printed when `hapticlab console` started, and in its token file):") || "";
    sessionStorage.setItem("hapticlab-token", token);
  }
  const res = await fetch(url, {
    method: "POST", headers: { "Content-Type": "application/json", "X-HapticLab-Token": token },
    body: JSON.stringify(body || {}),
  });
  const j = await res.json();
  $("message").textContent = res.ok ? "" : (j.error || res.statusText);
  if (res.status === 403) { token = ""; sessionStorage.removeItem("hapticlab-token"); }
  return res.ok;
}
const control = (path, body) => post("/api/session/" + path, body);
$("stop").addEventListener("click", () => control("stop"));
$("start").addEventListener("click", () => control("start", { participant: $("participant").value, step: $("step").checked }));
$("next").addEventListener("click", () => control("next"));
$("pause").addEventListener("click", () => control("pause", { paused: true }));
$("resume").addEventListener("click", () => control("pause", { paused: false }));
$("rest").addEventListener("click", () => control("rest", { seconds: Number($("rest-s").value) }));
$("end-training").addEventListener("click", () => control("end-training"));
// The trial shown when the button is pressed (0: none shown running): one
// that ended meanwhile is not aborted, nor the next in its place (the server
// refuses, and says so).
let shownTrialId = 0;
$("abort").addEventListener("click", () => control("abort", { reason: $("reason").value, trial_id: shownTrialId }));
$("add-note").addEventListener("click", async () => { if (await control("note", { text: $("note").value })) $("note").value = ""; });

const text = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);

async function refreshStudy() {
  try {
    const j = await (await fetch("/api/study")).json();
    const select = $("participant");
    if (!select.options.length) for (const p of j.participants) {
      select.add(new Option(p.code, p.code));
      $("export-participant").add(new Option(p.code, p.code));
    }
    let html = "";
    for (const p of j.participants) {
      html += `<h3>${text(p.code)}: ${p.complete} of ${p.scheduled} complete, ${p.aborted} aborted, ${p.to_do} to do</h3><table><tr><th>#</th><th>task</th><th>setting</th><th>rep</th><th>status</th><th>reason</th></tr>`;
      for (const t of p.trials)
        html += `<tr class="${text(t.status)}"><td>${t.position}</td><td>${text(t.task)}</td><td>${text(t.setting)}</td><td>${t.repetition}</td><td>${text(t.status)}</td><td>${text(t.abort_reason || "")}</td></tr>`;
      html += "</table>";
    }
    $("study-body").innerHTML = html;
  } catch (e) { $("study-body").textContent = "cannot read the study: " + e; }
}
refreshStudy();
setInterval(refreshStudy, 2000);

function describe(s) {
  if (!s.running && !s.result) return "No session running." + (s.error ? ` Last error: ${text(s.error)}` : "");
  let h = `<b>${text(s.participant)}</b> — ${s.running ? text(s.phase || "starting") : "session ended"}`;
  if (s.trial_number) h += ` — trial ${s.trial_number} of ${s.trial_count}: ${text(s.task)}, rep ${s.repetition}, setting <b>${text(s.setting)}</b>`;
  if (s.trial_elapsed_wall_s !== undefined) h += ` — ${s.trial_elapsed_wall_s.toFixed(1)} s`;
  if (s.paused) h += s.rest_left_s !== undefined ? ` — <b>rest</b>, ${s.rest_left_s} s left` : " — <b>paused</b>";
  if (s.rest_after_trial_s !== undefined) h += ` — rest of ${s.rest_after_trial_s} s after this trial`;
  if (s.time_left_s !== undefined) h += ` — about ${Math.round(s.time_left_s / 60)} min left`;
  if (s.last_status) h += `<br>last trial: ${text(s.last_status)} ${text(s.last_abort_reason || "")}`;
  if (s.result) h += `<br>result: ${s.result.trials_complete} complete, ${s.result.trials_aborted} aborted, ${s.result.trials_left} left` + (s.result.stopped_by_operator ? " (stopped by the operator)" : "");
  if (s.loop) h += `<br>loop: ${s.loop.rate_Hz.toFixed(0)} Hz, period p99 ${s.loop.p99_period_ms.toFixed(3)} ms (max ${s.loop.max_period_ms.toFixed(3)} ms, ${s.loop.overruns} overruns), ${s.loop.dropped_samples} samples dropped; writer ${(1e3 * s.loop.writer_lag_s).toFixed(0)} ms behind`;
  if (s.error) h += `<br><span class="err">${text(s.error)}</span>`;
  return h;
}

// A live plot of one instrument (Chart.js), or null without Chart.js.
function makeChart(canvasId, title) {
  if (typeof Chart === "undefined") return null;
  return new Chart($(canvasId), {
    type: "line",
    data: { datasets: ["tip force N", "displayed force N", "insertion m", "pitch rad", "yaw rad"].map((label, i) => ({
      label, data: [], borderWidth: 1, pointRadius: 0, yAxisID: i < 2 ? "y" : "y1",
      borderColor: ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#56B4E9"][i] })) },
    options: { animation: false, parsing: false, normalized: true,
      plugins: { title: { display: true, text: title } },
      scales: { x: { type: "linear", title: { display: true, text: "loop time s" } },
                y: { position: "left", title: { display: true, text: "N" } },
                y1: { position: "right", grid: { drawOnChartArea: false } } } },
  });
}
// Appends [t, tip, displayed, insertion, pitch, yaw] points; keeps the last 10 s.
function addPoints(chart, points) {
  if (!chart || !points.length) return;
  for (const p of points) chart.data.datasets.forEach((d, i) => d.data.push({ x: p[0], y: p[i + 1] }));
  const newest = points[points.length - 1][0];
  chart.data.datasets.forEach((d) => { while (d.data.length && d.data[0].x < newest - 10) d.data.shift(); });
  chart.update("none");
}
const clearChart = (chart) => chart && chart.data.datasets.forEach((d) => (d.data = []));
const charts = [makeChart("plot0", "Left instrument"), makeChart("plot1", "Right instrument")];
if (!charts[0]) $("live-status").textContent = "Chart.js not found (apt install libjs-chart.js): numbers only.";

$("analyze").addEventListener("click", async () => { await post("/api/results/analyze", {}); refreshResults(); });
$("export").addEventListener("click", async () => {
  await post("/api/results/export", { participant: $("export-participant").value, every: Number($("export-every").value),
                                      gzip: $("export-gzip").checked });
  refreshResults();
});
let shownReport = "";
async function refreshResults() {
  const r = await (await fetch("/api/results")).json();
  $("results-state").textContent = `${r.job || ""} ${r.state}${r.message ? ": " + r.message : ""}`;
  $("downloads").innerHTML = r.files.map((f) => ` <a href="/results/${f}" download>${f}</a>`).join("");
  if (r.state === "done" && r.job === "analysis" && r.files.includes("report.html") && shownReport !== r.message) {
    shownReport = r.message;
    $("report").src = "/results/report.html?" + Date.now();
    $("report").style.display = "block";
  }
}
refreshResults();
setInterval(refreshResults, 1000);

// Follows a live stream (/events/live, /events/tuning) into two charts: they
// are cleared when `repetitionKey` of the status changes (a new trial, or a
// new repetition of the free trial); `counter` in window.hapticlab counts
// the points received; onStatus(status) runs for every message.
function followLive(url, repetitionKey, twoCharts, counter, onStatus) {
  let last = -1;
  new EventSource(url).onmessage = (ev) => {
    const j = JSON.parse(ev.data);
    if (j.status[repetitionKey] !== last) {
      last = j.status[repetitionKey];
      twoCharts.forEach(clearChart);
    }
    j.instruments.forEach((points, k) => {
      window.hapticlab[counter] += points.length;
      addPoints(twoCharts[k], points);
    });
    onStatus(j.status);
  };
}
followLive("/events/live", "trial_number", charts, "livePoints", (s) => {
  window.hapticlab.liveMessages++;
  shownTrialId = s.running && s.phase === "trial" ? s.trial_id : 0;
  $("status").innerHTML = describe(s);
  $("live-status").innerHTML = s.running ? describe(s) + `<br>points received: ${window.hapticlab.livePoints}` : "No trial running.";
});
