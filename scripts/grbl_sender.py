"""Drives pygrbl-streamer (a grbl streaming client from PyPI, used as-is) against a port:
soft reset and banner, $X, then the program by grbl's character-counting method against the
RX size the board advertises in $I. The port is a device path or, for `gantry emulate --tcp`,
`socket://HOST:PORT` (pyserial's URL handler in place of its serial class: the streamer itself
is unchanged). With `pauses`, the sender's own pause/resume (`!`, then `~`) is pressed three
times on the way, each after the machine stood in `Hold:0` for half a second. Prints one
summary line:
  lines L acks A errors E state S status <...>
"""
import sys
import threading
import time
import types

import serial
import pygrbl_streamer.streamer as streamer_module
from pygrbl_streamer import GrblStreamer

port, program = sys.argv[1], sys.argv[2]
extra = sys.argv[3:]
pauses = "pauses" in extra
rx = next((int(a) for a in extra if a.isdigit()), 128)

if port.startswith("socket://"):
    from serial.urlhandler.protocol_socket import Serial as SocketSerial

    shim = types.SimpleNamespace(**{k: getattr(serial, k) for k in dir(serial) if not k.startswith("__")})
    shim.Serial = SocketSerial
    streamer_module.serial = shim

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
held = []


def fresh_status(state, limit=10):
    """The MPos of the first status report asked for from now on that starts with `state`."""
    t0 = time.time()
    while time.time() - t0 < limit:
        asked = time.time()
        g.realtime(b"?")
        time.sleep(0.05)
        st = g.last_status
        if st.get("time", 0) >= asked and str(st.get("raw", "")).startswith(state):
            return st["raw"].split("|")[1]
    return None


def press_pauses():
    for at in (0.2, 0.5, 0.8):
        while True:
            with lock:
                if acks >= at * len(lines):
                    break
            time.sleep(0.01)
        g.pause()
        held.append((fresh_status("<Hold:0"), None))
        time.sleep(0.5)
        held[-1] = (held[-1][0], fresh_status("<Hold:0"))
        g.resume()


if pauses:
    threading.Thread(target=press_pauses, daemon=True).start()
t0 = time.time()
ok = g.stream(lines, stop_on_error=False, wait_for_idle=True, ack_timeout=30, completion_timeout=600)
elapsed = time.time() - t0
time.sleep(0.3)
g.realtime(b"?")
time.sleep(0.3)
status = g.last_status.get("raw", "")
g.disconnect()
still = all(a is not None and a == b for a, b in held)
with lock:
    print(f"lines {len(lines)} acks {acks} errors {len(errors)} ok {ok} wall {elapsed:.1f}s "
          f"pauses {len(held)} still {still} status {status} held {held}")
sys.exit(0 if ok and acks == len(lines) and not errors and (not pauses or (len(held) == 3 and still)) else 1)
