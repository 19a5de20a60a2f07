"""A simulated RS-485 line: two socat pty pairs joined by the baud-pacing relay.

    client (libmodbus) -> DIR/client ==socat== DIR/relay_client
                                                   | pty_relay.py (paces bytes)
    pymodbus server    -> DIR/server ==socat== DIR/relay_server

socat keeps each pair alive when one end is closed and reopened, so a client may
close and reopen DIR/client (libmodbus does on errors) without ending the line.
"""
import os
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def _die_with_parent():
    """Children get SIGTERM if the rig dies (even by SIGKILL): no orphaned socat."""
    import ctypes
    import signal
    PR_SET_PDEATHSIG = 1
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def _pty_pair(a, b):
    return subprocess.Popen(
        ["socat", f"PTY,raw,echo=0,link={a}", f"PTY,raw,echo=0,link={b}"],
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        preexec_fn=_die_with_parent)


def _wait_for(paths, procs, timeout=5.0):
    deadline = time.monotonic() + timeout
    while not all(os.path.exists(p) for p in paths):
        if time.monotonic() > deadline or any(p.poll() is not None for p in procs):
            raise OSError(f"socat did not create {', '.join(paths)}")
        time.sleep(0.01)


class RtuLink:
    def __init__(self, baud):
        self.baud = baud
        self.dir = tempfile.mkdtemp(prefix="burrbench-rtu-")
        self.client_path = os.path.join(self.dir, "client")
        self.server_path = os.path.join(self.dir, "server")
        self._relay_client = os.path.join(self.dir, "relay_client")
        self._relay_server = os.path.join(self.dir, "relay_server")
        self._procs = []

    def start(self):
        if shutil.which("socat") is None:
            raise OSError("socat not found (Debian package socat)")
        self._procs.append(_pty_pair(self.client_path, self._relay_client))
        self._procs.append(_pty_pair(self.server_path, self._relay_server))
        _wait_for([self.client_path, self._relay_client, self.server_path, self._relay_server],
                  self._procs)
        relay = subprocess.Popen(
            [sys.executable, os.path.join(HERE, "pty_relay.py"), self._relay_client,
             self._relay_server, str(self.baud)],
            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, preexec_fn=_die_with_parent)
        self._procs.append(relay)
        line = relay.stdout.readline()
        if not line.startswith(b"RELAY ready"):
            raise OSError("the pty relay did not start")

    def stop(self):
        for p in reversed(self._procs):
            if p.poll() is None:
                p.terminate()
        for p in self._procs:
            try:
                p.wait(2)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
            if p.stdout:
                p.stdout.close()
        self._procs = []
        shutil.rmtree(self.dir, ignore_errors=True)
