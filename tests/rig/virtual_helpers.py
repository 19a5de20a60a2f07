"""Start and stop the virtual rig (rig/virtual/virtual_rig.py) from pytest.

API (import from tests in tests/rig/; pytest puts this folder on sys.path):

    with start_virtual_rig(["--pattern", "ramp"]) as (proc, host, port):
        ...   # Modbus TCP on host:port (a free loopback port unless you pass --port)
    with start_virtual_rig_rtu(["--pattern", "ramp", "--baud", "115200"]) as (proc, pty):
        ...   # Modbus RTU on the pty path (baud-paced relay in between)

`proc` is the subprocess.Popen of the rig; `proc.stderr_path` is a file holding its
stderr (fault-injection lines `EVENT <kind> t_mono_ns=<ns> ...`, see events()).
playback_start_ns(proc) is the CLOCK_MONOTONIC instant of device sample 0 (Python's
time.monotonic_ns() and C++ CLOCK_MONOTONIC share it): with a pattern, sample k of a
device was taken at playback_start_ns + k * 1e9 / rate.
With `--served-log FILE` in args, read_served_log(FILE) lists every read reply the rig
actually sent as (t_mono_ns, unit, address, count, counter) tuples.
On leaving the block the rig gets SIGTERM (then SIGKILL after 5 s) and is reaped.
The READY line must come within `timeout` seconds, else RuntimeError with stderr.
"""
import contextlib
import os
import select
import signal
import subprocess
import tempfile
import time

import h5py
import numpy as np

PYTHON = "/usr/bin/python3"
SOURCE_DIR = os.environ.get(
    "BURRBENCH_SOURCE_DIR",
    os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
RIG_SCRIPT = os.path.join(SOURCE_DIR, "rig", "virtual", "virtual_rig.py")


def _read_ready(proc, timeout):
    deadline = time.monotonic() + timeout
    buf = b""
    fd = proc.stdout.fileno()
    while b"\n" not in buf:
        left = deadline - time.monotonic()
        if left <= 0 or proc.poll() is not None:
            break
        r, _, _ = select.select([fd], [], [], min(left, 0.1))
        if r:
            chunk = os.read(fd, 4096)
            if not chunk:
                break
            buf += chunk
    line = buf.split(b"\n", 1)[0].decode(errors="replace").strip()
    if not line.startswith("READY "):
        with open(proc.stderr_path, errors="replace") as f:
            err = f.read()
        raise RuntimeError(f"virtual rig did not get ready (stdout {line!r}); stderr:\n{err}")
    return line


def stop_virtual_rig(proc, grace_s=5.0):
    """SIGTERM, wait up to grace_s, then SIGKILL. Returns the exit code."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(grace_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    proc.stdout.close()
    return proc.returncode


@contextlib.contextmanager
def _started(args, timeout):
    err = tempfile.NamedTemporaryFile(prefix="virtual-rig-", suffix=".stderr", delete=False)
    proc = subprocess.Popen([PYTHON, RIG_SCRIPT, *args], stdout=subprocess.PIPE, stderr=err,
                            stdin=subprocess.DEVNULL)
    err.close()
    proc.stderr_path = err.name
    try:
        line = _read_ready(proc, timeout)
        yield proc, line
    finally:
        stop_virtual_rig(proc)
        os.unlink(err.name)


@contextlib.contextmanager
def start_virtual_rig(args, timeout=10.0):
    """TCP rig; yields (proc, host, port). Adds --port 0 unless args set --port."""
    args = list(args)
    if "--port" not in args:
        args += ["--port", "0"]
    with _started(args, timeout) as (proc, line):
        kind, where = line.split()[1:3]
        assert kind == "tcp", line
        host, port = where.rsplit(":", 1)
        yield proc, host, int(port)


@contextlib.contextmanager
def start_virtual_rig_rtu(args, timeout=10.0):
    """RTU rig on a pty pair through the baud-paced relay; yields (proc, pty_path)."""
    args = list(args)
    if "--rtu" not in args:
        args.append("--rtu")
    with _started(args, timeout) as (proc, line):
        kind, where = line.split()[1:3]
        assert kind == "rtu", line
        yield proc, where


def events(proc, kind=None):
    """Fault events logged so far: list of dicts {kind, t_mono_ns, ...}."""
    out = []
    with open(proc.stderr_path, errors="replace") as f:
        for ln in f:
            parts = ln.split()
            if len(parts) < 2 or parts[0] != "EVENT":
                continue
            ev = {"kind": parts[1]}
            for p in parts[2:]:
                k, _, v = p.partition("=")
                ev[k] = int(v) if v.lstrip("-").isdigit() else v
            if kind is None or ev["kind"] == kind:
                out.append(ev)
    return out


def playback_start_ns(proc):
    """CLOCK_MONOTONIC ns of sample 0 (from the rig's `EVENT start` line)."""
    return events(proc, "start")[0]["playback_start_ns"]


def read_served_log(path):
    """Rows of a --served-log file: (t_mono_ns, unit, address, count, counter)."""
    with open(path) as f:
        lines = f.read().splitlines()
    if not lines or lines[0] != "t_mono_ns,unit,address,count,counter":
        raise ValueError(f"{path}: not a virtual rig served log")
    return [tuple(int(x) for x in ln.split(",")) for ln in lines[1:] if ln]


T0_NS = 5_000_000_000  # recordings use host monotonic time: anything but zero


def write_recording(path, ft_hz=200.0, stage_hz=100.0, spindle_hz=50.0, duration_s=1.0,
                    stage_lag_s=0.1):
    """A small recording in the docs/formats.md layout: /streams/<name>/{t_ns, channels/<ch>}."""
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "burrbench.recording"
        f.attrs["format_version"] = "1.0"
        s = f.create_group("streams")
        n = int(duration_s * ft_hz)
        g = s.create_group("ft_sensor")
        g["t_ns"] = T0_NS + np.round(np.arange(n) * 1e9 / ft_hz).astype(np.int64)
        i = np.arange(n, dtype=np.float64)
        g.create_group("channels")
        g["channels/force_N"] = np.stack([0.25 * i, -0.5 * i, 1.0 + i], axis=1)
        g["channels/torque_Nmm"] = np.stack([10.0 * i, -i, 2.0 * i], axis=1)
        m = int((duration_s - stage_lag_s) * stage_hz)
        g = s.create_group("stage")
        g["t_ns"] = T0_NS + int(stage_lag_s * 1e9) + np.round(np.arange(m) * 1e9 / stage_hz).astype(np.int64)
        j = np.arange(m, dtype=np.float64)
        g.create_group("channels")
        g["channels/position_mm"] = np.stack([0.001 * j, 2.0 - 0.002 * j, -0.5 * j], axis=1)
        q = int(duration_s * spindle_hz)
        g = s.create_group("spindle")
        g["t_ns"] = T0_NS + np.round(np.arange(q) * 1e9 / spindle_hz).astype(np.int64)
        g.create_group("channels")
        g["channels/spindle_rpm"] = -(1000.0 + 10.0 * np.arange(q))
    return {"ft": (n, ft_hz), "stage": (m, stage_hz), "spindle": (q, spindle_hz)}
