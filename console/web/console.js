// The operator's page: study progress (polled), session controls (POST with
// the token), STOP (always visible, and loud when it is not answered), live
// plots (one server-sent event stream for the whole page, drawn with
// Debian's Chart.js).
"use strict";
const $ = (id) => document.getElementById(id);
window.hapticlab = { livePoints: 0, liveMessages: 0, stopAnswers: 0 };  // for the browser tests

// --- the token: the console prints this page's address with it in the
// fragment (#token=...), which the browser never sends to a server. The
// page keeps it in this tab's sessionStorage (it survives a reload, and
// goes with the tab) and takes it out of the address bar, so it is not
// shown, bookmarked or shared with the address. Not localStorage: a tab
// the participant opens by typing the bare address must not find it.
// Every read that names a setting or a participant needs it too.
const TOKEN_KEY = "hapticlab-token";
(function keepTokenFromAddress() {
  const m = location.hash.match(/(?:^#|&)token=([^&]*)/);
  if (!m) return;
  sessionStorage.setItem(TOKEN_KEY, decodeURIComponent(m[1]));
  history.replaceState(null, "", location.pathname + location.search);
})();
const token = () => sessionStorage.getItem(TOKEN_KEY) || "";
const NO_TOKEN = "this page has no valid token: open the address the console printed (it ends in #token=…)";
if (!token()) $("message").textContent = NO_TOKEN;

// A read with the token; throws (with NO_TOKEN on a 403) unless answered 200.
async function getJson(url) {
  const res = await fetch(url, { headers: { "X-HapticLab-Token": token() }, signal: AbortSignal.timeout(10000) });
  if (res.status === 403) { $("message").textContent = NO_TOKEN; throw new Error(NO_TOKEN); }
  if (!res.ok) throw new Error(`${url}: HTTP ${res.status}`);
  return res.json();
}
// An address for a GET the browser itself opens (the stream, a frame, a
// download): with a one-time ticket, never the token (a ticket left in the
// downloads list or a frame's address is spent). null without a token.
async function ticketUrl(path) {
  try {
    const res = await fetch("/api/ticket", {
      method: "POST", headers: { "Content-Type": "application/json", "X-HapticLab-Token": token() },
      body: JSON.stringify({ path }), signal: AbortSignal.timeout(10000),
    });
    if (res.status === 403) { $("message").textContent = NO_TOKEN; return null; }
    if (!res.ok) return null;
    return encodeURI(path) + "?ticket=" + (await res.json()).ticket;
  } catch (e) { return null; }
}
// A download link: the click asks for a ticket, then opens the file with it.
function downloadLink(path, label) {
  const a = document.createElement("a");
  a.href = "#";
  a.textContent = label;
  a.addEventListener("click", async (ev) => {
    ev.preventDefault();
    const url = await ticketUrl(path);
    if (!url) return;
    const go = document.createElement("a");
    go.href = url;
    go.download = "";
    go.click();
  });
  return a;
}

function show(page) {
  document.querySelectorAll("section").forEach((s) => s.classList.toggle("on", s.id === page));
  document.querySelectorAll("nav button").forEach((b) => b.classList.toggle("on", b.dataset.page === page));
}
document.querySelectorAll("nav button").forEach((b) => b.addEventListener("click", () => show(b.dataset.page)));

// A control: true when the console did it. A refusal is shown in #message,
// with what the console said (it names the field and the rule).
async function post(url, body) {
  let res, j = {};
  try {
    res = await fetch(url, {
      method: "POST", headers: { "Content-Type": "application/json", "X-HapticLab-Token": token() },
      body: JSON.stringify(body || {}), signal: AbortSignal.timeout(10000),
    });
    j = await res.json().catch(() => ({}));
  } catch (e) {
    $("message").textContent = `${url}: no answer from the console (${e.message})`;
    return false;
  }
  $("message").textContent = res.ok ? "" : (res.status === 403 ? NO_TOKEN : (j.error || res.statusText));
  return res.ok;
}

// --- STOP. Its answer is awaited on its own: after 1 s without one the
// page says so, loudly, and a refusal or an error is shown the same way; a
// STOP that did not reach the console must not look like one that did.
let stopSeq = 0;
function stopState(kind, text) {
  $("stop-state").className = kind;
  $("stop-state").textContent = text;
}
function stopAlarm(text) {
  $("stop-alarm").textContent = text;
  $("stop-alarm").classList.toggle("on", Boolean(text));
}
async function sendStop() {
  const seq = ++stopSeq;
  const sent = performance.now();
  stopState("pending", "STOP sent…");
  stopAlarm("");
  const unanswered = setTimeout(() => {
    if (seq !== stopSeq) return;
    stopState("pending", "STOP NOT ANSWERED");
    stopAlarm("STOP NOT ANSWERED after 1 s: the session may still be running. Press STOP again; if it stays " +
              "unanswered, stop the console (Ctrl-C in its terminal) or switch the device off.");
  }, 1000);
  let res, j = {};
  try {
    res = await fetch("/api/session/stop", { method: "POST", headers: { "X-HapticLab-Token": token() },
                                               signal: AbortSignal.timeout(15000) });
    j = await res.json().catch(() => ({}));
  } catch (e) {
    res = null;
    j = { error: e.message };
  }
  clearTimeout(unanswered);
  if (seq !== stopSeq) return;
  window.hapticlab.stopAnswers++;
  const s = ((performance.now() - sent) / 1000).toFixed(1);
  if (!res || !res.ok) {
    const why = !res ? `no answer from the console (${j.error})` : res.status === 403 ? NO_TOKEN : (j.error || res.statusText);
    stopState("", "");
    stopAlarm(`STOP FAILED${res ? ` (HTTP ${res.status})` : ""}: ${why}. The session may still be running.`);
    return;
  }
  stopState("ok", `STOPPED (${j.stopped}; answered in ${s} s${j.record_pending ? "; its record is being stored" : ""})`);
  // A record still pending is said beside STOP (the status says when it is
  // stored); one that failed is loud.
  stopAlarm(j.recorded === false && !j.record_pending ? j.record_error : "");
}
$("stop").addEventListener("click", sendStop);

const control = (path, body) => post("/api/session/" + path, body);
$("start").addEventListener("click", () => control("start", { participant: $("participant").value, step: $("step").checked }));
$("next").addEventListener("click", () => control("next"));
$("pause").addEventListener("click", () => control("pause", { paused: true }));
$("resume").addEventListener("click", () => control("pause", { paused: false }));
$("rest").addEventListener("click", () => control("rest", { seconds: Number($("rest-s").value) }));
$("end-training").addEventListener("click", () => control("end-training"));
// The trial shown when the button is pressed (0: none shown running): one
// that ended meanwhile is not aborted, nor the next in its place (the server
// refuses, and says so). Once aborted, the reason is cleared, so the next
// click cannot abort another trial with it.
let shownTrialId = 0;
$("abort").addEventListener("click", async () => {
  if (await control("abort", { reason: $("reason").value, trial_id: shownTrialId })) $("reason").value = "";
});
$("add-note").addEventListener("click", async () => { if (await control("note", { text: $("note").value })) $("note").value = ""; });

const text = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);

async function refreshStudy() {
  try {
    const j = await getJson("/api/study");
    const select = $("participant");
    if (!select.options.length) for (const p of j.participants) {
      select.add(new Option(p.code, p.code));
      $("export-participant").add(new Option(p.code, p.code));
    }
    let html = "";
    for (const p of j.participants) {
      html += `<h3>${text(p.code)}: ${p.complete} of ${p.scheduled} complete, ${p.aborted} aborted, ${p.to_do} to do</h3>`;
      // A between-group design: the participant's group, sittings and the next one's phase and due date.
      if (p.group !== undefined)
        html += `<p class="sitting">group ${text(p.group)}; sittings ${p.sittings_done} of ${p.sittings} done; next: ${text(p.next_phase)}${p.next_phase === "done" ? "" : " " + p.next_session}, due ${text(p.next_due_utc)}</p>`;
      html += `<table><tr><th>#</th><th>task</th><th>setting</th><th>rep</th><th>status</th><th>reason</th></tr>`;
      for (const t of p.trials)
        html += `<tr class="${text(t.status)}"><td>${t.position}</td><td>${text(t.task)}</td><td>${text(t.setting)}</td><td>${t.repetition}</td><td>${text(t.status)}</td><td>${text(t.abort_reason || "")}</td></tr>`;
      html += "</table>";
    }
    $("study-body").innerHTML = html;
  } catch (e) { $("study-body").textContent = "cannot read the study: " + e; }
}
refreshStudy();
setInterval(refreshStudy, 2000);

// The participant screen is served from a port of its own (another origin).
getJson("/api/status").then((s) => {
  const url = `${location.protocol}//${location.hostname}:${s.participant_port}/participant`;
  $("participant-link").href = url;
  $("participant-link").textContent = url;
}).catch(() => {});

function describe(s) {
  if (!s.running && !s.result) return "No session running." + (s.error ? ` Last error: ${text(s.error)}` : "");
  let h = `<b>${text(s.participant)}</b> — ${s.running ? text(s.phase || "starting") : "session ended"}`;
  if (s.trial_number) h += ` — trial ${s.trial_number} of ${s.trial_count}: ${text(s.task)}, rep ${s.repetition}, setting <b>${text(s.setting)}</b>`;
  if (s.trial_elapsed_wall_s !== undefined) h += ` — ${s.trial_elapsed_wall_s.toFixed(1)} s`;
  if (s.paused) h += s.rest_left_s !== undefined ? ` — <b>rest</b>, ${s.rest_left_s} s left` : " — <b>paused</b>";
  if (s.rest_after_trial_s !== undefined) h += ` — rest of ${s.rest_after_trial_s} s after this trial`;
  if (s.waiting_for_next) h += ` — <span class="ask">waiting for you: press “Next trial” to start the next trial</span>`;
  if (s.running && s.phase === "training") h += " — press “End training” when the participant is ready";
  if (s.time_left_s !== undefined) h += ` — about ${Math.round(s.time_left_s / 60)} min left`;
  if (s.last_fault) h += `<br><span class="fault">FAULT in trial ${s.last_trial_number} (id ${s.last_trial_id}): ${text(s.last_fault)}</span> — aborted, re-queued`;
  else if (s.last_status) h += `<br>last trial: ${text(s.last_status)} ${text(s.last_abort_reason || "")}`;
  if (s.result) h += `<br>result: ${s.result.trials_complete} complete, ${s.result.trials_aborted} aborted, ${s.result.trials_left} left` + (s.result.stopped_by_operator ? " (stopped by the operator)" : "");
  if (s.result && s.result.warnings)
    for (const w of s.result.warnings) h += `<br><span class="ask">warning: ${text(w)}</span>`;
  if (s.loop) h += `<br>loop: ${s.loop.rate_Hz.toFixed(0)} Hz, period p99 ${s.loop.p99_period_ms.toFixed(3)} ms (max ${s.loop.max_period_ms.toFixed(3)} ms, ${s.loop.overruns} overruns), ${s.loop.dropped_samples} samples dropped; writer ${(1e3 * s.loop.writer_lag_s).toFixed(0)} ms behind`;
  if (s.error) h += `<br><span class="err">${text(s.error)}</span>`;
  if (s.last_stop && s.last_stop.recorded !== "stored")
    h += `<br><span class="${s.last_stop.recorded === "failed" ? "fault" : "ask"}">STOP's record: ${text(s.last_stop.recorded)}` +
         `${s.last_stop.record_error ? " — " + text(s.last_stop.record_error) : ""}</span>`;
  return h;
}

// The device's alert (a call that has not returned for the watchdog's
// time) and a hang (the console must be restarted): a banner, at once.
function deviceAlarm(s) {
  const said = s.device_hung ? `DEVICE HUNG: ${s.device_hung}. No session or free trial can use it: stop the console ` +
                               "(Ctrl-C), restart the device, then start the console again."
             : s.device_alert ? `DEVICE ALERT (${s.device_alert_utc}): ${s.device_alert}` : "";
  if ($("device-alarm").textContent !== said) $("device-alarm").textContent = said;
  $("device-alarm").classList.toggle("on", Boolean(said));
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
// Appends [t, tip, displayed, insertion, pitch, yaw] points newer than the
// chart's newest (a page that joins gets the window so far, then the
// stream's next points, which may repeat a few); keeps the last 10 s.
function addPoints(chart, points) {
  if (!chart || !points.length) return;
  const sets = chart.data.datasets;
  const newestShown = sets[0].data.length ? sets[0].data[sets[0].data.length - 1].x : -Infinity;
  let added = 0;
  for (const p of points) {
    if (p[0] <= newestShown) continue;
    sets.forEach((d, i) => d.data.push({ x: p[0], y: p[i + 1] }));
    ++added;
  }
  if (!added) return;
  const newest = points[points.length - 1][0];
  sets.forEach((d) => { while (d.data.length && d.data[0].x < newest - 10) d.data.shift(); });
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
let shownFiles = "";
async function refreshResults() {
  let r;
  try { r = await getJson("/api/results"); } catch (e) { return; }
  $("results-state").textContent = `${r.job || ""} ${r.state}${r.message ? ": " + r.message : ""}${r.stale ? " — " + r.stale : ""}`;
  if (JSON.stringify(r.files) !== shownFiles) {
    shownFiles = JSON.stringify(r.files);
    $("downloads").replaceChildren(...r.files.flatMap((f) => [" ", downloadLink("/results/" + f, f)]));
  }
  const current = r.files.includes("report.html");
  if (!current && shownReport) { shownReport = ""; $("report").classList.remove("on"); $("report").src = "about:blank"; }
  if ((r.state === "done" || r.state === "incomplete") && r.job === "analysis" && current && shownReport !== r.message) {
    const url = await ticketUrl("/results/report.html");
    if (!url) return;
    shownReport = r.message;
    $("report").src = url;
    $("report").classList.add("on");
  }
}
refreshResults();
setInterval(refreshResults, 1000);

// The page's one event stream: "live" (the session) and "tuning" (a free
// trial). A browser opens at most six connections to a host, so each tab
// holds one stream, and its STOP always has a connection left. Opened with
// a one-time ticket (EventSource sends no header): when it is lost, the
// browser would retry with the spent one, so the page opens a new stream
// with a new ticket instead.
let stream = null;
const streamListeners = [];
async function openStream() {
  const url = await ticketUrl("/events/operator");
  if (!url) {
    $("live-status").textContent = "No live stream: " + NO_TOKEN;
    setTimeout(openStream, 3000);
    return;
  }
  const s = new EventSource(url);
  stream = s;
  for (const [name, fn] of streamListeners) s.addEventListener(name, fn);
  s.onerror = () => {
    s.close();
    $("live-status").textContent = "The live stream was lost or refused (the console serves a limited number; " +
                                   "close other console tabs); reconnecting…";
    setTimeout(openStream, 1000);
  };
}
function onStream(name, fn) {
  streamListeners.push([name, fn]);
  if (stream) stream.addEventListener(name, fn);
}
// Follows one event of the stream into two charts: they are cleared when
// `repetitionKey` of the status changes (a new trial, or a new repetition
// of the free trial); `counter` in window.hapticlab counts the points
// received; onStatus(status) runs for every message.
function followLive(eventName, repetitionKey, twoCharts, counter, onStatus) {
  let last = -1;
  onStream(eventName, (ev) => {
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
  });
}
followLive("live", "trial_number", charts, "livePoints", (s) => {
  window.hapticlab.liveMessages++;
  shownTrialId = s.running && s.phase === "trial" ? s.trial_id : 0;
  $("status").innerHTML = describe(s);
  $("live-status").innerHTML = s.running ? describe(s) + `<br>points received: ${window.hapticlab.livePoints}` : "No trial running.";
  deviceAlarm(s);
});
openStream();
