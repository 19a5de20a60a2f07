"""A device that keeps answering but stops measuring (its counter no longer advances):
`acquire` keeps every row, marks them stale, and says so — a warning naming the device and
the span, and a `frozen` event in the recording — so a lab does not drill on believing
the sensor is live (docs/rig.md, "Latest mode")."""
import re

import numpy as np

import rig_helpers as rh
from virtual_helpers import start_virtual_rig, write_recording


def frozen_session(tmp_path, loop):
    # A 1 s recording played, then (without --loop) held at its last sample: the counters
    # stop; acquired for 2 s.
    rec = tmp_path / "short.h5"
    write_recording(rec, ft_hz=200.0, stage_hz=100.0, spindle_hz=50.0, duration_s=1.0)
    with start_virtual_rig(["--recording", str(rec)] + (["--loop"] if loop else [])) as (proc, host, port):
        body = (rh.tcp_device("ft_sensor", port, 9, 180, 42, 500, rh.FT_CHANNELS, counter=220, timeout_ms=1000)
                + rh.tcp_device("stage", port, 1, 0, 8, 200, rh.STAGE_CHANNELS, counter=6, timeout_ms=1000))
        out = tmp_path / "r.h5"
        p = rh.run(["acquire", "--rig", rh.write_map(tmp_path, body), "--out", str(out), "--duration", "2"])
    assert p.returncode == 0, p.stdout + p.stderr
    return rh.read_recording(str(out)), p.stderr


def test_a_device_that_stops_measuring_is_named_with_its_span(tmp_path):
    rec, err = frozen_session(tmp_path, loop=False)
    for name in ("ft_sensor", "stage"):
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


def test_a_device_that_keeps_measuring_gets_no_warning(tmp_path):
    rec, err = frozen_session(tmp_path, loop=True)
    assert rh.events(rec, "frozen") == [], rec["_events"]
    assert "did not advance" not in err, err
