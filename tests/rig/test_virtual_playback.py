"""Virtual rig playing a recording: the right sample at the right time, per device."""
import struct
import time

import h5py
import numpy as np
import pytest
from pymodbus.client import ModbusTcpClient

from virtual_helpers import PYTHON, RIG_SCRIPT, T0_NS, playback_start_ns, start_virtual_rig, write_recording


def u32(regs):
    return struct.unpack(">I", struct.pack(">HH", *regs))[0]


def floats(regs):
    return list(struct.unpack(f">{len(regs) // 2}f", struct.pack(f">{len(regs)}H", *regs)))


def i32s(regs):
    return list(struct.unpack(f">{len(regs) // 2}i", struct.pack(f">{len(regs)}H", *regs)))


def ft_row(k):
    return [0.25 * k, -0.5 * k, 1.0 + k, 10.0 * k, -1.0 * k, 2.0 * k]


def expected_index(t_rel_s, n, hz, lag_s=0.0):
    """Index of the newest sample whose time <= t (first sample before it starts)."""
    return min(n - 1, max(0, int(np.floor((t_rel_s - lag_s) * hz + 1e-9))))


def test_playback_values_and_timing(tmp_path):
    rec = tmp_path / "r.h5"
    sizes = write_recording(rec)
    with start_virtual_rig(["--recording", str(rec)]) as (proc, host, port):
        t_ready = playback_start_ns(proc) * 1e-9  # same clock as time.monotonic()
        c = ModbusTcpClient(host, port=port, timeout=2)
        assert c.connect()
        checked = 0
        while time.monotonic() - t_ready < 1.3:
            t_a = time.monotonic() - t_ready
            regs = c.read_holding_registers(200, 22, slave=9).registers
            t_b = time.monotonic() - t_ready
            k = u32(regs[20:22])
            assert floats(regs[:12]) == [struct.unpack(">f", struct.pack(">f", v))[0] for v in ft_row(k)]
            n, hz = sizes["ft"]
            lo = expected_index(t_a - 0.0005, n, hz)
            hi = expected_index(t_b + 0.0005, n, hz)
            assert lo <= k <= hi, (t_a, t_b, k)
            st = c.read_holding_registers(0, 8, slave=1).registers
            ks = u32(st[6:8])
            assert i32s(st[:6]) == [round(0.001 * ks * 1000), round((2.0 - 0.002 * ks) * 1000),
                                    round(-0.5 * ks * 1000)]
            t_c = time.monotonic() - t_ready
            m, shz = sizes["stage"]
            assert expected_index(t_b - 0.0005, m, shz, 0.1) <= ks <= expected_index(t_c + 0.0005, m, shz, 0.1)
            sp = c.read_holding_registers(0, 4, slave=2).registers
            kq = u32(sp[2:4])
            assert sp[:2] == [1000 + 10 * kq, 1]  # |rpm|, direction "-"
            checked += 1
            time.sleep(0.01)
        assert checked > 30
        # After the end the last sample is held and the counters stop.
        time.sleep(0.1)
        regs = c.read_holding_registers(220, 2, slave=9).registers
        assert u32(regs) == sizes["ft"][0] - 1
        assert u32(c.read_holding_registers(6, 2, slave=1).registers) == sizes["stage"][0] - 1
        c.close()


def test_playback_fifo_holds_newest_eight(tmp_path):
    rec = tmp_path / "r.h5"
    write_recording(rec)
    with start_virtual_rig(["--recording", str(rec)]) as (proc, host, port):
        c = ModbusTcpClient(host, port=port, timeout=2)
        assert c.connect()
        time.sleep(0.2)
        regs = c.read_holding_registers(300, 98, slave=9).registers
        newest = u32(regs[:2])
        assert newest >= 7
        got = floats(regs[2:])
        want = [struct.unpack(">f", struct.pack(">f", v))[0]
                for k in range(newest - 7, newest + 1) for v in ft_row(k)]
        assert got == want
        c.close()


def test_loop_keeps_counting(tmp_path):
    rec = tmp_path / "r.h5"
    sizes = write_recording(rec, duration_s=0.3, stage_lag_s=0.05)
    with start_virtual_rig(["--recording", str(rec), "--loop"]) as (proc, host, port):
        c = ModbusTcpClient(host, port=port, timeout=2)
        assert c.connect()
        time.sleep(0.8)
        regs = c.read_holding_registers(200, 22, slave=9).registers
        k = u32(regs[20:22])
        n = sizes["ft"][0]
        assert k > 2 * n  # two laps done, the counter did not restart
        assert floats(regs[:12]) == [struct.unpack(">f", struct.pack(">f", v))[0] for v in ft_row(k % n)]
        c.close()


def test_stale_samples_are_not_played(tmp_path):
    rec = tmp_path / "r.h5"
    write_recording(rec)
    with h5py.File(rec, "a") as f:
        n = f["streams/ft_sensor/t_ns"].shape[0]
        f["streams/ft_sensor/stale"] = (np.arange(n) % 2).astype(np.uint8)  # odd rows repeat
    with start_virtual_rig(["--recording", str(rec)]) as (proc, host, port):
        c = ModbusTcpClient(host, port=port, timeout=2)
        assert c.connect()
        time.sleep(0.3)
        regs = c.read_holding_registers(200, 22, slave=9).registers
        k = u32(regs[20:22])
        assert 20 <= k <= 40  # 100 fresh samples per second, not 200
        assert floats(regs[:12]) == [struct.unpack(">f", struct.pack(">f", v))[0] for v in ft_row(2 * k)]
        c.close()


@pytest.mark.parametrize("breakage, field", [
    ("no_streams", "/streams"),
    ("wrong_format", "/@format"),
    ("decreasing_t", "t_ns"),
    ("bad_shape", "force_N"),
    ("nan", "force_N"),
    ("text_force", "force_N"),
    ("dataset_as_stream", "/streams"),
])
def test_bad_recording_exit_2(tmp_path, breakage, field):
    import subprocess
    rec = tmp_path / "bad.h5"
    with h5py.File(rec, "w") as f:
        if breakage == "wrong_format":
            f.attrs["format"] = "burrbench.sample"
        if breakage == "dataset_as_stream":
            f["streams/ft_sensor"] = np.zeros(3)
        elif breakage != "no_streams":
            g = f.create_group("streams/ft_sensor")
            g["t_ns"] = np.array([3, 2, 1] if breakage == "decreasing_t" else [1, 2, 3], dtype=np.int64)
            force = np.zeros((3, 2) if breakage == "bad_shape" else (3, 3))
            if breakage == "nan":
                force[1, 1] = np.nan
            g["channels/force_N"] = np.array([[b"x"] * 3] * 3) if breakage == "text_force" else force
    before = rec.read_bytes()
    r = subprocess.run([PYTHON, RIG_SCRIPT, "--recording", str(rec), "--port", "0"],
                       capture_output=True, timeout=10)
    assert r.returncode == 2
    assert str(rec).encode() in r.stderr and field.encode() in r.stderr
    assert rec.read_bytes() == before


def test_plays_a_recording_written_by_burrbench(tmp_path):
    """The C++ writer's file (via `burrbench recording import`), one stream for all channels."""
    import os
    import subprocess
    exe = os.environ.get("BURRBENCH")
    if not exe:
        pytest.skip("BURRBENCH (path to the CLI) is set by CTest")
    csv = tmp_path / "r.csv"
    rows = ["t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N,tx_Nmm,ty_Nmm,tz_Nmm,spindle_rpm"]
    for i in range(400):  # 200 Hz for 2 s
        rows.append(f"{i * 0.005},{0.01 * i},{-0.02 * i},0.5,{0.25 * i},{-0.5 * i},{1 + i},"
                    f"{10 * i},{-i},{2 * i},{-1000 - 10 * i}")
    csv.write_text("\n".join(rows) + "\n")
    rec = tmp_path / "r.h5"
    subprocess.run([exe, "recording", "import", "--csv", str(csv), "--out", str(rec)],
                   check=True, capture_output=True, timeout=60)
    with start_virtual_rig(["--recording", str(rec)]) as (proc, host, port):
        c = ModbusTcpClient(host, port=port, timeout=2)
        assert c.connect()
        time.sleep(0.25)
        regs = c.read_holding_registers(200, 22, slave=9).registers
        k = u32(regs[20:22])
        assert 30 <= k <= 80
        assert floats(regs[:12]) == [struct.unpack(">f", struct.pack(">f", v))[0] for v in ft_row(k)]
        st = c.read_holding_registers(0, 8, slave=1).registers
        ks = u32(st[6:8])
        assert i32s(st[:6]) == [round(10.0 * ks), round(-20.0 * ks), 500]
        sp = c.read_holding_registers(0, 4, slave=2).registers
        assert sp[:2] == [1000 + 10 * u32(sp[2:4]), 1]
        c.close()


def test_plays_a_burrbench_synth_recording(tmp_path):
    """What `make demo` does: the rig serves a session simulated by `burrbench synth`."""
    import os
    import subprocess
    exe = os.environ.get("BURRBENCH")
    if not exe:
        pytest.skip("BURRBENCH (path to the CLI) is set by CTest")
    ex = os.path.join(os.path.dirname(RIG_SCRIPT), "..", "..", "examples")
    sample, rec = tmp_path / "sample.h5", tmp_path / "plunge.h5"
    subprocess.run([exe, "sample", "synth", "--extent-mm", "8", "8", "3", "--voxel-mm", "0.1",
                    "--compact-mm", "1.0", "--seed", "1", "--out", str(sample)],
                   check=True, capture_output=True, timeout=120)
    subprocess.run([exe, "synth", "--sample", str(sample), "--protocol",
                    os.path.join(ex, "protocols", "plunge.toml"), "--params",
                    os.path.join(ex, "experiments", "synthetic", "params_true.toml"),
                    "--out", str(rec), "--truth", str(tmp_path / "truth.json"), "--noise-N", "0.02",
                    "--seed", "11"], check=True, capture_output=True, timeout=120)
    with h5py.File(rec, "r") as f:
        fresh = f["streams/ft_sensor/stale"][...] == 0
        wrench = np.hstack([f["streams/ft_sensor/channels/force_N"][...],
                            f["streams/ft_sensor/channels/torque_Nmm"][...]])[fresh]
        pos = f["streams/stage/channels/position_mm"][...][f["streams/stage/stale"][...] == 0]
        rpm = f["streams/spindle/channels/spindle_rpm"][...][f["streams/spindle/stale"][...] == 0]
        load = f["streams/spindle/channels/spindle_torque_Nmm"][...][f["streams/spindle/stale"][...] == 0]
    assert np.ptp(load) > 0.05  # the model's cutting load, N·mm
    with start_virtual_rig(["--recording", str(rec), "--spindle-rated-Nmm", "1"]) as (proc, host, port):
        c = ModbusTcpClient(host, port=port, timeout=2)
        assert c.connect()
        seen = set()
        for _ in range(15):
            regs = c.read_holding_registers(200, 22, slave=9).registers
            k = u32(regs[20:22])
            assert floats(regs[:12]) == [float(np.float32(v)) for v in wrench[k]]
            st = c.read_holding_registers(0, 8, slave=1).registers
            assert i32s(st[:6]) == [int(round(v * 1000)) for v in pos[u32(st[6:8])]]
            sp = c.read_holding_registers(0, 5, slave=2).registers
            r = rpm[u32(sp[2:4])]
            assert sp[:2] == [int(round(abs(r))), int(r < 0)]
            # The load register: int16 in 0.1 % of the rated 1 N·mm (0.001 N·mm a count).
            assert struct.unpack(">h", struct.pack(">H", sp[4]))[0] == int(round(1000 * load[u32(sp[2:4])]))
            seen.add(k)
            time.sleep(0.05)
        assert len(seen) > 10
        c.close()
