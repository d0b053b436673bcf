"""Drives pygrbl-streamer (a grbl streaming client from PyPI, used as-is) against a port:
soft reset and banner, $X, then the program by grbl's character-counting method against the
RX size the board advertises in $I. Prints one summary line:
  lines L acks A errors E state S status <...>
"""
import sys
import threading
import time

from pygrbl_streamer import GrblStreamer

port, program = sys.argv[1], sys.argv[2]
rx = int(sys.argv[3]) if len(sys.argv) > 3 else 128

acks = 0
errors = []
lock = threading.Lock()


class Counting(GrblStreamer):
    def receive_callback(self, data):
        global acks
        with lock:
            if data == "ok":
                acks += 1
            elif data.startswith("error"):
                acks += 1
                errors.append(data)


g = Counting(port, rx_buffer_size=rx)
g.connect(reset=True)
time.sleep(0.5)  # callbacks run on their own thread: let connect()'s $X answer arrive first
with lock:
    acks = 0  # the $X of connect() is not part of the program
    errors.clear()
lines = [l.strip() for l in open(program) if l.strip()]
t0 = time.time()
ok = g.stream(lines, stop_on_error=False, wait_for_idle=True, ack_timeout=30, completion_timeout=600)
elapsed = time.time() - t0
time.sleep(0.3)
g.realtime(b"?")
time.sleep(0.3)
status = g.last_status.get("raw", "")
g.disconnect()
with lock:
    print(f"lines {len(lines)} acks {acks} errors {len(errors)} ok {ok} wall {elapsed:.1f}s status {status}")
sys.exit(0 if ok and acks == len(lines) and not errors else 1)
