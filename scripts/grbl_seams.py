"""The grbl seams, driven by pygrbl-streamer (a grbl client from PyPI, used as-is) against
`gantry emulate --pty` (scripts/grbl-sender-test.sh runs it). Modes:
  error PORT      an error line mid-job with spindle and flood on: the error line gets its
                  error, the moves after it run with the spindle and flood on (every status
                  polled while they run says A:SF), the job ends at X10 Y1, and $G says M3 M8.
  stream PORT     streams a long cut with spindle and flood on and never returns (the caller
                  kills this process with SIGKILL mid-job).
  after-kill PORT the next client after a killed sender: it is greeted with the banner, the
                  machine stands Idle with spindle and coolant off (no A:) and does not move.
  answers PORT    M98 answered once (error:20) and the sender goes on; $C over arcs and G91
                  moves from the program's position (no false error, the travel caught); $110
                  below the start speed refused and unchanged; 20 queued $J= jogs smooth and
                  within 0.8 s, and one jog cancel stops a stream of them.
Prints one line per check; exit status 0 when every check passed.
"""
import re
import sys
import threading
import time

from pygrbl_streamer import GrblStreamer

mode, port = sys.argv[1], sys.argv[2]
seen = []
lock = threading.Lock()


class Recording(GrblStreamer):
    def receive_callback(self, data):
        with lock:
            seen.append(data)


def mpos(status):
    m = re.search(r"MPos:([-\d.]+),([-\d.]+),([-\d.]+)", status)
    return tuple(float(v) for v in m.groups()) if m else None


def poll_status(g, wait=0.3):
    g.realtime(b"?")
    time.sleep(wait)
    return g.last_status.get("raw", "")


failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


if mode == "error":
    g = Recording(port, rx_buffer_size=128)
    g.connect(reset=True)
    time.sleep(0.3)
    statuses = []
    done = threading.Event()

    def poller():
        while not done.is_set():
            g.realtime(b"?")
            time.sleep(0.05)
            s = g.last_status.get("raw", "")
            if s:
                statuses.append(s)

    t = threading.Thread(target=poller, daemon=True)
    t.start()
    lines = ["G21 G90", "M3 S5000 M8", "G1 X1 F300", "G1 X11 Q1", "G1 X4", "G1 X7 Y1", "G1 X10"]
    ok = g.stream(lines, stop_on_error=False, wait_for_idle=True, ack_timeout=30)
    done.set()
    t.join()
    with lock:
        answers = [l for l in seen if l == "ok" or l.startswith("error")]
    check(answers[-7:] == ["ok", "ok", "ok", "error:36", "ok", "ok", "ok"], f"answers {answers[-7:]}")
    # grbl reports the accessories (A:) with the overrides (Ov:), in every few reports.
    moving_after = [s for s in statuses if s.startswith("<Run") and (mpos(s) or (0,))[0] > 1.05]
    with_accessories = [s for s in moving_after if "|Ov:" in s]
    check(len(with_accessories) >= 2,
          f"{len(moving_after)} statuses while cutting after the error, {len(with_accessories)} with Ov/A")
    bad = [s for s in with_accessories if "|A:SF" not in s]
    check(not bad, f"spindle and flood on in every one of them {bad[:2]}")
    with lock:
        seen.clear()
    g.command("$G")
    time.sleep(0.2)
    with lock:
        modes = next((l for l in seen if l.startswith("[GC:")), "")
    check(" M3 " in modes and " M8" in modes, f"$G agrees: {modes}")
    for _ in range(30):
        final = poll_status(g, 0.05)
        if "|Ov:" in final:
            break
    check(mpos(final) == (10.0, 1.0, 0.0) and "|A:SF" in final, f"ends at X10 Y1 with A:SF: {final}")
    g.command("M5 M9")
    g.disconnect()
elif mode == "stream":
    g = Recording(port, rx_buffer_size=128)
    g.connect(reset=True)
    lines = ["G21 G90", "M3 S5000 M8"] + [f"G1 X{i} F300" for i in range(1, 101)]
    print("streaming", flush=True)
    g.stream(lines, stop_on_error=False, wait_for_idle=True, ack_timeout=300)
    time.sleep(600)
elif mode == "after-kill":
    g = Recording(port, rx_buffer_size=128)
    t0 = time.time()
    g.connect(reset=False)
    greeted = time.time() - t0
    with lock:
        banner = [l for l in seen if l.startswith("Grbl 1.1")]
    check(len(banner) == 1, f"greeted once with the banner in {greeted:.2f} s: {banner}")
    for _ in range(30):
        first = poll_status(g, 0.05)
        if "|Ov:" in first:
            break
    time.sleep(2.0)
    second = poll_status(g)
    check(first.startswith("<Idle") and "|A:" not in first, f"Idle, spindle and coolant off: {first}")
    p = mpos(first)
    check(p is not None and 0.0 < p[0] < 100.0, f"stopped on the path, not at the end: {p}")
    check(mpos(second) == p, f"no motion after the sender left: {p} -> {mpos(second)}")
    g.disconnect()
elif mode == "answers":
    g = Recording(port, rx_buffer_size=128)
    g.connect(reset=True)
    time.sleep(0.3)

    def answers_of(lines, timeout=20, idle=True):
        with lock:
            seen.clear()
        ok = g.stream(lines, stop_on_error=False, wait_for_idle=idle, ack_timeout=timeout)
        time.sleep(0.2)
        with lock:
            return ok, [l for l in seen if l == "ok" or l.startswith("error")], list(seen)

    ok, ans, raw = answers_of(["G21 G90", "M98 P100", "G0 X1"])
    msgs = [l for l in raw if l.startswith("[MSG")]
    check(ans == ["ok", "error:20", "ok"] and not msgs, f"M98: {ans} {msgs}")
    st = poll_status(g)
    check(st.startswith("<Idle") and mpos(st)[0] == 1.0, f"usable after M98: {st}")
    # Check mode: an arc valid from the program's own position, G91 moves adding up past the
    # travel (X travels to +300 mm).
    g.command("$C")
    time.sleep(0.2)
    ok, ans, raw = answers_of(
        ["G90 G0 X10 Y10", "G2 X20 Y10 I5 J0 F300", "G91 G1 X200", "G1 X200", "G90 G0 X0 Y0"],
        idle=False)  # (grbl reports Check, never Idle, in check mode)
    check(ans == ["ok", "ok", "ok", "error:900", "ok"], f"$C: {ans}")
    with lock:
        seen.clear()
    g.command("$C")
    time.sleep(0.5)
    with lock:
        banners = [l for l in seen if l.startswith("Grbl 1.1")]
    check(len(banners) == 1, f"$C off soft-resets: {banners}")
    # $110 below the start speed (60 mm/min): refused, unchanged.
    with lock:
        seen.clear()
    refused = g.command("$110=10")
    time.sleep(0.2)
    with lock:
        reply = [l for l in seen if l.startswith("error") or l.startswith("[MSG")]
        seen.clear()
    g.command("$$")
    time.sleep(0.3)
    with lock:
        s110 = [l for l in seen if l.startswith("$110=")]
    check(not refused and any(l.startswith("error:") for l in reply) and s110 == ["$110=3000.000"],
          f"$110=10: {reply} {s110}")
    # 20 jogs of 0.5 mm back to back: one smooth move.
    st0 = mpos(poll_status(g, 0.1))
    t0 = time.time()
    # Character counting (the sender keeps the 128-byte RX buffer full), as a jog wheel does.
    jogger = threading.Thread(
        target=lambda: g.stream(["$J=G91 X0.5 F1500"] * 20, wait_for_idle=False, ack_timeout=10),
        daemon=True)
    jogger.start()
    deadline = time.time() + 5
    moved = None
    while time.time() < deadline:
        st = poll_status(g, 0.02)
        if st.startswith("<Idle") and mpos(st) and mpos(st)[0] >= st0[0] + 9.999:
            moved = time.time() - t0
            break
    check(moved is not None and moved <= 0.8, f"20 jogs of 0.5 mm: X {st0[0]} -> {mpos(st)}, {moved} s")
    # A stream of jogs, one cancel: everything stops.
    jogger.join()
    jogger = threading.Thread(
        target=lambda: g.stream(["$J=G91 X5 F1500"] * 6, wait_for_idle=False, ack_timeout=10),
        daemon=True)
    jogger.start()
    time.sleep(0.3)
    g.realtime(b"\x85")
    time.sleep(1.0)
    a = mpos(poll_status(g, 0.1))
    time.sleep(1.0)
    b = mpos(poll_status(g, 0.1))
    jogger.join()
    check(a == b and a[0] < st0[0] + 10 + 30 - 5, f"one cancel stops them all: {a} {b}")
    g.disconnect()
sys.exit(1 if failures else 0)
