// Gantry console: the readout from the board's pushed status (Server-Sent Events), commands as
// JSON POSTs to the same serve process. No libraries; nothing fetched from elsewhere.
"use strict";
const $ = (id) => document.getElementById(id);
// The printed URL's token has become this page's cookie (serve's lock): keep it out of the
// address bar, the history and screenshots.
if (new URLSearchParams(location.search).has("token")) window.history.replaceState(null, "", location.pathname);
let status = null, setup = null, path = null, job = null, programName = null, errorLines = [];
// The revision of the program shown (serve's, loaded.rs), and the frame the views are drawn in.
let programRev = null, frame = "work";
// This page is opening a program (its own upload or library choice): not "another client's".
let opening = false;

function log(text) {
  const li = document.createElement("li");
  li.textContent = new Date().toLocaleTimeString() + "  " + text;
  $("log").prepend(li);
  while ($("log").children.length > 200) $("log").lastChild.remove();
}

async function post(what, body) {
  try {
    const r = await fetch("/api/" + what, {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body || {}),
    });
    if (r.status === 401) { offline("the console's token is not valid (serve restarted?): open the URL gantry serve printed"); return { ok: false, error: "401" }; }
    const v = await r.json();
    if (!v.ok) refused(what + ": " + v.error);
    return v;
  } catch (e) { log(what + ": " + e); return { ok: false, error: String(e) }; }
}

// ---- readout ----
const fmt = (v, digits = 3) => (v < 0 ? "" : "+") + v.toFixed(digits);
function buildAxes(letters) {
  const tb = document.querySelector("#axes tbody");
  if (tb.children.length === letters.length) return;
  tb.textContent = "";
  for (const l of letters) {
    const tr = document.createElement("tr");
    tr.innerHTML = `<th>${l}</th><td class="pos" id="work-${l}">-</td><td class="mpos" id="mach-${l}">-</td>` +
      `<td><button id="zero-${l}">Zero ${l}</button></td><td><button id="home-${l}">Home ${l}</button></td>`;
    tb.append(tr);
    $("zero-" + l).onclick = () => post("zero", { axis: l }).then((v) => v.ok && log(v.message));
    $("home-" + l).onclick = () => post("home", { axis: l });
  }
}

// A refusal: in the log, and in the top bar until the next one or 15 s.
let refusedTimer = null;
function refused(text) {
  log(text);
  $("refusal").textContent = text;
  $("refusal").hidden = false;
  clearTimeout(refusedTimer);
  refusedTimer = setTimeout(() => { $("refusal").hidden = true; }, 15000);
}

// ---- live or not: with no event stream (or no status in 2.5 s) every control is disabled ----
let live = false, lastStatus = 0;
function offline(why) {
  live = false;
  document.body.classList.add("offline");
  $("offline").hidden = false;
  $("offline-text").textContent = why;
  // Not the board's last state in green: the page does not know it.
  $("state").textContent = "no link";
  $("state").className = "state Offline";
  $("words").textContent = "";
  for (const el of document.querySelectorAll("button, input, select, textarea")) el.disabled = true;
}
function online() {
  if (live) return;
  live = true;
  document.body.classList.remove("offline");
  $("offline").hidden = true;
  for (const el of document.querySelectorAll("button, input, select, textarea")) el.disabled = false;
  gateRun();
}

// A program whose check failed does not run (the server refuses it too): Run stays disabled
// until the program is fixed and opened again.
let programErrors = 0;
function gateRun() {
  for (const id of ["run", "run-from"]) {
    $(id).disabled = !live || programErrors > 0;
    $(id).title = programErrors ? "the program has errors (see the check): fix it and open it again" : "";
  }
}
setInterval(() => {
  if (live && Date.now() - lastStatus > 2500) offline("no status from gantry serve for " + Math.round((Date.now() - lastStatus) / 1000) + " s: the readout is stale");
}, 500);

function onStatus(s) {
  status = s;
  lastStatus = Date.now();
  online();
  buildAxes(s.letters);
  // Work position in the executing move's units: mm to the µm, inches to 0.0001 in.
  const inch = s.units === "in", digits = inch ? 4 : 3;
  $("units").textContent = s.units;
  $("wcs").textContent = s.work_system;
  for (const u of document.querySelectorAll(".u")) u.textContent = s.units;
  $("state").textContent = s.state;
  $("state").className = "state " + s.state;
  $("words").textContent = s.words !== s.state ? s.words : "";
  $("alarm").hidden = !s.alarm;
  $("alarm").textContent = s.alarm ? s.alarm + " — clear the cause, then Unlock (or Home)" : "";
  s.letters.forEach((l, i) => {
    $("work-" + l).textContent = fmt(s.work_units[i], digits);
    $("mach-" + l).textContent = fmt(s.machine[i]);
  });
  $("feed").textContent = s.feed_units.toFixed(inch ? 2 : 1);
  $("pfeed").textContent = s.programmed_feed_units.toFixed(inch ? 2 : 1);
  $("fo").textContent = s.feed_override;
  $("ro").textContent = s.rapid_override;
  $("so").textContent = s.spindle_override;
  $("rpm").textContent = s.rpm;
  // Laser mode: the beam's power now instead of the spindle speed commanded.
  const laser = s.laser_power !== null && s.laser_power !== undefined;
  $("spindle-label").textContent = laser ? "laser" : "spindle";
  $("rpm-actual").textContent = laser ? s.laser_power.toFixed(1) : s.rpm_actual;
  $("spindle-unit").textContent = laser ? "% power now (laser mode)" : "rpm commanded";
  for (const tr of document.querySelectorAll("#offsets tbody tr")) tr.classList.toggle("active", +tr.dataset.p === s.work_system_index + 1);
  $("outputs").textContent = s.outputs;
  $("line").textContent = s.line;
  $("tool").textContent = s.tool ? "T" + s.tool : "none";
  $("homed").textContent = s.homed || "none";
  $("inputs").textContent = s.inputs.length ? s.inputs.join(", ") : "none active";
  $("buffers").textContent = `${s.planner} planner blocks, ${s.queue} lines queued`;
  $("link").textContent = "live " + new Date().toLocaleTimeString();
  if (s.tool_change != null && !(job && job.stop)) showStop("tool change: put tool " + s.tool_change + " in the spindle, then press Continue");
  else if (!(job && job.stop)) showStop(null);
  draw();
}

function showStop(text) {
  $("stop").hidden = !text;
  $("stop-text").textContent = text || "";
}

// ---- events ----
let es = null;
function connect() {
  es = new EventSource("/events");
  es.addEventListener("status", (e) => onStatus(JSON.parse(e.data)));
  es.addEventListener("setup", (e) => {
    setup = JSON.parse(e.data);
    if (document.activeElement !== $("setup-toml") && !$("setup-toml").dataset.edited) $("setup-toml").value = setup.toml;
    showOffsets(setup.offsets);
    draw(true);
  });
  es.addEventListener("job", (e) => onJob(JSON.parse(e.data)));
  es.addEventListener("program", (e) => {
    const p = JSON.parse(e.data);
    if (p.rev === programRev) return;
    if (!opening && programName !== null && p.name !== programName) log("program " + p.name + " opened by another client");
    // The listing and path are serve's: read them whenever its revision changes.
    fetchProgram();
  });
  es.addEventListener("notice", (e) => log(JSON.parse(e.data).text));
  es.addEventListener("library", (e) => showLibrary(JSON.parse(e.data).programs));
  es.addEventListener("macros", (e) => showMacros(JSON.parse(e.data).macros));
  es.addEventListener("probe", (e) => {
    const p = JSON.parse(e.data);
    $("probe-result").textContent = p.text;
    $("probe-result").className = p.ok ? "" : "bad";
  });
  es.onerror = async () => {
    offline("connection to gantry serve lost: retrying… (the job, if any, runs on in serve)");
    // The stream gives no status code: ask once whether it is the token (serve restarted).
    try {
      const r = await fetch("/api/loaded", { method: "POST", headers: { "Content-Type": "application/json" }, body: "{}" });
      if (r.status === 401) offline("gantry serve has a new token (it restarted): open the URL it printed");
    } catch (_) { /* serve is down: the stream retries */ }
    if (es.readyState === EventSource.CLOSED) setTimeout(connect, 2000);
  };
}

async function fetchProgram() {
  const v = await post("loaded", {});
  if (v.ok) showProgram(v);
}

function showProgram(v) {
  programRev = v.rev;
  programName = v.name;
  $("prog-name").textContent = `${v.name}: ${v.lines} lines` + (v.seconds != null ? `, planned time ${hms(v.seconds)}` : "");
  $("check").textContent = v.check;
  $("check").className = v.errors ? "bad" : "";
  errorLines = v.error_lines;
  programErrors = v.errors || 0;
  gateRun();
  listing(v.source, v.error_lines);
  path = v.path;
  if (job) { markLine(job.line); offerResume(job); }
  draw(true);
}

function hms(s) {
  s = Math.max(0, Math.round(s));
  return `${Math.floor(s / 3600)}:${String(Math.floor(s / 60) % 60).padStart(2, "0")}:${String(s % 60).padStart(2, "0")}`;
}

function onJob(j) {
  job = j;
  const pct = j.total ? Math.min(100, (100 * j.line) / j.total) : 0;
  $("progress-bar").style.width = (j.running ? pct : j.completed ? 100 : pct) + "%";
  if (j.running) {
    $("job").textContent = `${j.name}: line ${j.line} / ${j.total}, ${hms(j.elapsed_s)} elapsed` +
      (j.left_s != null ? `, ETA ${hms(j.left_s)} (planned ${hms(j.planned_s)})` : ", ETA -") +
      (j.from_line ? `, from line ${j.from_line}` : "");
    $("job-errors").textContent = "";
  } else {
    $("job").textContent = `${j.name}: ` + (j.completed ? "done" : j.aborted ? "aborted" : "ended") +
      (j.elapsed_s != null ? ` after ${hms(j.elapsed_s)}` : "");
    $("job-errors").textContent = (j.errors || []).concat(j.alarms || []).join("\n");
  }
  showStop(j.running && j.stop ? j.stop : null);
  markLine(j.line);
  offerResume(j);
  draw(true);
}

// After a job that stopped short (abort, alarm on the path, an error), serve's resume line: in
// the from-line field, with a button that runs from it.
function offerResume(j) {
  const n = !j.running && j.name === programName ? j.resume_line : null;
  $("resume-offer").hidden = !n;
  if (!n) return;
  $("resume-line").textContent = n;
  if (document.activeElement !== $("from")) $("from").value = n;
}

// ---- controls ----
$("hold").onclick = () => post("hold");
$("resume").onclick = () => post("resume");
$("abort").onclick = () => post("abort");
$("continue").onclick = () => post("continue");
$("home-all").onclick = () => post("home", {});
$("unlock").onclick = () => post("unlock");
$("fo-set").onclick = () => post("override", { feed: +$("fo-in").value });
$("ro-set").onclick = () => post("override", { rapid: +$("ro-in").value });
$("so-set").onclick = () => post("override", { spindle: +$("so-in").value });
$("ovr-reset").onclick = () => {
  $("fo-in").value = 100; $("ro-in").value = 100; $("so-in").value = 100;
  post("override", { feed: 100, rapid: 100, spindle: 100 });
};
// The ± buttons of the feed (data-fo) and spindle (data-so) overrides: 10-200 % from the board's.
const overrideSteps = (attr, which, input) => {
  for (const b of document.querySelectorAll(`[data-${attr}]`)) {
    b.onclick = () => {
      const now = status ? status[`${which}_override`] : 100;
      const v = Math.max(10, Math.min(200, now + +b.dataset[attr]));
      $(input).value = v;
      post("override", { [which]: v });
    };
  }
};
overrideSteps("so", "spindle", "so-in");
overrideSteps("fo", "feed", "fo-in");
// Work offsets G54..G59.3 as the board keeps them: one row each, editable, set with G10 L2.
function showOffsets(offsets) {
  const tb = document.querySelector("#offsets tbody");
  if (tb.children.length !== offsets.length) {
    tb.textContent = "";
    offsets.forEach((o, i) => {
      const tr = document.createElement("tr");
      tr.dataset.p = i + 1;
      tr.innerHTML = `<th>${o.name}</th>` + ["X", "Y", "Z"].map((l) => `<td><input id="off-${i + 1}-${l}" class="off" inputmode="decimal"></td>`).join("") +
        `<td><button id="off-set-${i + 1}">Set</button></td>`;
      tb.append(tr);
      $("off-set-" + (i + 1)).onclick = () => {
        const body = { p: i + 1 };
        for (const l of ["X", "Y", "Z"]) if ($(`off-${i + 1}-${l}`).value !== "") body[l] = +$(`off-${i + 1}-${l}`).value;
        post("offset", body).then((v) => v.ok && log(v.message));
      };
    });
  }
  offsets.forEach((o, i) => ["X", "Y", "Z"].forEach((l, a) => {
    const inp = $(`off-${i + 1}-${l}`);
    if (inp && document.activeElement !== inp && o.values[a] != null) inp.value = o.values[a].toFixed(3);
  }));
}
$("off-read").onclick = () => post("read_back");

// Jog: a step per press, or (continuous) from press to release. A continuous jog is the
// board's: while the button is held this page sends a keepalive every 50 ms, and the board
// stops the jog 250 ms after the last one it heard, so a page that closes, hangs or goes offline
// stops the machine (docs/controller.md "Jogging").
const step = () => +$("step").value;
const KEEPALIVE_MS = 50;
let jogging = null;
function keepAlive() {
  // Quietly: a lost keepalive is what the board's dead-man is for.
  fetch("/api/jog_alive", { method: "POST", headers: { "Content-Type": "application/json" }, body: "{}" })
    .catch(() => {});
}
function jogStart(axis, dir) {
  if (jogging) return;
  const continuous = step() === 0;
  jogging = { axis, dir, continuous, timer: continuous ? setInterval(keepAlive, KEEPALIVE_MS) : null };
  post("jog", { axis, dir, step: step(), feed: +$("jogfeed").value });
}
function jogEnd() {
  if (!jogging) return;
  const j = jogging;
  jogging = null;
  if (j.timer) clearInterval(j.timer);
  if (j.continuous) post("jog_stop");
}
for (const b of document.querySelectorAll(".jog")) {
  b.addEventListener("pointerdown", (e) => { e.preventDefault(); jogStart(b.dataset.axis, +b.dataset.dir); });
  for (const ev of ["pointerup", "pointerleave", "pointercancel"]) b.addEventListener(ev, jogEnd);
}
const KEYS = { ArrowLeft: ["X", -1], ArrowRight: ["X", 1], ArrowUp: ["Y", 1], ArrowDown: ["Y", -1], PageUp: ["Z", 1], PageDown: ["Z", -1] };
const typing = (t) => t && (t.tagName === "INPUT" || t.tagName === "TEXTAREA" || t.tagName === "SELECT");
document.addEventListener("keydown", (e) => {
  if (typing(e.target)) return;
  if (e.key === "Escape") { post("abort"); e.preventDefault(); return; }
  if (e.key === " ") { post("hold"); e.preventDefault(); return; }
  const k = KEYS[e.key];
  if (!k) return;
  e.preventDefault();
  if (!e.repeat) jogStart(k[0], k[1]);
});
document.addEventListener("keyup", (e) => { if (KEYS[e.key]) jogEnd(); });
window.addEventListener("blur", jogEnd);

// MDI with history (↑ ↓ in the field).
const history = [];
let hpos = 0;
$("mdi-form").onsubmit = (e) => {
  e.preventDefault();
  const line = $("mdi").value.trim();
  if (!line) return;
  history.push(line);
  hpos = history.length;
  const li = document.createElement("li");
  li.textContent = line;
  li.onclick = () => { $("mdi").value = line; };
  $("mdi-history").prepend(li);
  $("mdi").value = "";
  post("mdi", { line });
};
$("mdi").addEventListener("keydown", (e) => {
  if (e.key === "ArrowUp" && hpos > 0) $("mdi").value = history[--hpos];
  else if (e.key === "ArrowDown" && hpos < history.length) $("mdi").value = history[++hpos] || "";
  else return;
  e.preventDefault();
});

// ---- program ----
$("file").onchange = async () => {
  const f = $("file").files[0];
  if (!f) return;
  const text = await f.text();
  $("prog-name").textContent = "checking…";
  opening = true;
  const v = await post("program", { name: f.name, text }).finally(() => { opening = false; });
  if (v.ok) showProgram(v);
};

function listing(text, errs) {
  const box = $("listing");
  box.textContent = "";
  const lines = text.split("\n");
  const bad = new Set(errs);
  const frag = document.createDocumentFragment();
  lines.slice(0, 5000).forEach((l, i) => {
    const d = document.createElement("div");
    d.id = "L" + (i + 1);
    if (bad.has(i + 1)) d.className = "err";
    const n = document.createElement("span");
    n.className = "n";
    n.textContent = i + 1;
    d.append(n, l);
    frag.append(d);
  });
  box.append(frag);
  if (errs.length) { const d = $("L" + errs[0]); if (d) box.scrollTop = d.offsetTop - box.offsetTop - 40; }
}

let marked = null;
function markLine(n) {
  if (marked) marked.classList.remove("cur");
  marked = $("L" + n);
  if (marked) marked.classList.add("cur");
}

$("run").onclick = () => post("run", {});
$("run-from").onclick = () => post("run", { from_line: +$("from").value || 1 });
$("run-resume").onclick = () => post("run", { from_line: +$("resume-line").textContent });
$("show-pre").onclick = async () => {
  const v = await post("preamble", { from_line: +$("from").value || 1 });
  $("preamble").hidden = !v.ok;
  if (v.ok) $("preamble").textContent = "preamble sent before line " + ($("from").value || 1) + ":\n" + v.preamble.join("\n");
};

// ---- library and macros (kept by serve) ----
const cell = (tr, text) => { const td = document.createElement("td"); td.textContent = text; tr.append(td); return td; };
const button = (td, label, cls, fn) => { const b = document.createElement("button"); b.textContent = label; b.className = cls; b.onclick = fn; b.disabled = !live; td.append(b); return b; };
function showLibrary(list) {
  const tb = document.querySelector("#library tbody");
  tb.textContent = "";
  for (const p of list) {
    const tr = document.createElement("tr");
    tr.dataset.name = p.name;
    cell(tr, p.name);
    cell(tr, p.size < 10240 ? p.size + " B" : Math.round(p.size / 1024) + " KiB");
    cell(tr, new Date(p.date * 1000).toLocaleString());
    cell(tr, p.seconds != null ? hms(p.seconds) : p.errors ? p.errors + " errors" : "-");
    cell(tr, (p.tools || []).map((t) => "T" + t).join(", ") || "none");
    button(cell(tr, ""), "Open", "lib-open", async () => {
      $("prog-name").textContent = "checking…";
      opening = true;
      const v = await post("library_open", { name: p.name }).finally(() => { opening = false; });
      if (v.ok) showProgram(v);
    });
    button(cell(tr, ""), "Delete", "lib-delete", () => { if (confirm("Remove " + p.name + " from the library?")) post("library_delete", { name: p.name }); });
    tb.append(tr);
  }
}
function showMacros(list) {
  const tb = document.querySelector("#macros tbody");
  tb.textContent = "";
  for (const m of list) {
    const tr = document.createElement("tr");
    tr.dataset.name = m.name;
    cell(tr, m.name);
    const pre = document.createElement("pre");
    pre.textContent = m.text;
    cell(tr, "").append(pre);
    button(cell(tr, ""), "Run", "go macro-run", () => post("macro_run", { name: m.name }));
    button(cell(tr, ""), "Edit", "macro-edit", () => { $("macro-name").value = m.name; $("macro-text").value = m.text; });
    button(cell(tr, ""), "Delete", "macro-delete", () => { if (confirm("Delete macro " + m.name + "?")) post("macro_delete", { name: m.name }); });
    tb.append(tr);
  }
}
$("macro-form").onsubmit = async (e) => {
  e.preventDefault();
  const v = await post("macro_save", { name: $("macro-name").value, text: $("macro-text").value });
  if (v.ok) { log(v.message); $("macro-name").value = ""; $("macro-text").value = ""; }
};

// ---- probing: the plan is shown and confirmed before anything moves ----
async function probe(body) {
  const plan = await post("probe_plan", body);
  if (!plan.ok) return;
  if (!confirm(plan.plan + "\n\nStart? The machine moves.")) return;
  $("probe-result").textContent = "probing…";
  await post("probe", body);
}
$("probe-z").onclick = () => probe({ kind: "z", thickness: +$("pz-thickness").value, distance: +$("pz-distance").value,
  feed: +$("pz-feed").value, retract: +$("pz-retract").value });
const xy = () => ({ clearance: +$("pc-clearance").value, depth: +$("pc-depth").value, diameter: +$("pc-diameter").value,
  feed: +$("pc-feed").value, retract: +$("pc-retract").value });
$("probe-edge").onclick = () => probe({ kind: "edge", side: $("pe-side").value, ...xy() });
$("probe-corner").onclick = () => probe({ kind: "corner", corner: $("pc-corner").value, ...xy() });
$("probe-boss").onclick = () => probe({ kind: "boss", size: +$("pb-size").value, ...xy() });
$("probe-bore").onclick = () => probe({ kind: "bore", size: +$("pb-size").value, diameter: xy().diameter,
  feed: xy().feed, retract: xy().retract });
$("probe-tool").onclick = () => probe({ kind: "tool", setter_z: +$("pt-setter").value, distance: +$("pt-distance").value,
  feed: +$("pt-feed").value, ...($("pt-tool").value ? { tool: +$("pt-tool").value } : {}) });

// ---- setup ----
$("setup-toml").addEventListener("input", () => { $("setup-toml").dataset.edited = "1"; });
$("setup-check").onclick = async () => {
  const v = await post("setup_check", { toml: $("setup-toml").value });
  $("setup-msg").textContent = v.ok ? v.message : v.error;
};
$("setup-push").onclick = async () => {
  const v = await post("setup_push", { toml: $("setup-toml").value });
  $("setup-msg").textContent = v.ok ? v.message : v.error;
  if (v.ok) delete $("setup-toml").dataset.edited;
};
$("setup-reload").onclick = () => {
  delete $("setup-toml").dataset.edited;
  if (setup) $("setup-toml").value = setup.toml;
};

// ---- tool path: top view and isometric ----
const VIEWS = {
  top: (p) => [p[0], p[1]],
  iso: (p) => [(p[0] - p[1]) * 0.866, (p[0] + p[1]) * 0.5 + p[2]],
};
const cache = {};
// One frame for the path, the cross and the box: work coordinates of the active system (machine
// minus the board's offset, as the readout's work position), or machine coordinates.
function shift() {
  if (frame === "machine" || !status) return [0, 0, 0];
  return [0, 1, 2].map((i) => (status.machine[i] ?? 0) - (status.work[i] ?? 0));
}
$("frame").onchange = () => { frame = $("frame").value; draw(true); };
function box() {
  // The travel box (machine coordinates) in the frame drawn.
  if (!setup || !status) return null;
  const off = shift();
  const lo = [0, 1, 2].map((i) => (setup.travel_min[i] ?? 0) - off[i]);
  const hi = [0, 1, 2].map((i) => (setup.travel_max[i] ?? 0) - off[i]);
  return { lo, hi };
}
function corners(b) {
  const c = [];
  for (const x of [b.lo[0], b.hi[0]]) for (const y of [b.lo[1], b.hi[1]]) for (const z of [b.lo[2], b.hi[2]]) c.push([x, y, z]);
  return c;
}
const EDGES = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];
let lastKey = "";
function draw(force) {
  const b = box();
  const cut = job && job.name === programName ? job.line : 0;
  const off = shift();
  const key = JSON.stringify([b, cut, path ? path.length : 0, programRev, frame]);
  const stale = force || key !== lastKey;
  lastKey = key;
  for (const name of ["top", "iso"]) {
    const cv = $(name), proj = VIEWS[name];
    const ctx = cv.getContext("2d");
    if (stale || !cache[name]) cache[name] = render(cv.width, cv.height, proj, b, cut, off);
    const c = cache[name];
    ctx.clearRect(0, 0, cv.width, cv.height);
    ctx.drawImage(c.img, 0, 0);
    if (status && c.map) {
      const at = frame === "machine" ? status.machine : status.work;
      const [x, y] = c.map(proj([at[0] || 0, at[1] || 0, at[2] || 0]));
      if (name === "top") window.gantryCross = [x, y];
      ctx.strokeStyle = "#ff5252"; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.arc(x, y, 6, 0, 7); ctx.moveTo(x - 10, y); ctx.lineTo(x + 10, y); ctx.moveTo(x, y - 10); ctx.lineTo(x, y + 10); ctx.stroke();
    }
  }
}
function render(w, h, proj, b, cut, off) {
  const pt = (i) => [path[i + 2] - off[0], path[i + 3] - off[1], path[i + 4] - off[2]];
  const img = document.createElement("canvas");
  img.width = w; img.height = h;
  const ctx = img.getContext("2d");
  // Fit the program's path (the travel box only when there is none); the box is clipped.
  const pts = [];
  if (b && !(path && path.length)) for (const c of corners(b)) pts.push(proj(c));
  if (path) for (let i = 0; i < path.length; i += 5) pts.push(proj(pt(i)));
  if (!pts.length) return { img, map: null };
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (const [x, y] of pts) { x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y); }
  const pad = 0.08 * Math.max(x1 - x0, y1 - y0, 1);
  x0 -= pad; x1 += pad; y0 -= pad; y1 += pad;
  const s = Math.min((w - 20) / Math.max(x1 - x0, 1e-3), (h - 20) / Math.max(y1 - y0, 1e-3));
  const map = ([x, y]) => [10 + (x - x0) * s + ((w - 20) - (x1 - x0) * s) / 2, h - 10 - (y - y0) * s - ((h - 20) - (y1 - y0) * s) / 2];
  if (b) {
    const c = corners(b).map((p) => map(proj(p)));
    ctx.strokeStyle = "#5c6670"; ctx.setLineDash([4, 4]); ctx.beginPath();
    for (const [i, j] of EDGES) { ctx.moveTo(...c[i]); ctx.lineTo(...c[j]); }
    ctx.stroke(); ctx.setLineDash([]);
  }
  if (path) {
    // Rapids dashed grey, feeds blue, what is already cut (lines before the board's) orange.
    const style = (k, line) => (k === 0 ? "#8a949e" : line < cut ? "#ff9800" : "#4fc3f7");
    let prev = null, cur = null;
    ctx.lineWidth = 1.2;
    for (let i = 0; i < path.length; i += 5) {
      const k = path[i], line = path[i + 1];
      const p = map(proj(pt(i)));
      if (prev && k !== 2) {
        const st = style(k, line);
        if (st !== cur) { if (cur) ctx.stroke(); ctx.strokeStyle = st; ctx.setLineDash(k === 0 ? [3, 3] : []); ctx.beginPath(); ctx.moveTo(...prev); cur = st; }
        ctx.lineTo(...p);
      } else if (cur) { ctx.stroke(); cur = null; }
      if (!cur) { ctx.beginPath(); ctx.moveTo(...p); }
      prev = p;
    }
    if (cur) ctx.stroke();
    ctx.setLineDash([]);
  }
  return { img, map };
}

offline("connecting to gantry serve…");
connect();
