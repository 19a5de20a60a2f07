#!/usr/bin/python3
"""Relay between two ttys that paces bytes like an RS-485 line at a given baud rate.

    /usr/bin/python3 pty_relay.py CLIENT_SIDE_TTY SERVER_SIDE_TTY BAUD

RS-485 is half duplex: both directions share one wire, so every byte (in either
direction) occupies 10 bit times (8N1: start + 8 data + stop) of that one wire
and is delivered when its last bit would arrive. A separate process so that
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
    pending = []            # [due_time, out_fd, byte] in wire order
    other = {fd_a: fd_b, fd_b: fd_a}
    while True:
        now = time.monotonic()
        # Deliver every byte whose last bit has arrived, grouped per destination.
        n = 0
        while n < len(pending) and pending[n][0] <= now:
            n += 1
        if n:
            i = 0
            while i < n:
                out = pending[i][1]
                j = i
                while j < n and pending[j][1] == out:
                    j += 1
                chunk = bytes(p[2] for p in pending[i:j])
                try:
                    os.write(out, chunk)
                except BlockingIOError:
                    pass  # nobody reads that side: a real line would lose it too
                i = j
            del pending[:n]
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
            out = other[fd]
            for b in data:
                wire_free = max(wire_free, now) + byte_s
                pending.append((wire_free, out, b))


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
