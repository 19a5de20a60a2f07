"""End to end over Modbus RTU through the virtual rig's baud-paced pty relay: exact
decoding of every value served, and no late reply ever taken as fresh data."""
import numpy as np

import rig_helpers as rh
from virtual_helpers import playback_start_ns, read_served_log, start_virtual_rig_rtu


def test_rtu_every_served_value_is_recorded_exactly(tmp_path):
    # One bus, two slaves, one poller thread. 42 registers take 8.4 ms on the wire at
    # 115200 baud; polls at 25 Hz per device leave room on a loaded machine.
    # The 500 ms timeout outlasts any stall of the shared host: no reply is given up on.
    served_log = tmp_path / "served.csv"
    with start_virtual_rig_rtu(["--pattern", "ramp", "--rate-hz", "5", "--stage-rate-hz", "5",
                                "--baud", "115200", "--served-log", str(served_log)]) as (proc, pty):
        body = (rh.rtu_device("ft_sensor", pty, 9, 180, 42, 25, rh.FT_CHANNELS, counter=220, timeout_ms=500)
                + rh.rtu_device("constants", pty, 9, 400, 18, 5, rh.CONST_CHANNELS, timeout_ms=500)
                + rh.rtu_device("stage", pty, 1, 0, 8, 25, rh.STAGE_CHANNELS, counter=6, timeout_ms=500))
        out = rh.acquire(tmp_path, rh.write_map(tmp_path, body), 3.0)
        start = playback_start_ns(proc)
    rec = rh.read_recording(out)
    ft, stage, const = rec["ft_sensor"], rec["stage"], rec["constants"]
    assert ft["t_ns"].size > 40 and np.ptp(ft["device_counter"]) >= 12
    rh.assert_every_served_reply_recorded(rec, read_served_log(served_log), {
        "ft_sensor": (9, 180), "stage": (1, 0), "constants": (9, 400)})
    for name in ("ft_sensor", "stage"):  # every sample, or its loss is a gap event
        lost = rh.assert_losses_recorded(rec, name)
        assert lost <= 0.1 * np.ptp(rec[name]["device_counter"]), (name, lost)
    rh.assert_ramp_exact(ft)
    np.testing.assert_array_equal(np.rint(stage["channels"]["position_mm"] * 1000).astype(np.int64),
                                  rh.ramp_position_um(stage["device_counter"]))
    for o in rh.ORDERS:
        assert const["t_ns"].size >= 5
        assert np.all(const["channels"][f"f32_{o}"] == 123456.0), o
        assert np.all(const["channels"][f"i32_{o}"] == 123456), o
    rh.assert_timestamps_honest(ft, start, 5)
    # The wire sets a floor under every round trip: 97 bytes × 10 bits / 115200 baud.
    rtt = (ft["t_recv_ns"] - ft["t_send_ns"]) / 1e6
    assert rtt.min() >= 0.8 * 8.42, rtt.min()


def test_rtu_late_replies_are_never_taken_as_fresh(tmp_path):
    # Every 4th request is answered 150 ms late, after our 60 ms timeout. The reply then
    # occupies the line while we ask again: taking it would return a sample ~60 ms older
    # than the request. The device counts at 1 kHz, so the counter exposes any such
    # reply (assert_timestamps_honest).
    with start_virtual_rig_rtu(["--pattern", "ramp", "--rate-hz", "1000", "--baud", "115200",
                                "--late-reply-every", "4", "--late-ms", "150"]) as (proc, pty):
        # late_reply_ms: the latest a reply may still come; set above the rig's 150 ms
        # plus what the loaded relay adds (docs/rig.md, "RTU recovery").
        body = rh.rtu_device("ft_sensor", pty, 9, 180, 42, 20, rh.FT_CHANNELS, counter=220, timeout_ms=60,
                             extra="late_reply_ms = 400\n")
        out = rh.acquire(tmp_path, rh.write_map(tmp_path, body), 3.0)
        start = playback_start_ns(proc)
    rec = rh.read_recording(out)
    ft = rec["ft_sensor"]
    assert ft["t_ns"].size >= 15
    rh.assert_ramp_exact(ft)
    rh.assert_timestamps_honest(ft, start, 1000)
    faults = rh.events(rec, "timeout", "ft_sensor") + rh.events(rec, "early_reply", "ft_sensor") \
        + rh.events(rec, "bad_data", "ft_sensor")
    assert len(faults) >= 3, rec["_events"]
    assert rh.events(rec, "gap", "ft_sensor"), "each lost poll is recorded as a gap"
