"""`kill -9` of `burrbench acquire`: `burrbench recover` rebuilds a recording holding every
sample acquired more than 100 ms before the kill; a flipped byte costs one block; the
journal itself is never modified."""
# ctest: load (issue 59: its promises hold beside two busy processes; make test-loaded)
import hashlib
import os
import shutil
import signal
import subprocess
import time

import numpy as np

import rig_helpers as rh
from virtual_helpers import playback_start_ns, start_virtual_rig

RATE = 100  # device samples/s, polled at 500/s: every device sample is read


def sha(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def test_kill_9_then_recover(tmp_path):
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", str(RATE)]) as (proc, host, port):
        body = rh.tcp_device("ft_sensor", port, 9, 180, 42, 500, rh.FT_CHANNELS, counter=220)
        rig_map = rh.write_map(tmp_path, body)
        out = os.path.join(str(tmp_path), "r.h5")
        journal = out + ".journal"
        acq = subprocess.Popen([rh.BURRBENCH, "acquire", "--rig", rig_map, "--out", out],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(2.5)
        t_kill = time.monotonic_ns()
        acq.send_signal(signal.SIGKILL)
        acq.wait()
        start = playback_start_ns(proc)
    assert not os.path.exists(out) and os.path.exists(journal)
    before = sha(journal)
    rec_path = os.path.join(str(tmp_path), "recovered.h5")
    p = rh.run(["recover", journal, "--out", rec_path])
    assert p.returncode == 0, p.stdout + p.stderr
    assert sha(journal) == before, "recover must not modify the journal"
    rec = rh.read_recording(rec_path)
    ft = rec["ft_sensor"]
    rh.assert_ramp_exact(ft)
    k = np.unique(ft["device_counter"])
    # Every device sample shown before kill - 100 ms (minus one period for the poll that
    # fetched it) is in the recovered recording, from the first one read on.
    k_due = int((t_kill - 100_000_000 - start) * RATE // 1_000_000_000) - 1
    assert k[-1] >= k_due, f"last recovered sample {k[-1]}, expected ≥ {k_due}"
    # ... each of them, unless the rig stalled past a device period: then a gap event.
    lost = rh.assert_losses_recorded(rec, "ft_sensor")
    assert lost <= 0.05 * np.ptp(k), lost
    assert rh.events(rec, "recovered"), "a recovered recording says so"

    # A flipped byte in a data block costs that block (≤ one block of samples) and no more.
    blocks = os.path.getsize(journal) // 4096
    assert blocks > 6
    damaged = os.path.join(str(tmp_path), "damaged.journal")
    shutil.copy(journal, damaged)
    with open(damaged, "r+b") as f:
        f.seek((blocks // 2) * 4096 + 700)
        b = f.read(1)
        f.seek((blocks // 2) * 4096 + 700)
        f.write(bytes([b[0] ^ 0x40]))
    p = rh.run(["recover", damaged, "--out", os.path.join(str(tmp_path), "damaged.h5")])
    assert p.returncode == 0, p.stdout + p.stderr
    assert "1 damaged block(s) skipped" in p.stdout, p.stdout
    dmg = rh.read_recording(os.path.join(str(tmp_path), "damaged.h5"))["ft_sensor"]
    per_block = (4096 - 20) // (8 + 28 + 2 * 42)
    lost = ft["t_ns"].size - dmg["t_ns"].size
    assert 1 <= lost <= per_block, lost
    rh.assert_ramp_exact(dmg)

    # A torn tail (half a block) is ignored.
    torn = os.path.join(str(tmp_path), "torn.journal")
    shutil.copy(journal, torn)
    with open(torn, "ab") as f:
        f.write(b"\x00" * 1500)
    p = rh.run(["recover", torn, "--out", os.path.join(str(tmp_path), "torn.h5")])
    assert p.returncode == 0 and "1500 torn tail bytes ignored" in p.stdout, p.stdout + p.stderr


def test_sigterm_finalises_the_recording(tmp_path):
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", str(RATE)]) as (proc, host, port):
        rig_map = rh.write_map(tmp_path, rh.tcp_device("ft_sensor", port, 9, 180, 42, 200, rh.FT_CHANNELS, counter=220))
        out = os.path.join(str(tmp_path), "r.h5")
        acq = subprocess.Popen([rh.BURRBENCH, "acquire", "--rig", rig_map, "--out", out],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(1.0)
        acq.send_signal(signal.SIGTERM)
        stdout, stderr = acq.communicate(timeout=30)
    assert acq.returncode == 0, stdout + stderr
    assert "wrote" in stdout and "jitter" in stdout  # the end summary
    rec = rh.read_recording(out)
    assert rec["ft_sensor"]["t_ns"].size > 50
    assert not rh.events(rec, "recovered")
    assert not os.path.exists(out + ".journal")
