"""Counter wrap is not a device restart (issue 11, fault 4): a uint16 counter rolls over
from 65535 to 0 every 65.5 s at 1 kHz. The virtual rig's counters start just below the
wrap and the map reads only their low words as uint16, so every device wraps 1.2 s after
the rig starts (beside two busy processes acquire took up to 0.6 s to make its first poll): no `counter_reset`, no FIFO record lost, counters unwrapped in the
recording, every value the one served for that sample."""
import numpy as np

import rig_helpers as rh
from virtual_helpers import start_virtual_rig

RATE = 250  # device samples/s: the FIFOs span 32 and 64 ms, polled every 10 ms
# ctest: load
START = 65536 - 300  # counter of sample 0: the wrap comes 1.2 s in


def test_uint16_counters_wrap_without_loss_or_reset(tmp_path):
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", str(RATE), "--counter-start", str(START)]) as (proc, host, port):
        text = rh.preset("virtual-fifo", port, rate_hz=100).replace("device_rate_hz = 1000", f"device_rate_hz = {RATE}")
        for old, new in (('counter = { register = 300, type = "uint32" }', 'counter = { register = 301, type = "uint16" }'),
                         ('counter = { register = 100, type = "uint32" }', 'counter = { register = 101, type = "uint16" }'),
                         ('counter = { register = 2, type = "uint32", word_order = "ABCD" }',
                          'counter = { register = 3, type = "uint16" }')):
            assert old in text, old
            text = text.replace(old, new)
        out = rh.acquire(tmp_path, rh.write_map(tmp_path, text), 2.5)
    rec = rh.read_recording(out)
    assert rh.events(rec, "counter_reset") == [], rec["_events"]
    for name in ("ft_sensor", "stage"):  # FIFO: every record once, in order, across the wrap
        k = rec[name]["device_counter"]
        assert k[0] < 65536 < k[-1], (name, k[0], k[-1])
        assert np.all(np.diff(k) >= 1), (name, np.unique(np.diff(k)))
        assert np.all(np.isin(np.arange(65530, 65542), k)), (name, "records at the wrap")
        rh.assert_losses_recorded(rec, name)  # any other loss (a host stall) is a gap event
    ft = dict(rec["ft_sensor"], device_counter=rec["ft_sensor"]["device_counter"] - START)
    rh.assert_ramp_exact(ft)
    np.testing.assert_array_equal(np.rint(rec["stage"]["channels"]["position_mm"] * 1000).astype(np.int64),
                                  rh.ramp_position_um(rec["stage"]["device_counter"] - START))
    spindle = rec["spindle"]["device_counter"]  # latest mode, polled at 100 Hz
    assert spindle[0] < 65536 < spindle[-1] and np.all(np.diff(spindle) >= 0), spindle
    np.testing.assert_array_equal(rec["spindle"]["channels"]["spindle_rpm"], rh.ramp_rpm(spindle - START))
