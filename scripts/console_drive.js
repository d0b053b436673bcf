// Drives gantry serve's console page in Debian's chromium through playwright-core (its own
// browser builds are never downloaded: executablePath is the system's). Run by
// scripts/console-test.sh, which starts `gantry emulate --pty` and `gantry serve --http`.
// Env: URL, GANTRY (the binary), PORT (the pty), BAD and JOB (program files), SHOT (screenshot).
"use strict";
const { chromium } = require("playwright-core");
const { execFileSync, spawn, spawnSync } = require("child_process");
const fs = require("fs");
const path = require("path");

const { URL, GANTRY, PORT, BAD, JOB, TOOL, SHOT, SERVE_PID } = process.env;
const BASE = URL.replace(/\?.*$/, "");
const SHOTS = path.dirname(SHOT);
const ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync"];
let failures = 0;
function check(ok, what) {
  console.log((ok ? "ok   " : "FAIL ") + what);
  if (!ok) failures++;
}
function cli(...args) {
  return execFileSync(GANTRY, [...args, "--port", PORT], { encoding: "utf8", timeout: 20000 });
}
function cliStatus() {
  const t = cli("status");
  const pos = (name) => {
    const m = t.match(new RegExp("^" + name + ":\\s+X (-?[\\d.]+)\\s+Y (-?[\\d.]+)\\s+Z (-?[\\d.]+)", "m"));
    return m.slice(1).map(Number);
  };
  return {
    text: t, state: t.match(/^state:\s+(\S+)/m)[1], machine: pos("machine"), work: pos("work"),
    line: +t.match(/^line:\s+(\d+)/m)[1], fo: +t.match(/override feed (\d+)/)[1],
    so: +t.match(/spindle (\d+) %/)[1], program: t.match(/^program:\s+(.*)$/m)[1],
  };
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const text = (page, sel) => page.locator(sel).textContent();
// The page shows serve's program: its listing (`lines` lines), a drawn path and the current line.
async function shows(page, lines) {
  try {
    await page.waitForFunction((n) => document.getElementById("L" + n) && document.querySelector("#listing .cur") &&
      document.getElementById("prog-name").textContent.includes(n + " lines"), lines, { timeout: 10000 });
  } catch { return false; }
  return (await pathPixels(page)) > 200;
}
// Path-coloured pixels of the top view (feeds blue, cut orange).
function pathPixels(page) {
  return page.evaluate(() => {
    const cv = document.getElementById("top"), d = cv.getContext("2d").getImageData(0, 0, cv.width, cv.height).data;
    let n = 0;
    for (let i = 0; i < d.length; i += 4) if (isPath(d[i], d[i + 1], d[i + 2])) n++;
    return n;
    function isPath(r, g, b) { return (r > 180 && g > 90 && g < 190 && b < 80) || (b > 180 && g > 140 && r < 140); }
  });
}
// Where the cross is drawn on the top view, and the path pixels around it.
function crossOnPath(page) {
  return page.evaluate(() => {
    const cv = document.getElementById("top"), d = cv.getContext("2d").getImageData(0, 0, cv.width, cv.height).data;
    const [cx, cy] = window.gantryCross.map(Math.round);
    let near = 0, x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (let y = 0; y < cv.height; y++) for (let x = 0; x < cv.width; x++) {
      const i = (y * cv.width + x) * 4, r = d[i], g = d[i + 1], b = d[i + 2];
      if (!((r > 180 && g > 90 && g < 190 && b < 80) || (b > 180 && g > 140 && r < 140))) continue;
      x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y);
      if (Math.hypot(x - cx, y - cy) <= 8) near++;
    }
    // The cross's own red pixels where it is said to be.
    const i = (cy * cv.width + cx) * 4;
    return { cx, cy, near, box: [x0, y0, x1, y1].join(","), inside: cx >= x0 && cx <= x1 && cy >= y0 && cy <= y1 && d[i] > 200 && d[i + 1] < 120 };
  });
}
// An MDI block from the page's field; sent again while the previous block's job still runs.
async function mdi(page, line) {
  for (let i = 0; i < 50; i++) {
    const answer = page.waitForResponse((r) => r.url().endsWith("/api/mdi"), { timeout: 20000 });
    await page.fill("#mdi", line);
    await page.press("#mdi", "Enter");
    const v = await (await answer).json();
    if (v.ok || !/still running/.test(v.error)) return v;
    await sleep(200);
  }
}
async function waitState(page, want, ms = 10000) {
  try {
    await page.waitForFunction((w) => document.getElementById("state").textContent === w, want, { timeout: ms });
    return true;
  } catch { return false; }
}

(async () => {
  const browser = await chromium.launch({ executablePath: process.env.CHROMIUM || "/usr/bin/chromium", args: ARGS });
  // The lock: without the printed URL's token (a browser with no cookie) nothing is served.
  let ctx = await browser.newContext({ viewport: { width: 1400, height: 1000 } });
  let page = await ctx.newPage();
  const locked = await page.goto(BASE);
  check(locked.status() === 401 && /token/.test(await page.textContent("body")), `no token: ${locked.status()} "${(await page.textContent("body")).trim().slice(0, 40)}…"`);
  await ctx.close();

  ctx = await browser.newContext({ viewport: { width: 1400, height: 1000 } });
  page = await ctx.newPage();
  page.on("pageerror", (e) => { console.log("page error: " + e); failures++; });
  await page.goto(URL);
  check(await waitState(page, "Idle"), "the page shows the board Idle from its pushed status");
  check(page.url() === BASE, "the token is taken out of the address bar: " + page.url());

  // Home through the page: X then Y seek their min switches (10 mm away), locate and set home
  // where machine coordinates already were (home_position = switch + pull-off).
  await page.click("#home-all");
  await page.waitForFunction(() => document.getElementById("homed").textContent.replace(/\s/g, "") === "XY", null, { timeout: 30000 }).catch(() => {});
  await waitState(page, "Idle", 30000);
  const homed = cliStatus();
  check(/^homed:\s+X\s*Y\s*$/m.test(homed.text) && homed.machine[0] === -299 && homed.machine[1] === -199 && homed.state === "Idle",
    `Home all: X and Y homed (page "${await text(page, "#homed")}"), machine X ${homed.machine[0]} Y ${homed.machine[1]} (switches at -301 / -201, 2 mm pull-off)`);

  // Status events arrive at the board's rate (10 Hz): count them for 2 s.
  const rate = await page.evaluate(() => new Promise((res) => {
    let n = 0;
    const es = new EventSource("/events");
    es.addEventListener("status", () => n++);
    setTimeout(() => { es.close(); res(n / 2); }, 2000);
  }));
  check(rate >= 9, `status events at ${rate} per second (board pushes 10 Hz)`);

  // A program with an error: shown at its line, with gantry check's words.
  await page.setInputFiles("#file", BAD);
  await page.waitForFunction(() => document.getElementById("check").textContent.length > 0);
  const report = await text(page, "#check");
  check(/bad\.nc:3:.*error/.test(report) && report.includes("^"), "the check names line 3 with a caret:\n" + report.split("\n").slice(0, 3).join("\n"));
  check(await page.locator("#L3.err").count() === 1, "listing line 3 is marked as the error");
  const want = spawnSync(GANTRY, ["check", BAD], { encoding: "utf8" }).stdout.split("\n")[0];
  check(report.includes(want.replace(/^.*bad\.nc/, "bad.nc")), "same message as gantry check: " + want);
  // It does not run: Run is disabled, and the server refuses it (the session's one start check).
  check(await page.locator("#run").isDisabled() && await page.locator("#run-from").isDisabled(),
    "Run and Run from line are disabled for a program whose check failed");
  const refused = await page.evaluate(() => fetch("/api/run", {
    method: "POST", headers: { "Content-Type": "application/json" }, body: "{}",
  }).then((r) => r.json()));
  check(!refused.ok && /nothing was run/.test(refused.error), "the server refuses to run it: " + JSON.stringify(refused).slice(0, 120));

  // A good program: checked, planned, drawn, run.
  await page.setInputFiles("#file", JOB);
  await page.waitForFunction(() => /planned time/.test(document.getElementById("prog-name").textContent));
  check(!(await page.locator("#check").getAttribute("class")), "the good program checks clean");
  await page.click("#run");
  check(await waitState(page, "Hold", 15000), "the job runs to its M0 and holds");
  await page.waitForFunction(() => !document.getElementById("stop").hidden, null, { timeout: 5000 }).catch(() => {});
  const stop = await text(page, "#stop-text");
  check(/M0/.test(stop) && stop.includes("check the clamp"), "the M0 stop shows its comment: " + JSON.stringify(stop));
  await page.click("#continue");
  check(await waitState(page, "Run"), "Continue resumes the job");
  await sleep(1500);
  await page.screenshot({ path: SHOT, fullPage: true });
  check(/ETA \d/.test(await text(page, "#job")), "progress with an ETA: " + (await text(page, "#job")));

  // Two clients: gantry status --watch beside the page.
  const watch = spawn(GANTRY, ["status", "--watch", "--for", "3", "--port", PORT]);
  let watched = "";
  watch.stdout.on("data", (d) => { watched += d; });

  // Running: the readout follows the board within one status period (feed 900 mm/min: 1.5 mm in 0.1 s).
  // (read before and after the CLI's answer: a loaded machine may take a while to run it)
  const pageX = parseFloat(await text(page, "#mach-X"));
  const cliX = cliStatus().machine[0];
  const pageX2 = parseFloat(await text(page, "#mach-X"));
  const near = Math.min(Math.abs(pageX - cliX), Math.abs(pageX2 - cliX));
  const between = (cliX - pageX) * (cliX - pageX2) <= 0;
  check(near <= 2.5 || between, `running: page X ${pageX} .. ${pageX2} vs gantry status X ${cliX}`);

  await page.click("#hold");
  check(await waitState(page, "Hold"), "Hold: the page shows Hold");
  await sleep(600);
  const held = cliStatus();
  check(held.state === "Hold", "gantry status agrees: " + held.state);
  const px = await text(page, "#mach-X"), wx = await text(page, "#work-X");
  check(parseFloat(px) === held.machine[0] && parseFloat(wx) === held.work[0], `held: page X ${px} / work ${wx} equal gantry status ${held.machine[0]} / ${held.work[0]}`);

  await page.fill("#fo-in", "50");
  await page.click("#fo-set");
  await page.waitForFunction(() => document.getElementById("fo").textContent === "50", null, { timeout: 5000 }).catch(() => {});
  check((await text(page, "#fo")) === "50" && cliStatus().fo === 50, "feed override 50 % on the page and in gantry status");

  await page.click("#resume");
  check(await waitState(page, "Run"), "Resume: running again");
  await new Promise((r) => watch.on("close", r));
  check(/state:\s+Hold/.test(watched) && /state:\s+Run/.test(watched), "gantry status --watch saw the same Hold and Run");

  // Closing the page never stops the job.
  const before = cliStatus();
  await ctx.close();
  await sleep(2000);
  const after = cliStatus();
  check(after.state === "Run" && after.line > before.line, `page closed: the job runs on (line ${before.line} -> ${after.line}, ${after.state})`);

  ctx = await browser.newContext({ viewport: { width: 1400, height: 1000 } });
  page = await ctx.newPage();
  await page.goto(URL);
  check(await waitState(page, "Run"), "a new page sees the job running");
  check(await shows(page, 406), "a new page shows serve's program: listing of 406 lines, path, current line");

  // A reload mid-job, and a second tab: the same listing, path and line, from serve.
  await page.reload();
  check(await waitState(page, "Run") && await shows(page, 406), "after a reload mid-job: listing, path and current line back");
  const tab2 = await ctx.newPage();
  await tab2.goto(BASE);
  check(await waitState(tab2, "Run") && await shows(tab2, 406), "a second tab shows the same program and line");
  await tab2.close();

  // A refusal in the board's words: a jog while the job runs is "busy" (902), not a G-code error.
  await page.locator("body").click({ position: { x: 5, y: 300 } });
  await page.keyboard.press("ArrowRight");
  await page.waitForFunction(() => !document.getElementById("refusal").hidden, null, { timeout: 5000 }).catch(() => {});
  const refusal = await text(page, "#refusal");
  check(/busy/.test(refusal) && !/plane/.test(refusal), "a jog while running is refused: " + refusal);

  const lineBefore = cliStatus().line;
  await page.click("#abort");
  check(await waitState(page, "Idle"), "Abort: Idle");
  const aborted = cliStatus();
  check(aborted.state === "Idle", "gantry status: Idle");
  // Serve's resume line is offered (and survives a reload).
  await page.waitForFunction(() => !document.getElementById("resume-offer").hidden, null, { timeout: 5000 }).catch(() => {});
  await page.reload();
  await waitState(page, "Idle");
  await page.waitForFunction(() => !document.getElementById("resume-offer").hidden, null, { timeout: 5000 }).catch(() => {});
  const resumeLine = +(await text(page, "#resume-line"));
  check(resumeLine >= lineBefore && resumeLine <= 406 && (await page.inputValue("#from")) === String(resumeLine),
    `after Abort (and a reload) the page offers resume line ${resumeLine} (board was at ${lineBefore}, then ${aborted.line})`);
  await page.click("#run-resume");
  check(await waitState(page, "Run", 15000), "Run from the offered line: running");
  await page.waitForFunction((n) => /from line (\d+)/.test(document.getElementById("job").textContent), resumeLine, { timeout: 10000 }).catch(() => {});
  const fromText = await text(page, "#job");
  // The preamble runs as line 0 first; then the board executes from the line.
  let resumed = cliStatus();
  for (let i = 0; i < 100 && resumed.line < resumeLine; i++) { await sleep(100); resumed = cliStatus(); }
  check(fromText.includes("from line " + resumeLine) && resumed.line >= resumeLine, `the job runs from line ${resumeLine}: ${fromText} (board line ${resumed.line})`);

  // The layout at a phone, a tablet and a laptop, mid-job (screenshots in docs/console.md).
  for (const [w, h] of [[390, 844], [1024, 768], [1280, 800]]) {
    await page.setViewportSize({ width: w, height: h });
    await page.evaluate(() => window.scrollTo(0, 0));
    await sleep(400);
    const L = await page.evaluate(() => {
      const r = (id) => document.getElementById(id).getBoundingClientRect();
      const small = [...document.querySelectorAll("button, select")].filter((b) => b.offsetParent && b.getBoundingClientRect().height < 44).map((b) => b.id || b.textContent);
      return { sw: document.documentElement.scrollWidth, hold: r("hold"), abort: r("abort"), resume: r("resume"), axes: r("axes"), top: r("top"), progress: r("progress"), readout: r("readout"), small };
    });
    await page.screenshot({ path: `${SHOTS}/console-${w}x${h}.png` });
    check(L.sw <= w, `${w}x${h}: no sideways scrolling (page ${L.sw} px wide)`);
    check(L.small.length === 0, `${w}x${h}: every button at least 44 px tall` + (L.small.length ? ": " + L.small.join(", ") : ""));
    const firstScreen = (b) => b.bottom <= h && b.right <= w && b.left >= 0;
    check(firstScreen(L.hold) && firstScreen(L.resume) && firstScreen(L.abort) && L.axes.top < h,
      `${w}x${h}: Hold, Resume, Abort and the readout on the first screen`);
    if (w >= 1024) check(L.progress.top < h && L.top.top < h && L.top.left >= L.readout.right,
      `${w}x${h}: progress and path beside the readout (path at x ${Math.round(L.top.left)}, readout ends ${Math.round(L.readout.right)})`);
  }
  await page.setViewportSize({ width: 1400, height: 1000 });
  await page.click("#abort");
  check(await waitState(page, "Idle"), "Abort: Idle again");

  // Jog by key: one 1 mm step, exactly.
  await page.selectOption("#step", "1");
  const x0 = cliStatus().machine[0];
  await page.locator("body").click({ position: { x: 5, y: 300 } });
  await page.keyboard.press("ArrowRight");
  await sleep(300);
  await waitState(page, "Idle");
  await sleep(300);
  let x1 = cliStatus().machine[0];
  check(Math.abs(x1 - x0 - 1) < 1e-9, `ArrowRight jogs X by 1.000 mm (${x0} -> ${x1})`);
  check(parseFloat(await text(page, "#mach-X")) === x1, "the readout shows it");

  // A held continuous jog is kept alive by the page (a keepalive every 50 ms); taken offline,
  // the page sends none and the board's dead-man stops the jog (docs/controller.md "Jogging").
  await page.selectOption("#step", "0");
  await page.fill("#jogfeed", "600");
  const xp = page.locator('.jog[data-axis="X"][data-dir="1"]');
  await xp.hover();
  await page.mouse.down();
  let jogging = false;
  for (let i = 0; i < 50 && !jogging; i++) { jogging = cliStatus().state === "Jog"; if (!jogging) await sleep(100); }
  check(jogging, "held X+: the board jogs");
  await sleep(1000);
  const stillJog = cliStatus();
  check(stillJog.state === "Jog", `still jogging after 1 s held (the page's keepalives): ${stillJog.state} at X ${stillJog.machine[0]}`);
  await ctx.setOffline(true);
  const off = Date.now();
  let st = cliStatus();
  while (st.state === "Jog" && Date.now() - off < 5000) st = cliStatus();
  const took = Date.now() - off;
  check(st.state === "Idle" && took <= 500, `offline: the board stopped the jog by itself in ${took} ms (state ${st.state})`);
  await sleep(300);
  const rest = cliStatus();
  check(rest.state === "Idle" && rest.machine[0] === st.machine[0], `and nothing moved after (X ${st.machine[0]} -> ${rest.machine[0]})`);
  await ctx.setOffline(false);
  await page.mouse.up();
  await page.selectOption("#step", "1");
  await waitState(page, "Idle");
  x1 = cliStatus().machine[0];

  // Zero X.
  await page.click("#zero-X");
  await page.waitForFunction(() => document.getElementById("work-X").textContent === "+0.000", null, { timeout: 5000 }).catch(() => {});
  check((await text(page, "#work-X")) === "+0.000" && cliStatus().work[0] === 0, "Zero X: work X 0.000 on the page and in gantry status");

  // The offset table reads the zero back from the board: G54 X is where X stood.
  await page.waitForFunction((x) => document.getElementById("off-1-X").value === x.toFixed(3), x1, { timeout: 5000 }).catch(() => {});
  check((await page.inputValue("#off-1-X")) === x1.toFixed(3), `the G54 row shows the G10 L20 zero: X ${await page.inputValue("#off-1-X")} (machine X ${x1})`);
  // Edited in the table (G10 L2 P2), read back from the board.
  await page.fill("#off-2-Y", "12.5");
  await page.click("#off-set-2");
  await page.waitForFunction(() => document.getElementById("off-2-Y").value === "12.500", null, { timeout: 5000 }).catch(() => {});
  const pulled = execFileSync(GANTRY, ["setup", "pull", "--port", PORT], { encoding: "utf8", timeout: 20000 });
  check((await page.inputValue("#off-2-Y")) === "12.500" && /^"G55" = \[[^\]]*12\.5/m.test(pulled),
    "G55 Y 12.5 set in the table: read back on the page and in gantry setup pull");

  // Spindle override: the readout follows (programmed S and the speed commanded).
  await mdi(page, "M3 S10000");
  await page.waitForFunction(() => document.getElementById("rpm").textContent === "10000", null, { timeout: 5000 }).catch(() => {});
  await page.click("[data-so='10']");
  await page.waitForFunction(() => document.getElementById("so").textContent === "110", null, { timeout: 5000 }).catch(() => {});
  const spun = cliStatus();
  check((await text(page, "#rpm")) === "10000" && (await text(page, "#rpm-actual")) === "11000" && spun.so === 110,
    `spindle override +10: S ${await text(page, "#rpm")} programmed, ${await text(page, "#rpm-actual")} rpm commanded, gantry status spindle ${spun.so} %`);
  await page.click("#ovr-reset");
  await page.waitForFunction(() => document.getElementById("so").textContent === "100", null, { timeout: 5000 }).catch(() => {});
  check(cliStatus().so === 100, "Reset all: spindle override 100 %");
  await mdi(page, "M5");

  // Inch readout after G20: work X 1 mm shows +0.0394 in.
  await mdi(page, "G20");
  await page.waitForFunction(() => document.getElementById("units").textContent === "in", null, { timeout: 5000 }).catch(() => {});
  await page.locator("body").click({ position: { x: 5, y: 300 } });
  await page.keyboard.press("ArrowRight");
  await sleep(300);
  await waitState(page, "Idle");
  await sleep(300);
  const inch = cliStatus();
  const wantIn = "+" + (inch.work[0] / 25.4).toFixed(4);
  check((await text(page, "#units")) === "in" && (await text(page, "#work-X")) === wantIn && inch.program.includes("G20"),
    `after G20 the readout is in inches: work X ${await text(page, "#work-X")} (gantry status ${inch.work[0]} mm, ${inch.program})`);
  await mdi(page, "G21");
  await page.waitForFunction(() => document.getElementById("units").textContent === "mm", null, { timeout: 5000 }).catch(() => {});
  check((await text(page, "#work-X")) === "+" + inch.work[0].toFixed(3), "after G21: mm again");

  // The library: an upload is kept (name, size, date, planned time, tools), listed after a
  // reload; chosen from the list it is checked and runs, its M6 prompts for the tool.
  page.on("dialog", (d) => d.accept());
  await page.setInputFiles("#file", TOOL);
  await page.waitForFunction(() => document.querySelector('#library tr[data-name="tool.nc"]'), null, { timeout: 10000 }).catch(() => {});
  await page.reload();
  await waitState(page, "Idle");
  await page.waitForFunction(() => document.querySelector('#library tr[data-name="tool.nc"]'), null, { timeout: 10000 }).catch(() => {});
  const row = await page.evaluate(() => [...(document.querySelector('#library tr[data-name="tool.nc"]') || { cells: [] }).cells].map((c) => c.textContent));
  check(row[0] === "tool.nc" && /B$/.test(row[1]) && /^0:00:\d\d$/.test(row[3]) && row[4] === "T2", "the library keeps tool.nc: " + row.slice(0, 5).join(" | "));
  await page.click('#library tr[data-name="job.nc"] .lib-open').catch(() => {});
  await page.waitForFunction(() => /^job\.nc/.test(document.getElementById("prog-name").textContent), null, { timeout: 10000 }).catch(() => {});
  await page.click('#library tr[data-name="tool.nc"] .lib-open');
  await page.waitForFunction(() => /^tool\.nc: 8 lines, planned time/.test(document.getElementById("prog-name").textContent), null, { timeout: 10000 }).catch(() => {});
  check(/^tool\.nc: 8 lines, planned time/.test(await text(page, "#prog-name")) && /tools\s+T2/.test(await text(page, "#check")),
    "chosen from the library: " + (await text(page, "#prog-name")) + ", the check lists T2");
  await page.click("#run");
  check(await waitState(page, "ToolChange", 15000), "the M6 stops the job: ToolChange");
  await page.waitForFunction(() => !document.getElementById("stop").hidden, null, { timeout: 5000 }).catch(() => {});
  const m6 = await text(page, "#stop-text");
  check(/tool 2|T2/.test(m6) && cliStatus().state === "ToolChange", "the M6 prompt: " + JSON.stringify(m6));
  await page.click("#continue");
  await page.waitForFunction(() => /tool\.nc: done/.test(document.getElementById("job").textContent), null, { timeout: 20000 }).catch(() => {});
  const toolDone = cliStatus();
  check(/tool\.nc: done/.test(await text(page, "#job")) && toolDone.state === "Idle" && /T2|tool 2/.test(toolDone.text),
    `after Continue the job completes with tool 2 in the spindle (${await text(page, "#job")})`);

  // A macro: kept by serve, run from the page (X back by exactly 1 mm).
  await page.fill("#macro-name", "left 1");
  await page.fill("#macro-text", "G91 G0 X-1\nG90");
  await page.click("#macro-save");
  await page.waitForFunction(() => document.querySelector('#macros tr[data-name="left 1"]'), null, { timeout: 10000 }).catch(() => {});
  const mx0 = cliStatus().machine[0];
  await page.click('#macros tr[data-name="left 1"] .macro-run');
  await page.waitForFunction(() => /macro left 1: done/.test(document.getElementById("job").textContent), null, { timeout: 20000 }).catch(() => {});
  const mx1 = cliStatus().machine[0];
  check(Math.abs(mx0 - mx1 - 1) < 1e-9, `macro "left 1" moved X by exactly -1.000 mm (${mx0} -> ${mx1})`);

  // One frame: the tool path, the cross and the box in work coordinates. With G54 moved away from
  // machine zero (jogs of 10 mm, then Zero X and Y), the cross sits on the path being cut.
  await page.selectOption("#step", "10");
  for (const key of ["ArrowRight", "ArrowRight", "ArrowRight", "ArrowUp", "ArrowUp"]) {
    await page.locator("body").click({ position: { x: 5, y: 300 } });
    await page.keyboard.press(key);
    await sleep(300);
    await waitState(page, "Idle");
  }
  await page.click("#zero-X");
  await page.click("#zero-Y");
  await page.waitForFunction(() => document.getElementById("work-Y").textContent === "+0.000", null, { timeout: 5000 }).catch(() => {});
  const moved = cliStatus();
  check(moved.machine[0] > 25 && moved.machine[1] > 15 && moved.work[0] === 0 && moved.work[1] === 0, `G54 at machine X ${moved.machine[0]} Y ${moved.machine[1]}`);
  await page.setInputFiles("#file", JOB);
  await page.waitForFunction(() => /planned time/.test(document.getElementById("prog-name").textContent));
  await page.click("#run");
  check(await waitState(page, "Hold", 15000), "the job runs to its M0 again");
  await page.click("#continue");
  await waitState(page, "Run");
  await page.waitForFunction(() => +document.getElementById("line").textContent > 60, null, { timeout: 30000 }).catch(() => {});
  await page.click("#hold");
  await waitState(page, "Hold");
  await sleep(500);
  for (const fr of ["work", "machine"]) {
    await page.selectOption("#frame", fr);
    await sleep(300);
    const px = await crossOnPath(page);
    check(px.near > 0 && px.inside, `${fr} coordinates: the cross (${px.cx}, ${px.cy}) is on the path (${px.near} path pixels within 8 px; path box ${px.box})`);
  }
  await page.selectOption("#frame", "work");
  await page.click("#abort");
  check(await waitState(page, "Idle"), "Abort: Idle");

  // Probing against the emulator's targets, through the page: each workflow's plan is confirmed
  // (the dialog), then the offsets are set to the µm.
  const g54 = () => {
    const m = execFileSync(GANTRY, ["setup", "pull", "--port", PORT], { encoding: "utf8", timeout: 20000 }).match(/^"G54" = \[([^\]]*)\]/m);
    return m ? m[1].split(",").map(Number) : [];
  };
  const dialogs = [];
  page.on("dialog", (d) => dialogs.push(d.message()));
  const goTo = async (blocks) => {
    for (const b of blocks) { await mdi(page, b); await page.waitForFunction(() => /mdi: done/.test(document.getElementById("job").textContent), null, { timeout: 20000 }).catch(() => {}); await waitState(page, "Idle"); }
  };
  // A workflow's start, sent again while the previous MDI block's job still runs.
  const startProbe = async (id) => {
    for (let i = 0; i < 50; i++) {
      const answer = page.waitForResponse((r) => r.url().endsWith("/api/probe"), { timeout: 20000 });
      await page.click(id);
      const v = await (await answer).json();
      if (v.ok || !/still running/.test(v.error)) return v;
      await sleep(300);
    }
  };
  await goTo(["G53 G0 Z5", "G53 G0 X150 Y50"]);
  await page.fill("#pz-thickness", "10");
  await page.fill("#pz-distance", "20");
  await startProbe("#probe-z");
  await page.waitForFunction(() => /set to|stopped/.test(document.getElementById("probe-result").textContent), null, { timeout: 30000 }).catch(() => {});
  await waitState(page, "Idle");
  const zr = await text(page, "#probe-result");
  const zOff = g54(), zSt = cliStatus();
  check(dialogs.some((d) => /probe down up to 20 mm/.test(d) && /Start\?/.test(d)), "Z: the plan was shown and asked before moving");
  check(/contact at machine Z -5\.000/.test(zr) && zOff[2] === -15 && zSt.work[2] === 12 && zSt.machine[2] === -3,
    `Z touch plate (10 mm on the plane at Z -5): "${zr}"; G54 Z ${zOff[2]} (gantry setup pull), work Z ${zSt.work[2]} after the 2 mm retract`);
  await page.waitForFunction(() => document.getElementById("off-1-Z").value === "-15.000", null, { timeout: 10000 }).catch(() => {});
  check((await page.inputValue("#off-1-Z")) === "-15.000", "the offset table shows G54 Z -15.000");
  await goTo(["G53 G0 Z5", "G53 G0 X206 Y106"]);
  await page.fill("#pc-clearance", "12");
  await page.fill("#pc-depth", "8");
  await page.fill("#pc-diameter", "0");
  await startProbe("#probe-corner");
  await page.waitForFunction(() => /corner at|stopped/.test(document.getElementById("probe-result").textContent), null, { timeout: 60000 }).catch(() => {});
  await waitState(page, "Idle");
  const cr = await text(page, "#probe-result");
  const cOff = g54(), cSt = cliStatus();
  check(dialogs.some((d) => /outside corner/.test(d)), "corner: the plan was shown and asked before moving");
  check(/X 200\.000 \(left face\) and Y 100\.000/.test(cr) && cOff[0] === 200 && cOff[1] === 100 && cOff[2] === -15 &&
    cSt.machine[0] === 206 && cSt.machine[1] === 106 && cSt.work[0] === 6 && cSt.work[1] === 6,
    `XY corner of the block at X 200 Y 100: "${cr}"; G54 ${cOff.join(", ")}; back above the start, work X ${cSt.work[0]} Y ${cSt.work[1]}`);

  // The other workflows: each plan asked first, each offset from `gantry setup pull` to the µm.
  const probeRun = async (id, done, what) => {
    const asked = dialogs.length;
    await page.evaluate(() => { document.getElementById("probe-result").textContent = ""; });
    await startProbe(id);
    await page.waitForFunction((re) => new RegExp(re).test(document.getElementById("probe-result").textContent), done, { timeout: 90000 }).catch(() => {});
    await waitState(page, "Idle");
    check(dialogs.length > asked && new RegExp(what).test(dialogs[dialogs.length - 1]), `${what}: the plan was shown and asked before moving`);
    return text(page, "#probe-result");
  };
  const um = (a, b) => Math.round(a * 1000) === Math.round(b * 1000);
  // Back-right corner of the block with a 3 mm tool: contacts at X 250 and Y 150, the corner
  // 1.5 mm inside each (the emulated probe is a point at the tool's centre).
  await goTo(["G53 G0 Z5", "G53 G0 X244 Y144"]);
  await page.fill("#pc-diameter", "3");
  await page.selectOption("#pc-corner", "back-right");
  const br = await probeRun("#probe-corner", "corner at|stopped", "outside corner \\(back-right\\)");
  const brOff = g54(), brSt = cliStatus();
  check(/X 250\.000 \(right face\) and Y 150\.000 \(back face\)/.test(br) && um(brOff[0], 248.5) && um(brOff[1], 148.5) && brOff[2] === -15 &&
    brSt.machine[0] === 244 && brSt.machine[1] === 144,
    `back-right corner, tool 3 mm: "${br}"; G54 ${brOff.join(", ")}; back above the start (${brSt.machine.slice(0, 2).join(", ")})`);
  // One edge: the block's back face, probing Y-; only G54 Y changes.
  await goTo(["G53 G0 X225 Y146"]);
  await page.fill("#pc-diameter", "0");
  await page.selectOption("#pe-side", "y-");
  const ed = await probeRun("#probe-edge", "face at|stopped", "probing Y- \\(the back face\\)");
  const edOff = g54();
  check(/machine Y 150\.000/.test(ed) && edOff[0] === 248.5 && edOff[1] === 150 && edOff[2] === -15,
    `edge Y- of the block: "${ed}"; G54 ${edOff.join(", ")}`);
  // The round boss (60 mm at X -100 Y 100), started 2 mm off its centre in X.
  await goTo(["G53 G0 X-98 Y100"]);
  await page.fill("#pb-size", "60");
  const bs = await probeRun("#probe-boss", "centre at|stopped", "Boss centre");
  const bsOff = g54(), bsSt = cliStatus();
  check(/X -130\.000 and -70\.000, Y 70\.000 and 130\.000/.test(bs) && /diameter 60\.000/.test(bs) && bsOff[0] === -100 && bsOff[1] === 100 &&
    bsSt.work[0] === 0 && bsSt.work[1] === 0,
    `boss: "${bs}"; G54 ${bsOff.join(", ")}; the tool above the centre (work X ${bsSt.work[0]} Y ${bsSt.work[1]})`);
  // The bore (30 mm at X -100 Y -100): the tool put in it off its centre (3 mm in X, 1 in Y: the X
  // chord is not the diameter, its middle is the centre), below the top.
  await goTo(["G53 G0 X-97 Y-101", "G53 G0 Z-3"]);
  await page.fill("#pb-size", "30");
  const bo = await probeRun("#probe-bore", "centre at|stopped", "Bore centre");
  const boOff = g54(), boSt = cliStatus();
  check(/Y -115\.000 and -85\.000/.test(bo) && /diameter 30\.000/.test(bo) && boOff[0] === -100 && boOff[1] === -100 &&
    boSt.machine[0] === -100 && boSt.machine[1] === -100 && boSt.machine[2] === -3,
    `bore: "${bo}"; G54 ${boOff.join(", ")}; the tool at the centre (${boSt.machine.join(", ")})`);
  // Tool length of the tool in the spindle (T2, from the M6) on the setter under G30 (X 275
  // Y -175 Z 20): the setter's top at Z 10, a tool of length 0 touches at Z -20: 30 mm.
  await goTo(["G53 G0 Z5"]);
  await page.fill("#pt-setter", "-20");
  await page.fill("#pt-distance", "15");
  const tl = await probeRun("#probe-tool", "length set|stopped", "Tool length of T2");
  // The length in use, from the board's status: machine Z - work Z - G54 Z (the board keeps a
  // G10 L1 length in its interpreter's tool table, not in the setup `gantry setup pull` reads).
  const tlSt = cliStatus(), tlOff = g54();
  const inUse = tlSt.machine[2] - tlSt.work[2] - tlOff[2];
  check(/setter at machine Z 10\.000/.test(tl) && /T2 length set to 30\.000/.test(tl) && um(inUse, 30) && tlSt.machine[0] === 275 &&
    tlSt.machine[1] === -175 && tlSt.machine[2] === 20,
    `tool length: "${tl}"; gantry status: length in use ${inUse.toFixed(3)} (machine Z ${tlSt.machine[2]}, work Z ${tlSt.work[2]}, G54 Z ${tlOff[2]}), over the setter at ${tlSt.machine.slice(0, 2).join(", ")}`);

  // serve gone: the page greys out, says so and disables every control.
  process.kill(+SERVE_PID, "SIGTERM");
  await page.waitForFunction(() => document.body.classList.contains("offline"), null, { timeout: 15000 }).catch(() => {});
  const gone = await page.evaluate(() => ({
    banner: getComputedStyle(document.getElementById("offline")).display !== "none" && document.getElementById("offline").textContent,
    state: document.getElementById("state").textContent,
    live: [...document.querySelectorAll("button, input, select, textarea")].filter((b) => !b.disabled).length,
  }));
  check(gone.banner && gone.state !== "Idle" && gone.live === 0, `serve stopped: banner "${String(gone.banner).trim().slice(0, 60)}…", state "${gone.state}", ${gone.live} controls enabled`);
  await page.screenshot({ path: `${SHOTS}/console-offline.png` });
  // serve again: it keeps its token (in its private runtime directory), so the same page comes
  // back live by itself, without a new URL.
  const again = spawn(GANTRY, ["serve", "--port", PORT, "--http", BASE.replace(/^http:\/\//, "").replace(/\/$/, "")]);
  let againLog = "";
  again.stderr.on("data", (d) => { againLog += d; });
  try {
    for (let i = 0; i < 300 && !/token is also in/.test(againLog); i++) await sleep(100);
    const url2 = (againLog.match(/the console is on (\S+)/) || [])[1];
    check(url2 === URL && /keeps its token/.test(againLog), "serve restarted with the same token: " + (url2 === URL ? "same URL" : url2));
    await page.waitForFunction(() => !document.body.classList.contains("offline"), null, { timeout: 20000 }).catch(() => {});
    check(await waitState(page, "Idle") && page.url() === BASE, "the open page is live again by itself, Idle, at " + page.url());
    const again2 = cliStatus();
    check(/^homed:\s+X\s*Y\s*$/m.test(again2.text) && again2.machine[0] === 275 && again2.machine[1] === -175,
      `after the serve restart the board is as it was (homed, at ${again2.machine.slice(0, 2).join(", ")})`);
    await page.waitForFunction(() => document.querySelector('#library tr[data-name="tool.nc"]') && document.querySelector('#macros tr[data-name="left 1"]'), null, { timeout: 10000 }).catch(() => {});
    const kept = await page.evaluate(() => [...document.querySelectorAll("#library tr[data-name], #macros tr[data-name]")].map((r) => r.dataset.name));
    check(kept.includes("tool.nc") && kept.includes("job.nc") && kept.includes("left 1"), "after the serve restart the library and the macros are there: " + kept.join(", "));
  } finally {
    again.kill("SIGTERM");
    await new Promise((r) => again.on("close", r));
  }

  await browser.close();
  console.log(failures ? `console test: ${failures} FAILED` : "console test: all passed");
  process.exit(failures ? 1 : 0);
})().catch((e) => { console.error(e); process.exit(1); });
