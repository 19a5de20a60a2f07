"""Virtual rig over Modbus TCP: start/stop, register layout (CONTRACTS E), read-only."""
import signal
import struct
import time

import pytest
from pymodbus.client import ModbusTcpClient

from virtual_helpers import playback_start_ns, start_virtual_rig


def regs_to_bytes(regs):
    return struct.pack(f">{len(regs)}H", *regs)


def f32(regs):  # ABCD
    return struct.unpack(">f", regs_to_bytes(regs))[0]


def u32(regs):  # ABCD
    return struct.unpack(">I", regs_to_bytes(regs))[0]


def i32(regs):  # ABCD
    return struct.unpack(">i", regs_to_bytes(regs))[0]


def i16(r):
    return struct.unpack(">h", struct.pack(">H", r))[0]


def as_f32(x):
    return struct.unpack(">f", struct.pack(">f", x))[0]


# The documented `ramp` pattern (rig/virtual/README.md), written out independently.
def ramp_ft(k):
    j = k % 10000
    return (0.01 * j, -0.02 * j, 0.03 * j, 1.0 * j, -2.0 * j, 3.0 * j)


def ramp_stage_um(k):
    return (k, -2 * k, 3 * k)


def ramp_spindle(k):
    j = k % 10000
    return (j + 1, (k // 10000) % 2)


@pytest.fixture
def client_of():
    clients = []

    def make(host, port):
        c = ModbusTcpClient(host, port=port, timeout=2)
        assert c.connect()
        clients.append(c)
        return c

    yield make
    for c in clients:
        c.close()


def read(c, addr, count, unit):
    r = c.read_holding_registers(addr, count, slave=unit)
    assert not r.isError(), r
    return r.registers


def test_ready_line_and_prompt_shutdown(client_of):
    for sig in (signal.SIGTERM, signal.SIGINT):
        with start_virtual_rig(["--pattern", "constants"]) as (proc, host, port):
            assert host == "127.0.0.1" and port > 0
            c = client_of(host, port)  # a connected client must not delay shutdown
            read(c, 180, 6, 9)
            t = time.monotonic()
            proc.send_signal(sig)
            proc.wait(5)
            assert time.monotonic() - t < 2.0
            assert proc.returncode == 0


def test_constants_every_block_and_word_order(client_of):
    with start_virtual_rig(["--pattern", "constants"]) as (proc, host, port):
        c = client_of(host, port)
        ft = read(c, 180, 6, 9)
        assert [i16(r) for r in ft] == [150, -225, 10000, 250, -500, 1000]
        fl = read(c, 200, 12, 9)
        assert [f32(fl[i:i + 2]) for i in range(0, 12, 2)] == [1.5, -2.25, 100.0, 250.0, -500.0, 1000.0]
        const = read(c, 400, 18, 9)
        b = [regs_to_bytes(const[i:i + 2]) for i in range(0, 8, 2)]
        assert struct.unpack(">f", b[0])[0] == 123456.0                           # ABCD
        assert struct.unpack(">f", b[1][2:] + b[1][:2])[0] == 123456.0            # CDAB
        assert struct.unpack(">f", bytes([b[2][1], b[2][0], b[2][3], b[2][2]]))[0] == 123456.0  # BADC
        assert struct.unpack("<f", b[3])[0] == 123456.0                           # DCBA
        bi = [regs_to_bytes(const[10 + i:12 + i]) for i in range(0, 8, 2)]
        assert struct.unpack(">i", bi[0])[0] == 123456
        assert struct.unpack(">i", bi[1][2:] + bi[1][:2])[0] == 123456
        assert struct.unpack(">i", bytes([bi[2][1], bi[2][0], bi[2][3], bi[2][2]]))[0] == 123456
        assert struct.unpack("<i", bi[3])[0] == 123456
        stage = read(c, 0, 8, 1)
        assert [i32(stage[i:i + 2]) for i in (0, 2, 4)] == [12345, -6789, 100000]
        spindle = read(c, 0, 4, 2)
        assert spindle[:2] == [30000, 1]


def test_saturation_never_wraps(client_of):
    with start_virtual_rig(["--pattern", "saturate"]) as (proc, host, port):
        c = client_of(host, port)
        assert [i16(r) for r in read(c, 180, 6, 9)] == [32767, -32767, 50, 32767, -32767, 0]
        stage = read(c, 0, 6, 1)
        assert [i32(stage[i:i + 2]) for i in (0, 2, 4)] == [2**31 - 1, -(2**31), 0]
        assert read(c, 0, 2, 2) == [65535, 0]


def test_nonfinite_floats_and_clamped_integers(client_of):
    import math
    with start_virtual_rig(["--pattern", "nonfinite"]) as (proc, host, port):
        c = client_of(host, port)
        fl = read(c, 200, 12, 9)
        got = [f32(fl[i:i + 2]) for i in range(0, 12, 2)]
        assert math.isnan(got[0]) and got[1] == math.inf and got[2] == -math.inf
        assert math.isnan(got[3]) and got[4:] == [0.0, 0.0]
        assert [i16(r) for r in read(c, 180, 6, 9)] == [0, 32767, -32767, 0, 0, 0]
        stage = read(c, 0, 6, 1)
        assert [i32(stage[i:i + 2]) for i in (0, 2, 4)] == [0, 2**31 - 1, -(2**31)]
        assert read(c, 0, 2, 2) == [0, 0]


def test_ramp_one_consistent_sample_per_read(client_of):
    with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "1000"]) as (proc, host, port):
        c = client_of(host, port)
        seen = set()
        for _ in range(50):
            regs = read(c, 180, 42, 9)  # int16, float32 and counter in one request
            k = u32(regs[40:42])
            want = ramp_ft(k)
            assert [i16(r) for r in regs[0:6]] == [round(want[0] * 100), round(want[1] * 100),
                                                  round(want[2] * 100), want[3], want[4], want[5]]
            assert [f32(regs[20 + i:22 + i]) for i in range(0, 12, 2)] == [as_f32(v) for v in want]
            fifo = read(c, 300, 98, 9)
            newest = u32(fifo[0:2])
            for s in range(8):
                k_s = newest - 7 + s
                got = [f32(fifo[2 + 12 * s + i:4 + 12 * s + i]) for i in range(0, 12, 2)]
                assert got == ([as_f32(v) for v in ramp_ft(k_s)] if k_s >= 0 else [0.0] * 6)
            stage = read(c, 0, 8, 1)
            ks = u32(stage[6:8])
            assert tuple(i32(stage[i:i + 2]) for i in (0, 2, 4)) == ramp_stage_um(ks)
            sfifo = read(c, 100, 98, 1)  # stage FIFO: 16 positions of 6 registers
            newest = u32(sfifo[0:2])
            assert newest >= ks
            for s in range(16):
                k_s = newest - 15 + s
                got = tuple(i32(sfifo[2 + 6 * s + i:4 + 6 * s + i]) for i in (0, 2, 4))
                assert got == (ramp_stage_um(k_s) if k_s >= 0 else (0, 0, 0))
            sp = read(c, 0, 4, 2)
            assert tuple(sp[:2]) == ramp_spindle(u32(sp[2:4]))
            seen.add(k)
            time.sleep(0.003)
        assert len(seen) > 20  # the counter really advances


def test_counter_follows_rate(client_of):
    """Device sample k is taken at playback_start_ns + k/rate, each device at its own rate."""
    args = ["--pattern", "ramp", "--rate-hz", "500", "--spindle-rate-hz", "100"]
    with start_virtual_rig(args) as (proc, host, port):
        t0 = playback_start_ns(proc)
        c = client_of(host, port)
        for _ in range(20):
            for unit, addr, rate in ((9, 220, 500), (1, 6, 500), (2, 2, 100)):
                before = time.monotonic_ns()
                k = u32(read(c, addr, 2, unit))
                after = time.monotonic_ns()
                assert (before - t0) * rate // 10**9 <= k <= (after - t0) * rate // 10**9
            time.sleep(0.02)


def test_writes_refused_and_bad_reads(client_of):
    with start_virtual_rig(["--pattern", "constants"]) as (proc, host, port):
        c = client_of(host, port)
        before = read(c, 180, 6, 9)
        r = c.write_register(180, 1, slave=9)
        assert r.isError() and r.exception_code == 1  # ILLEGAL_FUNCTION
        r = c.write_registers(0, [1, 2], slave=1)
        assert r.isError() and r.exception_code == 1
        r = c.write_coil(0, True, slave=2)
        assert r.isError() and r.exception_code == 1
        assert read(c, 180, 6, 9) == before
        r = c.read_holding_registers(415, 10, slave=9)  # past the end of unit 9
        assert r.isError() and r.exception_code == 2  # ILLEGAL_DATA_ADDRESS
        r = c.read_holding_registers(197, 2, slave=1)
        assert r.isError() and r.exception_code == 2


def test_unknown_unit_gets_no_reply():
    with start_virtual_rig(["--pattern", "constants"]) as (proc, host, port):
        c = ModbusTcpClient(host, port=port, timeout=1, retries=0)
        assert c.connect()
        r = c.read_holding_registers(0, 1, slave=5)
        assert r.isError()
        assert not hasattr(r, "exception_code")  # a timeout, not an exception reply
        c.close()


def test_bad_arguments_exit_2(tmp_path):
    import subprocess
    from virtual_helpers import PYTHON, RIG_SCRIPT
    r = subprocess.run([PYTHON, RIG_SCRIPT, "--pattern", "ramp", "--rate-hz", "-1"],
                       capture_output=True, timeout=10)
    assert r.returncode == 2 and b"--rate-hz" in r.stderr
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not hdf5")
    r = subprocess.run([PYTHON, RIG_SCRIPT, "--recording", str(bad)], capture_output=True, timeout=10)
    assert r.returncode == 2 and str(bad).encode() in r.stderr
