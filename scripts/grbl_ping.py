"""The board's share of a grbl `ok` round trip, for scripts/bench-laser.sh: one line at a time
(nothing else in flight, so no planner or line buffer is in the way), the time from its write to
its `ok`. An empty line is answered by the grbl front end without the interpreter
(machine/src/grbl/mod.rs `read_lines`), a `G4 P0` is interpreted first (a sync point at rest):
with the board idle, what remains is the host's share and the wait for the pass that reads the
line (docs/laser-plasma.md "Raster speed").

Usage: grbl_ping.py PORT [COUNT]
Prints: ping N lines: empty p50/p90 ms, G4 P0 p50/p90 ms
"""
import os
import select
import sys
import time

from grbl_port import open_after_reset

port = sys.argv[1]
count = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
fd = open_after_reset(port)


def ping(line):
    rtts = []
    for _ in range(count):
        at = time.perf_counter()
        os.write(fd, line)
        got = b""
        while b"ok\r\n" not in got:
            if not select.select([fd], [], [], 5)[0]:
                sys.exit(f"no answer to {line!r}")
            got += os.read(fd, 4096)
        if b"error" in got:
            sys.exit(f"{line!r}: {got!r}")
        rtts.append(time.perf_counter() - at)
    rtts.sort()
    return rtts[len(rtts) // 2] * 1e3, rtts[len(rtts) * 9 // 10] * 1e3


e = ping(b"\n")
g = ping(b"G4 P0\n")
print(f"ping {count} lines: empty p50 {e[0]:.2f} p90 {e[1]:.2f} ms, G4 P0 p50 {g[0]:.2f} p90 {g[1]:.2f} ms")
