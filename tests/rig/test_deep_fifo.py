"""Issue 11, fault 7: a FIFO deeper than one Modbus request, read in several blocks per
poll, loses nothing through host stalls that an 8-deep FIFO cannot survive. The stalls
are real: the acquiring process is stopped (SIGSTOP) for 60 ms at a time."""
# ctest: load (issue 59: its promises hold beside two busy processes; make test-loaded)
# ctest: run serial (a loaded neighbour's scheduling delay adds to the stall)
import os
import signal
import subprocess
import threading
import time

import numpy as np

import rig_helpers as rh
from bad_input import assert_refused
from virtual_helpers import playback_start_ns, start_virtual_rig

STALL_S = 0.060
# The device samples at 500 Hz: the 96-record FIFO spans 192 ms, the 8-record one 16 ms.
# At 1 kHz (96 ms) a 60 ms stall left too little for the rest of a poll on this VM: the
# time to read the 12 blocks after the stall (the oldest records come last, ~1.5 ms a
# request on a busy host) and the VM's own freezes of tens of ms (docs/rig.md). It lost
# records in 1 of 8 runs beside one busy process, 3 of 6 beside two, and 1 of 5 clean-clone
# CI runs (alone).
RATE_HZ = 500


def fifo_map(tmp_path, name, port, out):
    text = rh.preset(name, port)
    assert text.count("device_rate_hz = 1000") == 2, f"{name}: its FIFOs no longer say device_rate_hz = 1000"
    return rh.write_map(tmp_path, text.replace("device_rate_hz = 1000", f"device_rate_hz = {RATE_HZ}"), out)


def acquire_with_stalls(tmp_path, rig_map, duration_s, stalls, out):
    """Runs acquire for duration_s and stops it for STALL_S at each time in stalls (s)."""
    out = os.path.join(str(tmp_path), out)
    p = subprocess.Popen([rh.BURRBENCH, "acquire", "--rig", rig_map, "--out", out, "--duration", str(duration_s)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    def stall():
        t0 = time.monotonic()
        for at in stalls:
            time.sleep(max(0.0, t0 + at - time.monotonic()))
            os.kill(p.pid, signal.SIGSTOP)
            time.sleep(STALL_S)
            os.kill(p.pid, signal.SIGCONT)
    t = threading.Thread(target=stall)
    t.start()
    stdout, stderr = p.communicate(timeout=60)
    t.join()
    assert p.returncode == 0, stdout + stderr
    return rh.read_recording(out)


def test_a_deep_fifo_read_in_blocks_survives_host_stalls(tmp_path):
    stalls = [0.8, 1.6, 2.4]
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", str(RATE_HZ), "--ft-fifo-depth", "96",
                            "--stage-fifo-depth", "96"]) as (proc, host, port):
        deep = fifo_map(tmp_path, "virtual-fifo-deep", port, "deep.toml")
        rec = acquire_with_stalls(tmp_path, deep, 3.2, stalls, "deep.h5")
        start = playback_start_ns(proc)
        shallow = fifo_map(tmp_path, "virtual-fifo", port, "shallow.toml")
        old = acquire_with_stalls(tmp_path, shallow, 3.2, stalls, "shallow.h5")
    ft = rec["ft_sensor"]
    k = ft["device_counter"]
    assert k.size > 0.8 * 3.2 * RATE_HZ, k.size
    holes = [(int(a), int(b)) for a, b in zip(k[:-1], k[1:]) if b != a + 1]
    assert not holes, ("every record exactly once, in order, across the stalls", holes[:5],
                       [e[1:] for e in rec["_events"] if e[2] == "ft_sensor"][:5])
    rh.assert_ramp_exact(ft)  # each record decoded as the sample its own counter names
    assert not rh.events(rec, "gap", "ft_sensor"), rh.events(rec, "gap", "ft_sensor")
    stage = rec["stage"]  # the stage's deep FIFO likewise (8-register records in 7 blocks)
    assert np.all(np.diff(stage["device_counter"]) == 1) and not rh.events(rec, "gap", "stage")
    np.testing.assert_array_equal(np.rint(stage["channels"]["position_mm"] * 1000).astype(np.int64),
                                  rh.ramp_position_um(stage["device_counter"]))
    # Device time = counter × period fitted to host time: close to when the rig took it.
    err_ms = (ft["t_ns"] - (start + k * 1e9 / RATE_HZ)) / 1e6
    assert np.median(np.abs(err_ms)) < 1.0, (np.median(np.abs(err_ms)), err_ms.min(), err_ms.max())
    # The 8-deep FIFO (16 ms at 500 Hz) cannot hold a 60 ms stall: records are lost (about
    # 22 a stall), each inside a recorded gap event.
    lost = rh.assert_losses_recorded(old, "ft_sensor")
    assert lost >= 3 * 15, lost


def test_blocks_are_checked_before_connecting(tmp_path):
    text = rh.preset("virtual-fifo-deep", rh.free_port())
    cases = [
        # two blocks reading the same registers
        (text.replace("{ start = 1114, count = 112 }", "{ start = 1100, count = 112 }"),
         "devices[0].blocks[1].start", "no other block"),
        # a FIFO region with a hole: one block left out
        (text.replace("  { start = 1114, count = 112 },\n", ""), "devices[0].fifo.first_register", "consecutively"),
        # a record split between two requests
        (text.replace("{ start = 1000, count = 114 },\n  { start = 1114, count = 112 }",
                      "{ start = 1000, count = 115 },\n  { start = 1115, count = 111 }"),
         "devices[0].fifo.record_registers", "inside one block"),
        # several blocks without each record's counter
        (text.replace(", record_counter = { register = 0, type = \"uint32\" }", ""),
         "devices[0].fifo.record_counter", "several blocks"),
        # blocks and a single block's keys together
        (text.replace('mode = "fifo"\nblocks', 'mode = "fifo"\nstart = 1000\nblocks', 1), "devices[0].start", "inside blocks"),
    ]
    for i, (body, field, why) in enumerate(cases):
        rig_map = rh.write_map(tmp_path, body, f"bad{i}.toml")
        p = rh.run(["rig", "check", "--rig", rig_map], timeout=20)
        assert_refused(p.returncode, p.stderr, rig_map, f"{rig_map}: {field}: expected", why)


def test_a_device_that_stops_sampling_does_not_skew_the_clock_fit(tmp_path):
    # A played recording ends before the acquisition does: the device stops sampling, and
    # the polls after that prove nothing about when their newest record was taken. They
    # used to pin every timestamp to the latest reply bound (the demo: 15 ms apart, fitted
    # lags 1 ms off); the fit now uses only polls during which the device kept sampling.
    from test_virtual_playback import write_recording
    write_recording(tmp_path / "short.h5", ft_hz=1000.0, stage_hz=1000.0, duration_s=1.5, stage_lag_s=0.0)
    with start_virtual_rig(["--recording", str(tmp_path / "short.h5"), "--ft-fifo-depth", "96",
                            "--stage-fifo-depth", "96"]) as (proc, host, port):
        rig_map = rh.write_map(tmp_path, rh.preset("virtual-fifo-deep", port), "deep.toml")
        out = os.path.join(str(tmp_path), "r.h5")
        p = rh.run(["acquire", "--rig", rig_map, "--out", out, "--duration", "2.0"])
        start = playback_start_ns(proc)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "do not overlap" not in p.stderr, p.stderr
    ft = rh.read_recording(out)["ft_sensor"]
    k = ft["device_counter"]
    assert k[-1] == 1499 and np.all(np.diff(k) == 1), (k[0], k[-1])
    err_ms = (ft["t_ns"] - (start + k * 1e6)) / 1e6
    assert np.max(np.abs(err_ms)) < 1.0, (np.median(err_ms), err_ms.min(), err_ms.max())
    # Records stamped with the reply of the poll's first (newest) block, not its last: the
    # clock's offset within 0.4 ms (stamped with the last reply it was 0.57 ms late).
    assert abs(np.median(err_ms)) < 0.4, np.median(err_ms)
