// The participant's screen, served from a port of its own: only what the
// participant may see: trial k of N while a trial runs, a cue (with a
// rest's countdown), the task's instructions. The stream it reads
// (/events/participant) carries nothing else.
"use strict";
const instructions = {
  dissection: "Dissect along the marked line with the right instrument; hold the tissue with the left.",
  clip: "Place the clips on the marked places of the vessel, one after the other.",
};
const cues = { go: "GO", ready: "READY", practice: "PRACTICE", rest: "REST", done: "DONE", stopped: "STOPPED" };
const source = new EventSource("/events/participant");
source.addEventListener("participant", (ev) => {
  const s = JSON.parse(ev.data);
  // The number only while a trial runs: between trials it would be the last one's.
  let line = s.trial_number ? `Trial ${s.trial_number} of ${s.trial_count}` : "Please wait";
  if (s.cue === "done") line = "All trials are done. Thank you!";
  if (s.cue === "stopped")
    line = "The session was stopped." + (s.trials_left ? ` ${s.trials_left} trial${s.trials_left === 1 ? " is" : "s are"} left for later.` : "");
  document.getElementById("trial").textContent = line;
  const cue = document.getElementById("cue");
  // A timed rest counts down (m:ss); the session goes on when it reaches 0.
  const left = s.rest_left_s;
  cue.textContent = (cues[s.cue] || String(s.cue).toUpperCase()) +
      (left !== undefined ? ` ${Math.floor(left / 60)}:${String(left % 60).padStart(2, "0")}` : "");
  cue.className = s.cue;
  document.getElementById("instructions").textContent = s.cue === "go" || s.cue === "practice" || s.cue === "ready"
    ? (instructions[s.task] || "") : "";
});
