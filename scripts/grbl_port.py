"""Opens a grbl board's serial port raw, soft-resets it and waits for its banner: the start that
scripts/grbl_ping.py and scripts/grbl_count.py share."""
import os
import select
import sys
import time
import tty


def open_after_reset(port):
    """The port's file descriptor, raw, after a soft reset (Ctrl-X), the `Grbl` banner and
    whatever followed it (startup lines, messages); exits if no banner comes in 5 s."""
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    os.write(fd, b"\x18")
    buf = b""
    deadline = time.time() + 5
    while b"Grbl" not in buf and time.time() < deadline:
        if select.select([fd], [], [], 0.5)[0]:
            buf += os.read(fd, 4096)
    if b"Grbl" not in buf:
        sys.exit("no banner after a soft reset")
    while select.select([fd], [], [], 0.2)[0]:
        os.read(fd, 4096)
    return fd
