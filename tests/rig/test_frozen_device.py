"""A device that keeps answering but stops measuring (its counter no longer advances):
`acquire` keeps every row, marks them stale, and says so — at once, on a line of its own,
while it lasts (and when the device measures again), and in the recording: a warning
naming the device and the span, and a `frozen` event (docs/rig.md, "Latest mode")."""
import re

import h5py
import numpy as np

import rig_helpers as rh
from virtual_helpers import start_virtual_rig, write_recording


def session(tmp_path, rec, duration_s):
    with start_virtual_rig(["--recording", str(rec)]) as (proc, host, port):
        body = (rh.tcp_device("ft_sensor", port, 9, 180, 42, 500, rh.FT_CHANNELS, counter=220, timeout_ms=1000)
                + rh.tcp_device("stage", port, 1, 0, 8, 200, rh.STAGE_CHANNELS, counter=6, timeout_ms=1000))
        out = tmp_path / "r.h5"
        p = rh.run(["acquire", "--rig", rh.write_map(tmp_path, body), "--out", str(out), "--duration", str(duration_s)])
    assert p.returncode == 0, p.stdout + p.stderr
    return rh.read_recording(str(out)), p.stderr


def test_a_device_that_stops_measuring_is_named_with_its_span(tmp_path):
    # A 1 s recording played, then held at its last sample: the counters stop; acquired
    # for 2 s.
    rec = tmp_path / "short.h5"
    write_recording(rec, ft_hz=200.0, stage_hz=100.0, spindle_hz=50.0, duration_s=1.0)
    rec, err = session(tmp_path, rec, 2)
    for name in ("ft_sensor", "stage"):
        assert re.search(rf"acquire: WARNING: {name} gives no new measurement: its counter has not advanced for "
                         r"[0-9.]+ s", err), err
        ev = rh.events(rec, "frozen", name)
        assert len(ev) == 1, rec["_events"]
        m = re.search(rf"warning: {name}: its counter did not advance for ([0-9.]+) s \(([0-9]+) polls, ([0-9.]+) s to "
                      r"([0-9.]+) s into the session\)", err)
        assert m, err
        span, polls, start, end = float(m.group(1)), int(m.group(2)), float(m.group(3)), float(m.group(4))
        # The playback ends 1 s after the rig starts (the rig started a little before the
        # session); the rest of the 2 s session is frozen.
        assert 0.6 < span < 2.0 and abs((end - start) - span) < 0.011, m.group(0)
        assert end > 1.9, m.group(0)
        s = rec[name]
        # The event is at the last fresh sample; every poll after it repeats its counter
        # to the session's end, is kept, and is marked stale.
        first = int(np.flatnonzero(s["t_ns"] == ev[0][0])[0])
        after = s["device_counter"][first + 1:]
        assert len(after) == polls and polls > 50, (len(after), polls)
        assert (after == s["device_counter"][first]).all()
        assert s["stale"][first + 1:].all() and not s["stale"][first]


def test_a_pause_is_named_while_it_lasts_and_the_live_device_is_not(tmp_path):
    # The force sensor gives nothing new from 0.8 s to 1.6 s of a 3 s recording (its rows
    # there are stale: the virtual rig holds its counter), then measures again; the stage
    # measures throughout.
    rec = tmp_path / "pause.h5"
    write_recording(rec, ft_hz=200.0, stage_hz=100.0, spindle_hz=50.0, duration_s=3.0)
    with h5py.File(rec, "a") as f:
        t = (f["streams/ft_sensor/t_ns"][()] - f["streams/ft_sensor/t_ns"][0]) * 1e-9
        f["streams/ft_sensor/stale"] = ((t >= 0.8) & (t < 1.6)).astype(np.uint8)
    rec, err = session(tmp_path, rec, 2.2)
    warned = err.index("acquire: WARNING: ft_sensor gives no new measurement")
    assert err.index("acquire: ft_sensor measures again") > warned, err
    assert "stage gives no new measurement" not in err and "warning: stage:" not in err, err
    ev = rh.events(rec, "frozen", "ft_sensor")
    assert len(ev) == 1 and rh.events(rec, "frozen", "stage") == [], rec["_events"]
    span = float(re.search(r"did not advance for ([0-9.]+) s", ev[0][3]).group(1))
    assert 0.6 < span < 1.1, ev  # 0.8 s of held counter, give or take a poll and a host stall
