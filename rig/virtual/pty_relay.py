#!/usr/bin/python3
"""Relay between two ttys that paces bytes like an RS-485 line at a given baud rate.

    /usr/bin/python3 pty_relay.py CLIENT_SIDE_TTY SERVER_SIDE_TTY BAUD

RS-485 is half duplex: both directions share one wire, so every byte (in either
direction) occupies 10 bit times (8N1: start + 8 data + stop) of that one wire.
Each chunk one side writes is delivered whole when its last bit would arrive. A separate process so that
pacing is not disturbed by the Modbus server holding the GIL.
"""
import os
import select
import signal
import sys
import termios
import time
import tty


def open_raw(path):
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    tty.setraw(fd, termios.TCSANOW)
    return fd


def relay(fd_a, fd_b, baud):
    byte_s = 10.0 / baud
    wire_free = 0.0         # when the wire finishes the last queued byte
    pending = []            # [due_time, out_fd, chunk] in wire order
    other = {fd_a: fd_b, fd_b: fd_a}
    while True:
        now = time.monotonic()
        while pending and pending[0][0] <= now:
            _, out, chunk = pending.pop(0)
            try:
                os.write(out, chunk)
            except (BlockingIOError, OSError):
                pass  # nobody reads that side: a real line would lose it too
        timeout = None if not pending else max(0.0, pending[0][0] - time.monotonic())
        ready, _, _ = select.select([fd_a, fd_b], [], [], timeout)
        now = time.monotonic()
        for fd in ready:
            try:
                data = os.read(fd, 4096)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                data = b""  # EIO: the other end of the pty was closed; wait for a new one
            if not data:
                time.sleep(0.01)
                continue
            # What one side wrote at once (a frame, as a rule) is delivered whole when
            # its last byte would have arrived: one wake-up per frame instead of one
            # per byte keeps the pacing exact on a busy machine.
            wire_free = max(wire_free, now) + len(data) * byte_s
            pending.append((wire_free, other[fd], data))


def main():
    if len(sys.argv) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    signal.signal(signal.SIGTERM, lambda *_: os._exit(0))
    fd_a = open_raw(sys.argv[1])
    fd_b = open_raw(sys.argv[2])
    print("RELAY ready", flush=True)
    try:
        relay(fd_a, fd_b, int(sys.argv[3]))
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
