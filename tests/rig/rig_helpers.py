"""Helpers for the acquisition tests: register maps for a running virtual rig, running
`burrbench acquire`/`recover`, reading recordings with h5py, and the virtual rig's
`ramp` pattern (rig/virtual/README.md) to predict every served value exactly.
The virtual rig itself is started with virtual_helpers (owned by the virtual rig)."""
import os
import re
import socket
import subprocess

import h5py
import numpy as np

BURRBENCH = os.environ.get("BURRBENCH", "burrbench")
SOURCE_DIR = os.environ.get(
    "BURRBENCH_SOURCE_DIR", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
PRESETS = os.path.join(SOURCE_DIR, "examples", "rigs")

HEADER = 'format = "burrbench.rig"\nformat_version = "1.0"\nrig_id = "test"\n'


def preset(name, port=None, **replace):
    """Text of examples/rigs/NAME.toml with the TCP port (and any `key = value`) replaced."""
    with open(os.path.join(PRESETS, name + ".toml")) as f:
        text = f.read()
    if port is not None:
        text = text.replace("port = 5020", f"port = {port}")
    for k, v in replace.items():
        text = re.sub(rf"^(\s*){k} = .*$", rf"\g<1>{k} = {v}", text, flags=re.M)
    return text


def tcp_device(name, port, slave, start, count, rate_hz, channels, counter=None, timeout_ms=50, extra=""):
    out = (f'[[devices]]\nname = "{name}"\ntransport = "tcp"\nhost = "127.0.0.1"\nport = {port}\n'
           f"slave = {slave}\nrate_hz = {rate_hz}\ntimeout_ms = {timeout_ms}\nstart = {start}\ncount = {count}\n")
    return out + _tail(channels, counter, extra)


def rtu_device(name, pty, slave, start, count, rate_hz, channels, counter=None, timeout_ms=100, baud=115200, extra=""):
    out = (f'[[devices]]\nname = "{name}"\ntransport = "rtu"\nserial = "{pty}"\nbaud = {baud}\n'
           f"slave = {slave}\nrate_hz = {rate_hz}\ntimeout_ms = {timeout_ms}\nstart = {start}\ncount = {count}\n")
    return out + _tail(channels, counter, extra)


def _tail(channels, counter, extra):
    out = extra
    if counter is not None:
        out += f'counter = {{ register = {counter}, type = "uint32", word_order = "ABCD" }}\n'
    for c in channels:
        out += "  [[devices.channels]]\n"
        for k, v in c.items():
            out += f"  {k} = {v if not isinstance(v, str) else chr(34) + v + chr(34)}\n"
    return out


FT_CHANNELS = [
    {"name": "force_N", "unit": "N", "type": "float32", "registers": [200, 202, 204]},
    {"name": "torque_Nmm", "unit": "N*mm", "type": "float32", "registers": [206, 208, 210]},
    {"name": "force_int16_N", "unit": "N", "type": "int16", "registers": [180, 181, 182], "scale": 0.01},
]
STAGE_CHANNELS = [{"name": "position_mm", "unit": "mm", "type": "int32", "registers": [0, 2, 4], "scale": 0.001}]
SPINDLE_CHANNELS = [{"name": "spindle_rpm", "unit": "rpm", "type": "uint16", "registers": [0], "negate_if_register": 1}]
# The drive's load register (address 4): int16, 0.1 % of the rated 10 N·mm a count.
SPINDLE_LOAD_CHANNELS = SPINDLE_CHANNELS + [
    {"name": "spindle_torque_Nmm", "unit": "N*mm", "type": "int16", "registers": [4], "scale": 0.01}]
ORDERS = ["ABCD", "CDAB", "BADC", "DCBA"]
CONST_CHANNELS = (
    [{"name": f"f32_{o}", "unit": "1", "type": "float32", "word_order": o, "registers": [400 + 2 * i]}
     for i, o in enumerate(ORDERS)]
    + [{"name": f"i32_{o}", "unit": "1", "type": "int32", "word_order": o, "registers": [410 + 2 * i]}
       for i, o in enumerate(ORDERS)])


def free_port():
    """A loopback TCP port nobody listens on (for maps that must fail before connecting)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def write_map(tmp_path, body, name="rig.toml"):
    path = os.path.join(str(tmp_path), name)
    with open(path, "w") as f:
        f.write(body if 'format = "burrbench.rig"' in body else HEADER + body)
    return path


def run(args, timeout=60, **kw):
    return subprocess.run([BURRBENCH, *args], capture_output=True, text=True, timeout=timeout, **kw)


def acquire(tmp_path, rig_map, duration, out="r.h5", extra=(), timeout=60):
    out = os.path.join(str(tmp_path), out)
    p = run(["acquire", "--rig", rig_map, "--out", out, "--duration", str(duration), *extra], timeout=timeout)
    assert p.returncode == 0, p.stdout + p.stderr
    return out


def read_recording(path):
    """{stream: {dataset: array, 'channels': {name: array}}, '_events': [(t, kind, stream, detail)], '_meta': attrs}"""
    out = {}
    with h5py.File(path, "r") as f:
        for name, g in f["streams"].items():
            s = {k: g[k][()] for k in g if k != "channels"}
            s["channels"] = {k: g["channels"][k][()] for k in g["channels"]}
            out[name] = s
        ev = f["events"]
        dec = lambda a: [x.decode() if isinstance(x, bytes) else x for x in a]
        out["_events"] = list(zip(ev["t_ns"][()], dec(ev["kind"][()]), dec(ev["stream"][()]), dec(ev["detail"][()])))
        out["_meta"] = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f["meta"].attrs.items()}
        out["_meta_sets"] = {k: f["meta"][k][()] for k in f["meta"]}
    return out


def events(rec, kind, stream=None):
    return [e for e in rec["_events"] if e[1] == kind and (stream is None or e[2] == stream)]


# --- the `ramp` pattern: device sample k (j = k mod 10000) ---
def ramp_wrench(k):
    j = np.asarray(k) % 10000
    return np.stack([0.01 * j, -0.02 * j, 0.03 * j, 1.0 * j, -2.0 * j, 3.0 * j], axis=-1)


def ramp_position_um(k):
    k = np.asarray(k)
    return np.stack([k, -2 * k, 3 * k], axis=-1)


def ramp_rpm(k):
    k = np.asarray(k)
    return np.where((k // 10000) % 2 == 1, -1, 1) * ((k % 10000) + 1)


def ramp_spindle_load_Nmm(k):
    return 0.05 * (np.asarray(k) % 100)


def assert_contiguous(counter, label=""):
    """Every device sample between the first and last one read is in the recording."""
    u = np.unique(counter)
    missing = np.setdiff1d(np.arange(u[0], u[-1] + 1), u)
    assert missing.size == 0, f"{label}: {missing.size} device samples missing, first {missing[:10]}"


def assert_losses_recorded(rec, stream_name):
    """Device samples missing from a stream are allowed only inside a recorded gap event
    ("... counter A → B"): a fault may cost the samples it spans, never silently."""
    k = np.unique(rec[stream_name]["device_counter"])
    missing = np.setdiff1d(np.arange(k[0], k[-1] + 1), k)
    spans = []
    for e in events(rec, "gap", stream_name):
        m = re.search(r"counter (-?\d+) → (-?\d+)", e[3])
        if m:
            spans.append((int(m.group(1)), int(m.group(2))))
    unexplained = [c for c in missing if not any(a < c < b for a, b in spans)]
    assert not unexplained, f"{len(unexplained)} samples lost without a gap event: {unexplained[:10]}, gaps {spans}"
    return missing.size


def assert_every_served_reply_recorded(rec, served_rows, streams, given_up_ok=False):
    """Every read reply the rig wrote (its --served-log rows) is one row of the recording.

    streams: {stream name: (unit, start address)}. With a device counter, the counters
    served and recorded must be the same multiset (a repeated sample is a stale row, not
    a dropped one); without one, the numbers of replies must match. given_up_ok: a reply
    still on its way when the poll timed out was never acquired; each timeout or
    dropped-connection event may account for one such reply, no more. Nothing is ever
    recorded that the rig did not serve.
    """
    from collections import Counter
    for name, (unit, address) in streams.items():
        served = Counter(r[4] for r in served_rows if r[1] == unit and r[2] == address)
        assert served, (name, "the rig served nothing")
        s = rec[name]
        got = Counter(s["device_counter"].tolist()) if "device_counter" in s else None
        if got is None:  # no counter: compare the numbers of replies
            missing, invented = sum(served.values()) - s["t_ns"].size, 0
        else:
            missing, invented = sum((served - got).values()), sum((got - served).values())
        assert invented == 0, f"{name}: {invented} rows whose counter the rig never served"
        allowed = 0
        if given_up_ok:
            # A run of one kind is one event holding its count ("N in a row over ...").
            allowed = sum(int(m.group(1)) if (m := re.match(r"(\d+) in a row", e[3])) else 1
                          for k in ("timeout", "bad_data", "disconnected") for e in events(rec, k, name))
        assert 0 <= missing <= allowed, (
            f"{name}: {sum(served.values())} replies served, {missing} not recorded "
            f"({allowed} given up on by a recorded timeout or drop)")


def assert_ramp_exact(stream):
    """Every sample decodes to exactly what the rig served for its counter."""
    k = stream["device_counter"]
    ch = stream["channels"]
    want = ramp_wrench(k)
    # float32 registers hold the float32 nearest to the formula: compare as float32 bits.
    np.testing.assert_array_equal(ch["force_N"].astype(np.float32), want[:, :3].astype(np.float32))
    np.testing.assert_array_equal(ch["torque_Nmm"].astype(np.float32), want[:, 3:].astype(np.float32))
    if "force_int16_N" in ch:  # int16 N×100: raw j, -2j, 3j → exact to rounding of ×0.01
        np.testing.assert_array_equal(np.rint(ch["force_int16_N"] * 100).astype(np.int64),
                                      np.rint(want[:, :3] * 100).astype(np.int64))
        np.testing.assert_allclose(ch["force_int16_N"], want[:, :3], rtol=1e-12, atol=1e-12)


def assert_timestamps_honest(stream, start_ns, rate_hz, tol_ns=2_000_000):
    """A sample with counter k was taken at start + k/rate and shown until start + (k+1)/rate:
    the request that returned it must overlap that interval. A stale reply taken as fresh
    (RTU late reply) shows an older k than its send time allows."""
    k = stream["device_counter"].astype(np.float64)
    t_taken = start_ns + k * 1e9 / rate_hz
    t_replaced = start_ns + (k + 1) * 1e9 / rate_hz
    assert np.all(stream["t_send_ns"] <= stream["t_ns"]) and np.all(stream["t_ns"] <= stream["t_recv_ns"])
    early = t_taken - stream["t_recv_ns"]
    late = stream["t_send_ns"] - t_replaced
    assert early.max() <= tol_ns, f"sample from the future by {early.max() / 1e6:.2f} ms"
    assert late.max() <= tol_ns, f"stale sample accepted as fresh: {late.max() / 1e6:.2f} ms old at send time"
