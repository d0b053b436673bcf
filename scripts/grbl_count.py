"""A minimal grbl character-counting sender for scripts/bench-laser.sh: one thread, select(2) on
the port, at most RX bytes (default 127, grbl's 128-byte ring less one as senders keep it) of
unanswered lines in flight. It measures what pygrbl-streamer's three threads (reader, callbacks,
streamer) cannot show apart: the round trip from a line's write to its `ok`, which bounds a
counting sender's line rate at RX bytes per round trip. Soft reset and banner first.

Usage: grbl_count.py PORT PROGRAM [RX]
Prints: lines L acks A errors E wall W s rate R lines/s ok round trip p50/p90/p99 ms
"""
import os
import select
import sys
import time

from grbl_port import open_after_reset

port, program = sys.argv[1], sys.argv[2]
rx = int(sys.argv[3]) if len(sys.argv) > 3 else 127
fd = open_after_reset(port)
lines = [l.strip() for l in open(program) if l.strip()]
pending = []  # (bytes, time written) of unanswered lines, oldest first
in_flight = 0
sent = acks = 0
errors = []
rtts = []
buf = b""
t0 = time.time()
while acks < len(lines):
    while sent < len(lines) and in_flight + len(lines[sent]) + 1 <= rx:
        data = (lines[sent] + "\n").encode()
        os.write(fd, data)
        pending.append((len(data), time.perf_counter()))
        in_flight += len(data)
        sent += 1
    if not select.select([fd], [], [], 10)[0]:
        sys.exit(f"no answer for 10 s after {acks} of {len(lines)} lines")
    buf += os.read(fd, 4096)
    now = time.perf_counter()
    while b"\n" in buf:
        line, buf = buf.split(b"\n", 1)
        line = line.strip()
        if line == b"ok" or line.startswith(b"error"):
            n, at = pending.pop(0)
            in_flight -= n
            acks += 1
            rtts.append(now - at)
            if line != b"ok":
                errors.append(line.decode())
wall = time.time() - t0
rtts.sort()


def pct(p):
    return rtts[min(len(rtts) - 1, len(rtts) * p // 100)] * 1e3


print(f"lines {len(lines)} acks {acks} errors {len(errors)} wall {wall:.3f} s rate {acks / wall:.0f} lines/s "
      f"ok round trip p50 {pct(50):.2f} p90 {pct(90):.2f} p99 {pct(99):.2f} ms")
sys.exit(1 if errors else 0)
