"""End to end over Modbus TCP against the real virtual rig: every value the rig served
during the session is in the recording, decoded exactly, with honest timestamps."""
# ctest: load (issue 59: its promises hold beside two busy processes; make test-loaded)
import os
import re

import h5py
import numpy as np
import pytest

import rig_helpers as rh
from virtual_helpers import playback_start_ns, read_served_log, start_virtual_rig


def test_every_served_value_is_recorded_exactly(tmp_path):
    # Device 50 Hz, polled at 500 Hz: every device sample is read at least once. The 1 s
    # timeout outlasts any stall of the shared host, so no reply is given up on.
    served_log = tmp_path / "served.csv"
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "50", "--spindle-rate-hz", "20",
                            "--served-log", str(served_log)]) as (proc, host, port):
        body = (rh.tcp_device("ft_sensor", port, 9, 180, 42, 500, rh.FT_CHANNELS, counter=220, timeout_ms=1000)
                + rh.tcp_device("stage", port, 1, 0, 8, 500, rh.STAGE_CHANNELS, counter=6, timeout_ms=1000)
                + rh.tcp_device("spindle", port, 2, 0, 5, 100, rh.SPINDLE_LOAD_CHANNELS, counter=2, timeout_ms=1000)
                + rh.tcp_device("constants", port, 9, 400, 18, 20, rh.CONST_CHANNELS, timeout_ms=1000))
        out = rh.acquire(tmp_path, rh.write_map(tmp_path, body), 2.0, extra=["--sample-id", "S1", "--notes", "tcp e2e"])
        start = playback_start_ns(proc)
    rec = rh.read_recording(out)
    ft, stage, spindle = rec["ft_sensor"], rec["stage"], rec["spindle"]
    assert ft["device_counter"].size > 300 and np.ptp(ft["device_counter"]) > 80
    # Every reply the rig wrote is in the recording: nothing acquired is lost.
    rh.assert_every_served_reply_recorded(rec, read_served_log(served_log), {
        "ft_sensor": (9, 180), "stage": (1, 0), "spindle": (2, 0), "constants": (9, 400)})
    # Every device sample was read, unless the host stalled both processes for longer
    # than a device period (bench/rig.sh measures such stalls): that loss is a gap event.
    # How many that is depends on the host: beside two busy processes and the rest of the
    # suite (load 6-7) the Python rig answered 4 devices late enough to lose 28 of 107
    # force samples (issue 59); latest mode promises the gap events, not a rate.
    for name in ("ft_sensor", "stage", "spindle"):
        lost = rh.assert_losses_recorded(rec, name)
        assert lost <= 0.5 * np.ptp(rec[name]["device_counter"]), (name, lost)
    rh.assert_ramp_exact(ft)
    np.testing.assert_array_equal(np.rint(stage["channels"]["position_mm"] * 1000).astype(np.int64),
                                  rh.ramp_position_um(stage["device_counter"]))
    np.testing.assert_allclose(stage["channels"]["position_mm"], rh.ramp_position_um(stage["device_counter"]) * 1e-3,
                               rtol=0, atol=1e-9)
    np.testing.assert_array_equal(spindle["channels"]["spindle_rpm"][:, 0] if spindle["channels"]["spindle_rpm"].ndim > 1
                                  else spindle["channels"]["spindle_rpm"], rh.ramp_rpm(spindle["device_counter"]))
    # The drive's load register, decoded to the canonical spindle_torque_Nmm (issue 13).
    np.testing.assert_allclose(spindle["channels"]["spindle_torque_Nmm"].reshape(-1),
                               rh.ramp_spindle_load_Nmm(spindle["device_counter"]), rtol=0, atol=1e-9)
    assert np.ptp(spindle["channels"]["spindle_torque_Nmm"]) > 0
    # 123456.0 and 123456 in every word order, every sample.
    const = rec["constants"]
    assert const["t_ns"].size >= 20
    for o in rh.ORDERS:
        assert np.all(const["channels"][f"f32_{o}"] == 123456.0), o
        assert np.all(const["channels"][f"i32_{o}"] == 123456), o
    # A repeated counter is marked stale, never passed off as new.
    for s in (ft, stage, spindle):
        rep = np.concatenate([[False], s["device_counter"][1:] == s["device_counter"][:-1]])
        np.testing.assert_array_equal(s["stale"].astype(bool), rep)
    rh.assert_timestamps_honest(ft, start, 50)
    rh.assert_timestamps_honest(stage, start, 50)
    # Raw registers are kept beside the decoded values.
    assert ft["raw_registers"].size == ft["t_ns"].size * 42
    assert rec["_meta"]["sample_id"] == "S1" and rec["_meta"]["notes"] == "tcp e2e"
    assert "rig_id" in rec["_meta"]
    assert "port = %d" % port in (rec["_meta_sets"]["register_map_toml"].decode()
                                  if isinstance(rec["_meta_sets"]["register_map_toml"], bytes)
                                  else str(rec["_meta_sets"]["register_map_toml"]))
    assert rh.events(rec, "start") and rh.events(rec, "stop")
    assert not os.path.exists(out + ".journal")  # finalised and cleaned up
    with h5py.File(out) as f:
        assert f["provenance"]["inputs"]["sha256"].shape[0] == 1


def test_fifo_mode_is_lossless_at_device_rate(tmp_path):
    # 250 Hz devices drained through their 8- and 16-deep FIFOs at 100 polls/s: a poll may
    # stall up to 32 ms (the shared test machine) without losing a sample. (bench/rig.sh: 1 kHz.)
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "250"]) as (proc, host, port):
        rig_map = rh.preset("virtual-fifo", port, rate_hz=100).replace("device_rate_hz = 1000", "device_rate_hz = 250")
        out = rh.acquire(tmp_path, rh.write_map(tmp_path, rig_map), 2.0)
        start = playback_start_ns(proc)
    rec = rh.read_recording(out)
    ft, stage = rec["ft_sensor"], rec["stage"]
    k = ft["device_counter"]
    assert k.size > 400
    assert np.all(np.diff(k) == 1), "each device sample exactly once, in order"
    rh.assert_ramp_exact(ft)
    assert stage["device_counter"].size > 400 and np.all(np.diff(stage["device_counter"]) == 1)
    np.testing.assert_array_equal(np.rint(stage["channels"]["position_mm"] * 1000).astype(np.int64),
                                  rh.ramp_position_um(stage["device_counter"]))
    # Device time = counter × period fitted to host time: close to when the rig took it.
    err_ms = (ft["t_ns"] - (start + k * 4e6)) / 1e6
    assert np.median(np.abs(err_ms)) < 1.0, (np.median(np.abs(err_ms)), err_ms.min(), err_ms.max())
    assert np.all(np.diff(ft["t_ns"]) > 0)


def test_rig_check_and_tare(tmp_path):
    with start_virtual_rig(["--pattern", "constants"]) as (proc, host, port):
        rig_map = rh.write_map(tmp_path, rh.preset("virtual", port))
        p = rh.run(["rig", "check", "--rig", rig_map])
        assert p.returncode == 0, p.stdout + p.stderr
        assert "1.5 -2.25 100 N" in p.stdout, p.stdout
        assert "12.345 -6.789 100 mm" in p.stdout, p.stdout
        assert "-30000 rpm" in p.stdout, p.stdout
        assert p.stdout.count(" ms") >= 3  # a round-trip time per device
        tare = os.path.join(str(tmp_path), "tare.toml")
        p = rh.run(["rig", "tare", "--rig", rig_map, "--samples", "50", "--out", tare])
        assert p.returncode == 0, p.stdout + p.stderr
        assert "moved by" not in p.stderr, p.stderr  # a sensor at rest: no drift warning
        out = rh.acquire(tmp_path, rig_map, 0.5, extra=["--tare", tare])
    rec = rh.read_recording(out)
    np.testing.assert_allclose(rec["_meta_sets"]["bias"], [1.5, -2.25, 100.0, 250.0, -500.0, 1000.0], rtol=0, atol=1e-12)
    assert rec["_meta"]["bias_t_ns"] > 0
    # check on a device that does not answer: reported, exit 1, no hang
    dead = rh.write_map(tmp_path, rh.tcp_device("ghost", port, 9, 180, 6, 10,
                                                rh.FT_CHANNELS[2:], timeout_ms=50), "dead.toml")
    p = rh.run(["rig", "check", "--rig", dead], timeout=20)
    assert p.returncode == 1 and "FAILED" in p.stdout, p.stdout + p.stderr


def test_rig_check_shows_each_value_as_the_device_sent_it(tmp_path):
    # A float32 as its shortest float (19.91, not 19.909999847412109), a scaled integer
    # without the binary noise of its scale (1.992 µm-counts × 0.001, not 1.9920000000000002).
    with start_virtual_rig(["--pattern", "ramp"]) as (proc, host, port):
        p = rh.run(["rig", "check", "--rig", rh.write_map(tmp_path, rh.preset("virtual", port))])
    assert p.returncode == 0, p.stdout + p.stderr
    device = None
    lines = {}
    for line in p.stdout.splitlines():
        if not line.startswith(" "):
            device = line.split()[0]
            counter = int(line.split("counter ")[1])
            continue
        name, *vals = line.split()
        lines[(device, name)] = (counter, " ".join(vals[:-1]))
    k, text = lines[("ft_sensor", "force_N")]
    assert text == " ".join(str(np.float32(v)) for v in rh.ramp_wrench(k)[:3]), p.stdout
    k, text = lines[("stage", "position_mm")]
    assert text == " ".join(f"{v * 0.001:.12g}" for v in rh.ramp_position_um(k)), p.stdout
    assert all(len(v.replace("-", "").replace(".", "")) <= 12 for v in text.split()), text


def test_a_tare_taken_while_the_force_moves_is_flagged(tmp_path):
    # The ramp pattern's force rises steadily, as when the burr touches during the tare:
    # the tare is written (it is the user's call) with a warning naming the drift between
    # its halves. Its size: the ramp's rise over half the samples.
    tare = tmp_path / "tare.toml"
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "1000"]) as (proc, host, port):
        p = rh.run(["rig", "tare", "--rig", rh.write_map(tmp_path, rh.preset("virtual", port)), "--samples", "100",
                    "--out", tare])
    assert p.returncode == 0 and tare.exists(), p.stdout + p.stderr
    m = re.search(r"warning: the force moved by (\S+) (\S+) (\S+) N between the tare's first and second half "
                  r"\(([0-9]+) standard errors", p.stderr)
    assert m, p.stderr
    dx, dy, dz, sigmas = (float(g) for g in m.groups())
    # 0.01 N per device sample along x (-0.02 y, 0.03 z); 50 polls at 1 kHz apart ≈ 50 samples.
    assert 0.2 < dx < 3.0 and dy == pytest.approx(-2 * dx, rel=0.01) and dz == pytest.approx(3 * dx, rel=0.01), m.group(0)
    assert sigmas > 10, m.group(0)


def test_the_operator_and_the_burr_stated_at_acquisition_reach_the_recording_and_its_recovery(tmp_path):
    # As `recording import` takes them: stored in the recording's metadata (the axis
    # normalised), carried by the journal's header so that `recover` gives them back, and
    # refused before the session when they cannot be right.
    burr = ["--operator", "A. Lab", "--burr-radius-mm", "1.5", "--burr-axis", "0", "0.6", "0.8", "--spin", "-1"]
    with start_virtual_rig(["--pattern", "ramp"]) as (proc, host, port):
        rig_map = rh.write_map(tmp_path, rh.preset("virtual", port))
        out = rh.acquire(tmp_path, rig_map, 0.5, extra=[*burr, "--keep-journal"])
        for bad, option in ((["--burr-axis", "0", "0", "0"], "--burr-axis"), (["--spin", "2"], "--spin"),
                            (["--burr-radius-mm", "-1"], "--burr-radius-mm")):
            p = rh.run(["acquire", "--rig", rig_map, "--out", str(tmp_path / "bad.h5"), "--duration", "0.5", *bad])
            assert p.returncode == 2 and p.stderr.startswith(f"burrbench: command line: {option}: expected"), p.stderr
            assert not (tmp_path / "bad.h5").exists() and not (tmp_path / "bad.h5.journal").exists()
    p = rh.run(["recover", out + ".journal", "--out", str(tmp_path / "recovered.h5")])
    assert p.returncode == 0, p.stdout + p.stderr
    for path in (out, str(tmp_path / "recovered.h5")):
        meta = rh.read_recording(path)["_meta"]
        assert meta["operator"] == "A. Lab" and meta["burr_radius_mm"] == 1.5 and meta["spin_sign"] == -1, meta
        np.testing.assert_allclose(meta["burr_axis_rig"], [0, 0.6, 0.8], rtol=0, atol=1e-12)
