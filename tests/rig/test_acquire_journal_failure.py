"""A journal that cannot be written stops the acquisition loudly (never retried, never
silent), keeps the journal, and `recover` rebuilds everything synced before the failure.
The failure is real: the file-size limit (RLIMIT_FSIZE) makes the kernel refuse the write."""
import os
import subprocess

import numpy as np

import rig_helpers as rh
from file_size_limit import run_with_file_size_limit
from virtual_helpers import start_virtual_rig

LIMIT_BYTES = 150_000  # a few seconds of journal at 500 polls/s


def ramp_sensor_session(tmp_path, port):
    """A force sensor polled at 500 Hz from the virtual rig: its map, the recording and journal paths."""
    body = rh.tcp_device("ft_sensor", port, 9, 180, 42, 500, rh.FT_CHANNELS, counter=220, timeout_ms=1000)
    out = os.path.join(str(tmp_path), "r.h5")
    return rh.write_map(tmp_path, body), out, out + ".journal"


def test_write_failure_stops_loudly_and_the_journal_recovers(tmp_path):
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "100"]) as (proc, host, port):
        rig_map, out, journal = ramp_sensor_session(tmp_path, port)
        p = run_with_file_size_limit(["acquire", "--rig", rig_map, "--out", out, "--duration", "60"], LIMIT_BYTES,
                                     timeout=50)
    # Stopped at the failure, not at the end of the 60 s, with the reason and what to do.
    assert p.returncode == 3, (p.returncode, p.stderr)
    assert "ACQUISITION STOPPED" in p.stderr and "write failed" in p.stderr, p.stderr
    assert "File too large" in p.stderr and journal in p.stderr and "recover" in p.stderr, p.stderr
    assert not os.path.exists(out)
    assert 0 < os.path.getsize(journal) <= LIMIT_BYTES
    rec_path = os.path.join(str(tmp_path), "recovered.h5")
    r = rh.run(["recover", journal, "--out", rec_path])
    assert r.returncode == 0, r.stdout + r.stderr
    rec = rh.read_recording(rec_path)
    ft = rec["ft_sensor"]
    assert ft["t_ns"].size > 300  # about a second of polls or more reached the disk
    rh.assert_ramp_exact(ft)
    assert np.all(np.diff(ft["t_ns"]) > 0)
    rh.assert_losses_recorded(rec, "ft_sensor")  # up to the failure, nothing missing silently


def test_a_failed_final_write_keeps_the_session_in_the_journal_and_says_how_to_recover(tmp_path):
    # The session ran, but the recording cannot be written at the end (here the writer's
    # temporary name is taken by a folder, as real as a full disk): exit 3, the line says
    # the session is in the journal and gives the `recover` command, which rebuilds it.
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "100"]) as (proc, host, port):
        rig_map, out, journal = ramp_sensor_session(tmp_path, port)
        p = subprocess.Popen([rh.BURRBENCH, "acquire", "--rig", rig_map, "--out", out, "--duration", "2"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        os.mkdir(f"{out}.tmp-{p.pid}")  # the HDF5 writer's temporary, made at the end
        try:
            stdout, stderr = p.communicate(timeout=50)
        finally:
            p.kill()
    assert p.returncode == 3, (p.returncode, stderr)
    lines = [l for l in stderr.splitlines() if l.startswith("burrbench:")]
    assert len(lines) == 1, stderr
    assert lines[0].startswith(f"burrbench: error: {out}: ") and \
        f"the session is kept in the journal {journal}: run `burrbench recover {journal} --out {out}`" in lines[0], lines[0]
    assert not os.path.exists(out) and os.path.getsize(journal) > 0
    os.rmdir(f"{out}.tmp-{p.pid}")
    r = rh.run(["recover", journal, "--out", out])
    assert r.returncode == 0, r.stdout + r.stderr
    ft = rh.read_recording(out)["ft_sensor"]
    assert ft["t_ns"].size > 500  # about 2 s at 500 Hz
    rh.assert_ramp_exact(ft)
