// Drives gantry serve's console page in Debian's chromium through playwright-core (its own
// browser builds are never downloaded: executablePath is the system's). Run by
// scripts/console-test.sh, which starts `gantry emulate --pty` and `gantry serve --http`.
// Env: URL, GANTRY (the binary), PORT (the pty), BAD and JOB (program files), SHOT (screenshot).
"use strict";
const { chromium } = require("playwright-core");
const { execFileSync, spawn, spawnSync } = require("child_process");
const fs = require("fs");
const path = require("path");

const { URL, GANTRY, PORT, BAD, JOB, SHOT } = process.env;
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
async function waitState(page, want, ms = 10000) {
  try {
    await page.waitForFunction((w) => document.getElementById("state").textContent === w, want, { timeout: ms });
    return true;
  } catch { return false; }
}

(async () => {
  const browser = await chromium.launch({ executablePath: process.env.CHROMIUM || "/usr/bin/chromium", args: ARGS });
  let ctx = await browser.newContext({ viewport: { width: 1400, height: 1000 } });
  let page = await ctx.newPage();
  page.on("pageerror", (e) => { console.log("page error: " + e); failures++; });
  await page.goto(URL);
  check(await waitState(page, "Idle"), "the page shows the board Idle from its pushed status");

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
  const pageX = parseFloat(await text(page, "#mach-X"));
  const cliX = cliStatus().machine[0];
  check(Math.abs(pageX - cliX) <= 2.5, `running: page X ${pageX} vs gantry status X ${cliX}`);

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
  await page.click("#abort");
  check(await waitState(page, "Idle"), "Abort: Idle");
  check(cliStatus().state === "Idle", "gantry status: Idle");

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
  await page.fill("#mdi", "M3 S10000");
  await page.press("#mdi", "Enter");
  await page.waitForFunction(() => document.getElementById("rpm").textContent === "10000", null, { timeout: 5000 }).catch(() => {});
  await page.click("[data-so='10']");
  await page.waitForFunction(() => document.getElementById("so").textContent === "110", null, { timeout: 5000 }).catch(() => {});
  const spun = cliStatus();
  check((await text(page, "#rpm")) === "10000" && (await text(page, "#rpm-actual")) === "11000" && spun.so === 110,
    `spindle override +10: S ${await text(page, "#rpm")} programmed, ${await text(page, "#rpm-actual")} rpm commanded, gantry status spindle ${spun.so} %`);
  await page.click("#ovr-reset");
  await page.waitForFunction(() => document.getElementById("so").textContent === "100", null, { timeout: 5000 }).catch(() => {});
  check(cliStatus().so === 100, "Reset all: spindle override 100 %");
  await page.fill("#mdi", "M5");
  await page.press("#mdi", "Enter");

  // Inch readout after G20: work X 1 mm shows +0.0394 in.
  await page.fill("#mdi", "G20");
  await page.press("#mdi", "Enter");
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
  await page.fill("#mdi", "G21");
  await page.press("#mdi", "Enter");
  await page.waitForFunction(() => document.getElementById("units").textContent === "mm", null, { timeout: 5000 }).catch(() => {});
  check((await text(page, "#work-X")) === "+" + inch.work[0].toFixed(3), "after G21: mm again");

  await browser.close();
  console.log(failures ? `console test: ${failures} FAILED` : "console test: all passed");
  process.exit(failures ? 1 : 0);
})().catch((e) => { console.error(e); process.exit(1); });
