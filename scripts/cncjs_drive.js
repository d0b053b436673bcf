// Drives a CNCjs server (https://cnc.js.org, installed from npm and used as-is) headless through
// its socket.io API, the way its web page and pendants do: open a port with CNCjs's Grbl
// controller, load and start a program (CNCjs streams it by character counting), press its
// hold, cycle-start, feed-override and jog-cancel buttons. Used by scripts/cncjs-sender-test.sh.
//
//   node cncjs_drive.js URL CNCRC PORT SCENARIO [PROGRAM]
//
// SCENARIO: `run` streams PROGRAM; `hold` streams it with +10 % feed override, a feed hold at
// rest and a cycle start on the way; `jog` jogs by `$J=` and cancels a long jog; `pauses`
// streams PROGRAM with three Pause/Resume cycles (CNCjs's `gcode:pause`, which sends `!` and
// keeps the lines it has in flight, and `gcode:resume`), then eight jog clicks sent at once
// (X +8 mm exactly), then PROGRAM again: every line of both runs acknowledged once (CNCjs's
// sender count; CNCjs does not pass the sender's and the jogs' `ok`s on to its clients).
// Prints one JSON line (the final machine position as CNCjs parsed it, lines acknowledged,
// errors, what each step observed) and exits 0 when every check of the scenario held.
'use strict';
const fs = require('fs');
const jwt = require('jsonwebtoken');
const io = require('socket.io-client');

const [url, rcPath, port, scenario, program] = process.argv.slice(2);
const secret = JSON.parse(fs.readFileSync(rcPath)).secret;
const token = jwt.sign({ id: '', name: 'gantry-test' }, secret, { expiresIn: '1h' });
const socket = io.connect(url, { query: 'token=' + token });
const verbose = !!process.env.VERBOSE;
const log = (...a) => { if (verbose) console.error('[cncjs]', ...a); };

const result = { scenario, errors: [], checks: {} };
let status = null; // CNCjs's parsed grbl status
let senderStatus = null;
const command = (...args) => socket.emit('command', port, ...args);

function fail(why) {
  result.failed = why;
  finish();
}

function finish() {
  if (status) result.mpos = status.mpos;
  console.log(JSON.stringify(result));
  process.exit(result.failed || result.errors.length ? 1 : 0);
}

// Resolves when `pred(status)` holds, or fails the run after `ms`.
function until(what, pred, ms) {
  return new Promise((resolve) => {
    const t0 = Date.now();
    const poll = () => {
      if (status && pred(status)) return resolve(status);
      if (Date.now() - t0 > ms) return fail('timed out waiting for ' + what);
      setTimeout(poll, 20);
    };
    poll();
  });
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const x = (s) => Number(s.mpos.x);

// Loads and starts PROGRAM; resolves when every line is acknowledged and the machine is idle.
async function stream() {
  const gcode = fs.readFileSync(program, 'utf8');
  await new Promise((resolve) => command('gcode:load', 'program.nc', gcode, {}, (err) => {
    if (err) return fail('gcode:load: ' + err);
    resolve();
  }));
  command('gcode:start');
  await until('the job to run', (s) => s.activeState === 'Run', 10000);
}

async function streamDone() {
  const t0 = Date.now();
  while (!(senderStatus && senderStatus.total > 0 && senderStatus.received === senderStatus.total)) {
    if (Date.now() - t0 > 300000) return fail('timed out waiting for the acknowledgements');
    await sleep(50);
  }
  result.lines = senderStatus.total;
  result.acknowledged = senderStatus.received;
  await until('idle after the job', (s) => s.activeState === 'Idle', 60000);
}

// Pause, stand at rest for half a second (no motion), resume.
async function pauseResume(n) {
  command('gcode:pause');
  const held = await until('pause ' + n + ' at rest', (s) => s.activeState === 'Hold' && s.subState === 0, 10000);
  const at = held.mpos.x;
  await sleep(500);
  if (status.mpos.x !== at || status.activeState !== 'Hold') return fail('moved while paused');
  command('gcode:resume');
  await until('run after resume ' + n, (s) => s.activeState === 'Run', 5000);
}

const scenarios = {
  async run() {
    await stream();
    await streamDone();
  },
  async hold() {
    await stream();
    await until('the cut along X', (s) => x(s) >= 10, 20000);
    command('feedOverride', 10);
    const over = await until('feed override 110 %', (s) => Number(s.ov[0]) === 110, 3000);
    result.checks.feed_override = over.ov[0];
    command('feedhold');
    const held = await until('hold at rest', (s) => s.activeState === 'Hold' && s.subState === 0, 10000);
    const at = held.mpos.x;
    await sleep(1000);
    result.checks.hold = { state: 'Hold:' + status.subState, x: at, x_after_1s: status.mpos.x };
    if (status.mpos.x !== at || status.activeState !== 'Hold') return fail('moved while held');
    command('cyclestart');
    await until('run after cycle start', (s) => s.activeState === 'Run', 5000);
    await streamDone();
  },
  async pauses() {
    await stream();
    const pauses = [];
    for (const at of [0.2, 0.5, 0.8]) {
      const t0 = Date.now();
      while (!(senderStatus && senderStatus.received >= at * senderStatus.total)) {
        if (Date.now() - t0 > 120000) return fail('timed out before pause at ' + at);
        await sleep(20);
      }
      pauses.push(senderStatus.received);
      await pauseResume(pauses.length);
    }
    result.checks.paused_at_line = pauses;
    await streamDone();
    const first = { lines: senderStatus.total, acknowledged: senderStatus.received };
    const x0 = x(status);
    // Eight jog clicks at once, as fast clicking on CNCjs's jog button sends them.
    for (let i = 0; i < 8; i++) command('gcode', '$J=G91 G21 X1 F2000');
    await until('the jogs to start', (s) => s.activeState === 'Jog', 5000);
    await until('X +8 mm at rest', (s) => s.activeState === 'Idle' && Math.abs(x(s) - x0 - 8) < 1e-9, 30000);
    await sleep(500);
    result.checks.jog_clicks = { from: x0, to: x(status) };
    if (Math.abs(x(status) - x0 - 8) > 1e-9) return fail('eight clicks did not jog X +8 mm');
    senderStatus = null;
    await stream();
    // The new run's own count (not a late status of the first).
    const t1 = Date.now();
    while (!(senderStatus && senderStatus.received < senderStatus.total)) {
      if (Date.now() - t1 > 10000) return fail('no progress of the second run');
      await sleep(20);
    }
    await streamDone();
    result.checks.runs = [first, { lines: senderStatus.total, acknowledged: senderStatus.received }];
  },
  async jog() {
    command('gcode', '$J=G91 G21 X5 Y-2 F1200');
    await until('the jog to start', (s) => s.activeState === 'Jog', 5000);
    const end = await until('the jog to end', (s) => s.activeState === 'Idle', 10000);
    result.checks.jog = end.mpos;
    if (x(end) !== 5 || Number(end.mpos.y) !== -2) return fail('jog ended off target');
    command('gcode', '$J=G91 X100 F600');
    await until('the long jog to start', (s) => s.activeState === 'Jog' && x(s) > 6, 5000);
    command('jogCancel');
    const stop = await until('the cancelled jog to stop', (s) => s.activeState === 'Idle', 5000);
    result.checks.jog_cancel_x = stop.mpos.x;
    if (!(x(stop) > 6 && x(stop) < 20)) return fail('the cancelled jog did not stop early');
  },
};

socket.on('connect', () => {
  log('connected');
  socket.emit('open', port, { baudrate: 115200, controllerType: 'Grbl' }, (err) => {
    if (err) fail('open ' + port + ': ' + err);
  });
});
socket.on('serialport:read', (line) => {
  log('<', line);
  if (/^(error|ALARM)/.test(line)) result.errors.push(line);
});
socket.on('serialport:write', (data) => log('>', JSON.stringify(data)));
socket.on('sender:status', (s) => { senderStatus = s; });
let started = false;
socket.on('controller:state', (type, state) => {
  if (type !== 'Grbl' || !state.status) return;
  status = state.status;
  // CNCjs queries `$$`, `$G` and `$#` after the banner; the first Idle status means it is ready.
  if (!started && status.activeState === 'Idle') {
    started = true;
    scenarios[scenario]().then(finish, (e) => fail(String(e)));
  }
});
setTimeout(() => fail('scenario did not finish in 10 minutes'), 600000);
