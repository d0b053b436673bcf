"""Drives bCNC (from PyPI, used as-is) through its web pendant against `gantry emulate --pty`.

bCNC opens its port at start (`openserial` in the ini the caller wrote to $HOME/.bCNC); that port
is a pty of this script's own, relayed byte for byte to the emulated board's pty, so every byte
bCNC writes and every answer the board gives is counted on the way (the relay adds no bytes and
takes none: bCNC's own counting of the board's 128-byte buffer is what paces the job). Then,
through the pendant's HTTP endpoints only (bCNC's Pendant.py: `/send?cmd=RUN`, `/send?cmd=PAUSE`,
which holds when running and resumes when held, `/state`): the loaded job is run, paused three
times on the way (each pause waits for grbl's `Hold:0` and checks the machine stands still for
half a second in it) and resumed, and the job is followed to its end and bCNC's purge after it.

Usage: bcnc_drive.py BOARD_PTY BCNC_PTY PENDANT_PORT PROGRAM -- BCNC_COMMAND...
Prints one summary line and exits 0 only if every line bCNC wrote was answered exactly once with
`ok`, every program line was written exactly once and in order, and the three pauses held still.
Every wait has a deadline; bCNC is terminated at exit.
"""
import json
import os
import re
import select
import signal
import subprocess
import sys
import threading
import time
import tty
import urllib.request

board_pty, bcnc_pty, pendant_port, program = sys.argv[1:5]
command = sys.argv[sys.argv.index("--") + 1:]
REALTIME = set(b"?!~\x18") | set(range(0x80, 0x100))

lock = threading.Lock()
written = []  # complete lines bCNC wrote, in order
answers = []  # ok / error:N lines from the board, in order
statuses = []  # (time, status report)
other = []  # other lines from the board (banner, messages)
stop_relay = threading.Event()
relay_thread = None


def relay(master, board):
    """Copies bytes both ways, splitting bCNC's lines (realtime bytes apart) and the board's."""
    up = bytearray()
    down = bytearray()
    prev = 0
    while not stop_relay.is_set():
        r, _, _ = select.select([master, board], [], [], 0.05)
        if master in r:
            try:
                data = os.read(master, 4096)
            except OSError:
                data = b""  # bCNC has not opened its side yet, or closed it
            if not data:
                time.sleep(0.01)
            else:
                try:
                    os.write(board, data)
                except OSError as e:
                    with lock:
                        other.append(f"relay: write to the board failed after {len(written)} lines: {e}")
                    return
                for b in data:
                    if b in REALTIME:
                        continue
                    # A line ends at `\n` or `\r`, the `\n` of a `\r\n` pair ending nothing
                    # (grbl's rule): an empty line is a line grbl answers too.
                    if b == 0x0A and prev == 0x0D:
                        prev = b
                        continue
                    prev = b
                    if b in b"\r\n":
                        with lock:
                            written.append(up.decode(errors="replace").strip())
                        up.clear()
                    else:
                        up.append(b)
        if board in r:
            try:
                data = os.read(board, 4096)
            except OSError as e:
                with lock:
                    other.append(f"relay: read from the board failed: {e}")
                return
            try:
                os.write(master, data)
            except OSError:
                pass
            down += data
            while b"\n" in down:
                line, _, rest = down.partition(b"\n")
                down = bytearray(rest)
                text = line.decode(errors="replace").strip()
                with lock:
                    if text == "ok" or text.startswith("error"):
                        answers.append(text)
                    elif text.startswith("<"):
                        statuses.append((time.time(), text))
                    elif text:
                        other.append(text)


def http(path):
    with urllib.request.urlopen(f"http://127.0.0.1:{pendant_port}{path}", timeout=5) as r:
        return r.read().decode()


def wait(what, cond, limit):
    deadline = time.time() + limit
    while time.time() < deadline:
        if not relay_thread.is_alive():
            raise RuntimeError(f"the relay stopped while waiting for {what}: {other[-3:]}")
        try:
            if cond():
                return
        except OSError:
            pass
        time.sleep(0.05)
    raise TimeoutError(f"{what} not within {limit} s")


def status_since(t0, prefix):
    with lock:
        for t, s in statuses:
            if t >= t0 and s.startswith(prefix):
                return s
    return None


def mpos(s):
    m = re.search(r"MPos:([-0-9.,]+)", s)
    return m.group(1) if m else None


def main():
    # A SIGTERM (the caller's timeout) still ends bCNC and writes the trace.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(3))
    master, slave = os.openpty()
    tty.setraw(slave)
    if os.path.lexists(bcnc_pty):
        os.remove(bcnc_pty)
    os.symlink(os.ttyname(slave), bcnc_pty)
    board = os.open(board_pty, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(board)
    global relay_thread
    relay_thread = threading.Thread(target=relay, args=(master, board), daemon=True)
    relay_thread.start()
    prog = [l.strip() for l in open(program) if l.strip()]
    bcnc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=open(os.environ.get("BCNC_LOG", os.devnull), "w"),
                            start_new_session=True)
    held = []
    try:
        # bCNC up: its pendant answers, and it has talked to the board (banner, Idle status).
        wait("bCNC's pendant", lambda: json.loads(http("/state")) is not None, 60)
        wait("the board's banner and Idle via bCNC", lambda: status_since(0, "<Idle") is not None, 60)
        time.sleep(1.5)  # bCNC's open() sleeps 2 s and then sends its init; let that settle
        with lock:
            start = len(written)
            answered_before = len(answers)
        http("/send?cmd=RUN")

        def acked():
            with lock:
                return len(answers) - answered_before

        for at in (0.2, 0.5, 0.8):
            wait(f"{int(at * 100)} % of the job answered", lambda: acked() >= at * len(prog), 300)
            t0 = time.time()
            http("/send?cmd=PAUSE")
            wait("Hold:0 after the pendant's pause", lambda: status_since(t0, "<Hold:0") is not None, 30)
            first = status_since(t0, "<Hold:0")
            t1 = time.time() + 0.5
            wait("a status report 0.5 s into the hold", lambda: status_since(t1, "<") is not None, 10)
            later = status_since(t1, "<")
            held.append((mpos(first), mpos(later), later.split("|")[0]))
            t2 = time.time()
            http("/send?cmd=PAUSE")
            wait("Run after the pendant's resume", lambda: status_since(t2, "<Run") is not None
                 or status_since(t2, "<Idle") is not None, 30)

        def done():
            with lock:
                lines = written[start:]
                return len(lines) >= len(prog) and len(answers) == len(written)

        # Progress or a deadline: no new answer for 60 s ends the wait.
        last = (-1, 0.0)
        while not done():
            n = acked()
            if n != last[0]:
                last = (n, time.time())
            elif time.time() - last[1] > 60:
                raise TimeoutError(f"no answer for 60 s after {n} answers of the job")
            wait("the next answer", lambda: done() or acked() != n, 61)
        t3 = time.time()
        wait("Idle at the job's end", lambda: status_since(t3, "<Idle") is not None, 120)
        # bCNC's purge after a job (feed hold, soft reset, its $G restored): answered too.
        time.sleep(3)
        wait("bCNC's lines after the job answered", lambda: len(answers) == len(written), 30)
        final = status_since(time.time() - 1, "<") or statuses[-1][1]
    finally:
        try:
            os.killpg(bcnc.pid, signal.SIGTERM)
            bcnc.wait(timeout=10)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            os.killpg(bcnc.pid, signal.SIGKILL)
        stop_relay.set()
        if os.environ.get("BCNC_TRACE"):
            with lock, open(os.environ["BCNC_TRACE"], "w") as f:
                json.dump({"written": written, "answers": answers, "other": other,
                           "statuses": statuses[-50:]}, f, indent=0)
    with lock:
        job = written[start:]
        # The program lines as bCNC wrote them, in order (bCNC adds its own lines around them:
        # its purge's soft reset and restored modes, `$G` polls).
        # bCNC rewrites each line's words in its own format (`G1 X16.00` goes as `G1X16`): a
        # line is compared word by word, by value.
        def words(line):
            return tuple((c, float(v)) for c, v in re.findall(r"([A-Z])\s*([-+]?[0-9]*\.?[0-9]+)", line.upper()))

        progset = [words(l) for l in prog]
        sent = [words(l) for l in job]
        i = 0
        for l in sent:
            if i < len(progset) and l == progset[i]:
                i += 1
        in_order = i == len(progset)
        once = all(sent.count(l) <= progset.count(l) for l in set(progset))
        errors = [a for a in answers if a != "ok"]
        still = len(held) == 3 and all(a is not None and a == b and s.startswith("<Hold:0") for a, b, s in held)
        print(f"written {len(written)} answered {len(answers)} errors {len(errors)} {errors[:3]} "
              f"program {len(prog)} in_order {in_order} once {once} pauses {len(held)} still {still} "
              f"final {final} held {held}")
        ok = len(answers) == len(written) and not errors and in_order and once and still
    sys.exit(0 if ok else 1)


main()
