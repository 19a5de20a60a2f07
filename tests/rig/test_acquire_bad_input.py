"""Bad register maps, journals and register values: exit code 2 with a message naming
file, field and expectation, or flagged samples — never a crash, hang or silent number."""
import os

import numpy as np
import pytest

import rig_helpers as rh
from bad_input import assert_refused
from virtual_helpers import start_virtual_rig

GOOD = rh.tcp_device("ft_sensor", 5020, 9, 180, 42, 100, rh.FT_CHANNELS, counter=220)


@pytest.mark.parametrize("change,field", [
    (("rate_hz = 100", "rate_hz = 100\nwrite_coil = 3"), "devices[0].write_coil"),
    (("slave = 9", 'slave = 9\nfunction = "write_holding"'), "devices[0].function"),
    (('type = "int16"', 'type = "int12"'), "devices[0].channels[2].type"),
    (("count = 42", "count = 300"), "devices[0].count"),
    (("registers = [200, 202, 204]", "registers = [200, 202, 250]"), "devices[0].channels[0].registers[2]"),
    (("rate_hz = 100", "rate_hz = 100\nspeed = 1"), "devices[0].speed"),
    (('transport = "tcp"', 'transport = "can"'), "devices[0].transport"),
])
def test_bad_maps_exit_2_naming_the_field(tmp_path, change, field):
    rig_map = rh.write_map(tmp_path, GOOD.replace(*change, 1))
    p = rh.run(["acquire", "--rig", rig_map, "--out", os.path.join(str(tmp_path), "r.h5"), "--duration", "1"])
    assert_refused(p.returncode, p.stderr, rig_map, f"{rig_map}: {field}: expected")
    assert not os.path.exists(os.path.join(str(tmp_path), "r.h5.journal"))


def test_write_requests_are_refused_as_read_only(tmp_path):
    rig_map = rh.write_map(tmp_path, GOOD + "write_registers = [[180, 0]]\n")
    p = rh.run(["rig", "check", "--rig", rig_map])
    assert_refused(p.returncode, p.stderr, rig_map, "read-only")


def test_missing_map_and_bad_journal(tmp_path):
    p = rh.run(["acquire", "--rig", os.path.join(str(tmp_path), "none.toml"), "--out", "x.h5"])
    assert_refused(p.returncode, p.stderr, "none.toml")
    junk = os.path.join(str(tmp_path), "junk.journal")
    with open(junk, "wb") as f:
        f.write(os.urandom(3 * 4096))
    p = rh.run(["recover", junk, "--out", os.path.join(str(tmp_path), "r.h5")])
    assert_refused(p.returncode, p.stderr, junk)


def test_existing_journal_is_not_overwritten(tmp_path):
    rig_map = rh.write_map(tmp_path, GOOD)
    out = os.path.join(str(tmp_path), "r.h5")
    with open(out + ".journal", "wb") as f:
        f.write(b"left by a crash")
    p = rh.run(["acquire", "--rig", rig_map, "--out", out, "--duration", "1"])
    assert_refused(p.returncode, p.stderr, out + ".journal", "recover")
    with open(out + ".journal", "rb") as f:
        assert f.read() == b"left by a crash"


def test_nan_and_out_of_range_values_are_flagged(tmp_path):
    with start_virtual_rig(["--pattern", "nonfinite", "--rate-hz", "50"]) as (proc, host, port):
        # A register is read into one channel only (the map refuses overlaps): Fz's int16
        # register goes into the range-checked channel.
        chans = rh.FT_CHANNELS[:2] + [
            {"name": "force_int16_N", "unit": "N", "type": "int16", "registers": [180, 181], "scale": 0.01},
            {"name": "fz_checked_N", "unit": "N", "type": "int16", "registers": [182],
             "scale": 0.01, "min": -10.0, "max": 10.0}]
        body = (rh.tcp_device("ft_sensor", port, 9, 180, 42, 100, chans, counter=220)
                + rh.tcp_device("stage", port, 1, 0, 8, 100, rh.STAGE_CHANNELS, counter=6))
        out = rh.acquire(tmp_path, rh.write_map(tmp_path, body), 1.0)
    rec = rh.read_recording(out)
    ft = rec["ft_sensor"]
    n = ft["t_ns"].size
    assert n > 20
    # float32 NaN/Inf: the row is flagged (stale + sample_flags bit 0), the value is NaN,
    # never a number that could pass for a measurement.
    assert np.all(ft["stale"] == 1)
    assert np.all(ft["channels"]["sample_flags"].reshape(-1).astype(int) & 1)
    assert np.all(np.isnan(ft["channels"]["force_N"]))
    # The int16 registers of the same sample hold the rig's substitutes (NaN → 0, ±Inf →
    # the type's limit): 0 is decoded as served, a value at the register's rail is flagged
    # (at_rail), and a configured range catches the one beyond it.
    assert ft["channels"]["force_int16_N"][0][0] == 0.0
    assert np.isnan(ft["channels"]["force_int16_N"][0][1])
    assert np.all(np.isnan(ft["channels"]["fz_checked_N"]))
    # Raw registers are kept, so the flagged values can be inspected.
    assert ft["raw_registers"].size == n * 42
    # Positions stay finite (the stage's int32 saturates): stage samples are valid.
    stage = rec["stage"]
    assert np.all(np.isfinite(stage["channels"]["position_mm"]))


def test_values_at_their_registers_rail_are_flagged(tmp_path):
    # A sensor that clips holds its register at the rail (int16 ±32767, int32's limits,
    # uint16 65535) however far beyond the true value lies: such a number is a bound, not a
    # measurement, and must not reach a fit as a force or a position.
    with start_virtual_rig(["--pattern", "saturate", "--rate-hz", "50"]) as (proc, host, port):
        body = (rh.tcp_device("ft_sensor", port, 9, 180, 42, 100, rh.FT_CHANNELS, counter=220)
                + rh.tcp_device("stage", port, 1, 0, 8, 100, rh.STAGE_CHANNELS, counter=6)
                + rh.tcp_device("spindle", port, 2, 0, 5, 100, rh.SPINDLE_CHANNELS))
        out = rh.acquire(tmp_path, rh.write_map(tmp_path, body), 1.0)
    rec = rh.read_recording(out)
    ft = rec["ft_sensor"]
    assert ft["t_ns"].size > 20
    i16 = ft["channels"]["force_int16_N"]  # served 32767, −32767, 50
    assert np.isnan(i16[:, :2]).all() and np.all(i16[:, 2] == 0.5)
    assert np.all(ft["stale"] == 1)
    assert np.all(ft["channels"]["sample_flags"].reshape(-1).astype(int) & 1)
    # The float32 force (400, −400, 0.5 N) is a real reading: no rail in a float.
    np.testing.assert_array_equal(np.unique(ft["channels"]["force_N"], axis=0), [[400.0, -400.0, 0.5]])
    stage = rec["stage"]  # int32 limits in x and y
    assert np.all(stage["stale"] == 1)
    assert np.all(stage["channels"]["position_mm"] == 0)  # positions stay finite: 0
    spindle = rec["spindle"]  # 65535 rpm
    assert np.all(spindle["stale"] == 1) and np.isnan(spindle["channels"]["spindle_rpm"]).all()


def test_outputs_never_replace_inputs(tmp_path):
    # Refused up front (before a session), exit 2, the input byte for byte unchanged.
    rig_map = rh.write_map(tmp_path, GOOD)
    journal = os.path.join(str(tmp_path), "old.journal")
    with open(journal, "wb") as f:
        f.write(b"not really a journal, but an input all the same")
    cases = [
        (["acquire", "--rig", rig_map, "--out", rig_map, "--duration", "1"], rig_map),
        (["acquire", "--rig", rig_map, "--out", os.path.join(str(tmp_path), "r.h5"), "--journal", rig_map], rig_map),
        (["rig", "tare", "--rig", rig_map, "--out", rig_map], rig_map),
        (["recover", journal, "--out", journal], journal),
    ]
    for args, victim in cases:
        before = open(victim, "rb").read()
        p = rh.run(args, timeout=20)
        assert_refused(p.returncode, p.stderr, victim, "different from the inputs")
        assert open(victim, "rb").read() == before, args


@pytest.mark.parametrize("channel,key,value,field", [
    # Canonical channels that a recording could not hold (issue 11, fault 2) ...
    (0, "unit", "kN", "devices[0].channels[0].unit"),
    (0, "registers", [200, 202], "devices[0].channels[0].registers"),
    # ... and a register read into two channels (fault 6).
    (1, "registers", [204, 208, 210], "devices[0].channels[1].registers[0]"),
])
def test_rig_check_refuses_bad_maps_before_connecting(tmp_path, channel, key, value, field):
    # No server listens on the map's port: the map must be refused before any connect.
    chans = [dict(c) for c in rh.FT_CHANNELS]
    chans[channel][key] = value
    rig_map = rh.write_map(tmp_path, rh.tcp_device("ft_sensor", rh.free_port(), 9, 180, 42, 100, chans))
    p = rh.run(["rig", "check", "--rig", rig_map], timeout=20)
    assert_refused(p.returncode, p.stderr, rig_map, f"{rig_map}: {field}: expected")
    assert "connect" not in p.stderr, p.stderr
    p = rh.run(["acquire", "--rig", rig_map, "--out", os.path.join(str(tmp_path), "r.h5"), "--duration", "1"], timeout=20)
    assert_refused(p.returncode, p.stderr, rig_map, f"{rig_map}: {field}")
    assert not os.path.exists(os.path.join(str(tmp_path), "r.h5.journal"))


def test_position_in_micrometres_is_refused(tmp_path):
    chans = [dict(rh.STAGE_CHANNELS[0], unit="um")]
    rig_map = rh.write_map(tmp_path, rh.tcp_device("stage", rh.free_port(), 1, 0, 8, 100, chans))
    p = rh.run(["rig", "check", "--rig", rig_map], timeout=20)
    assert_refused(p.returncode, p.stderr, rig_map, f"{rig_map}: devices[0].channels[0].unit: expected \"mm\"")


def test_existing_recording_is_never_replaced(tmp_path):
    # Issue 11, fault 1: `acquire --out EXISTING.h5` with no device answering replaced the
    # recording with an empty one, exit 0.
    rig_map = rh.write_map(tmp_path, rh.tcp_device("ft_sensor", rh.free_port(), 9, 180, 42, 100, rh.FT_CHANNELS))
    out = os.path.join(str(tmp_path), "r.h5")
    with open(out, "wb") as f:
        f.write(b"the lab's only copy of yesterday's session")
    p = rh.run(["acquire", "--rig", rig_map, "--out", out, "--duration", "1"], timeout=20)
    assert_refused(p.returncode, p.stderr, out, f"{out}: --out: expected", "--overwrite")
    assert open(out, "rb").read() == b"the lab's only copy of yesterday's session"
    assert not os.path.exists(out + ".journal")


def test_a_session_without_samples_fails_and_writes_nothing(tmp_path):
    # Even with --overwrite, a session in which no device answered writes no recording
    # (an empty file would pass for data) and exits non-zero, saying why.
    rig_map = rh.write_map(tmp_path, rh.tcp_device("ft_sensor", rh.free_port(), 9, 180, 42, 100, rh.FT_CHANNELS))
    out = os.path.join(str(tmp_path), "r.h5")
    with open(out, "wb") as f:
        f.write(b"kept")
    p = rh.run(["acquire", "--rig", rig_map, "--out", out, "--duration", "1", "--overwrite"], timeout=30)
    assert p.returncode == 1, p.stdout + p.stderr
    assert "no device delivered a sample" in p.stderr and "fault" in p.stderr, p.stderr
    assert open(out, "rb").read() == b"kept"
    assert sorted(os.listdir(str(tmp_path))) == ["r.h5", "rig.toml"]


def test_overwrite_replaces_a_recording_with_a_whole_session(tmp_path):
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "200"]) as (proc, host, port):
        rig_map = rh.write_map(tmp_path, rh.tcp_device("ft_sensor", port, 9, 180, 42, 100, rh.FT_CHANNELS, counter=220))
        out = os.path.join(str(tmp_path), "r.h5")
        with open(out, "wb") as f:
            f.write(b"old")
        rh.acquire(tmp_path, rig_map, 0.5, extra=["--overwrite"])
    assert rh.read_recording(out)["ft_sensor"]["t_ns"].size > 10


def test_rtu_rates_the_bus_cannot_carry_are_refused_before_opening_it(tmp_path):
    # Issue 11: the FT 300 example asked for 100 Hz at 19 200 baud, 16.7 ms of wire a poll.
    chans = [{"name": "force_N", "unit": "N", "type": "int16", "registers": [180, 181, 182], "scale": 0.01}]
    body = rh.rtu_device("ft_sensor", "/dev/burrbench-no-such-port", 9, 180, 6, 100, chans, baud=19200)
    rig_map = rh.write_map(tmp_path, body)
    p = rh.run(["rig", "check", "--rig", rig_map], timeout=20)
    assert p.returncode == 2, p.stdout + p.stderr
    assert f"{rig_map}: devices[0].rate_hz: expected rates the bus" in p.stderr and "167 % busy" in p.stderr, p.stderr
    p = rh.run(["rig", "check", "--rig", rh.write_map(tmp_path, body.replace("rate_hz = 100", "rate_hz = 50"))], timeout=20)
    assert "83 % busy" in p.stdout and "16.67 ms" in p.stdout, p.stdout + p.stderr


def test_status_bits_mark_rows_invalid(tmp_path):
    # Issue 11: a status or saturation register marks rows invalid. The virtual sensor sets
    # its overload bit (0x0002 at register 222) on every 7th sample; the map's mask is 0x0002.
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "100", "--status-every", "7"]) as (proc, host, port):
        body = rh.tcp_device("ft_sensor", port, 9, 180, 43, 100, rh.FT_CHANNELS, counter=220,
                             extra="status = { register = 222, type = \"uint16\", invalid_mask = 0x0002 }\n")
        out = rh.acquire(tmp_path, rh.write_map(tmp_path, body), 1.5)
    ft = rh.read_recording(out)["ft_sensor"]
    k = ft["device_counter"]
    flags = ft["channels"]["sample_flags"].reshape(-1).astype(int)
    bad = (k % 7 == 0)
    assert bad.sum() >= 10 and (~bad).sum() >= 50, k
    np.testing.assert_array_equal((flags & 4) != 0, bad)
    assert np.all(ft["stale"][bad] == 1)
    for name in ("force_N", "torque_Nmm", "force_int16_N"):
        assert np.all(np.isnan(ft["channels"][name][bad])), name
        assert np.all(np.isfinite(ft["channels"][name][~bad])), name
    assert np.all(ft["raw_registers"][bad][:, 222 - 180] == 2)  # the status is kept raw


def test_recover_never_replaces_an_existing_recording(tmp_path):
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "200"]) as (proc, host, port):
        rig_map = rh.write_map(tmp_path, rh.tcp_device("ft_sensor", port, 9, 180, 42, 100, rh.FT_CHANNELS, counter=220))
        out = rh.acquire(tmp_path, rig_map, 0.5, extra=["--keep-journal"])
    before = open(out, "rb").read()
    p = rh.run(["recover", out + ".journal", "--out", out])
    assert_refused(p.returncode, p.stderr, out, f"{out}: --out: expected a file that does not exist yet")
    assert open(out, "rb").read() == before
    p = rh.run(["recover", out + ".journal", "--out", out, "--overwrite"])
    assert p.returncode == 0, p.stderr
    assert rh.read_recording(out)["ft_sensor"]["t_ns"].size > 10
