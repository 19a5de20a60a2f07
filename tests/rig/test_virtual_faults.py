"""Every fault-injection flag of the virtual rig has its documented, observable effect.

Raw Modbus TCP frames over a plain socket, so no client library retries or
reconnects behind our back.
"""
import socket
import struct
import time

import pytest

from virtual_helpers import events, read_served_log, start_virtual_rig


class RawClient:
    def __init__(self, host, port, timeout=2.0):
        self.sock = socket.create_connection((host, port), timeout=timeout)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.tid = 0

    def send_read(self, addr, count, unit=9):
        self.tid = (self.tid + 1) & 0xFFFF
        self.sock.sendall(struct.pack(">HHHBBHH", self.tid, 0, 6, unit, 3, addr, count))
        return self.tid

    def recv_reply(self):
        """-> (tid, function code, payload bytes)."""
        head = self._exact(7)
        tid, _, length, _unit = struct.unpack(">HHHB", head)
        body = self._exact(length - 1)
        return tid, body[0], body[1:]

    def read(self, addr, count, unit=9):
        """-> (tid, registers or ('exception', code), round-trip s)."""
        t = time.monotonic()
        sent = self.send_read(addr, count, unit)
        tid, fc, payload = self.recv_reply()
        assert tid == sent
        rtt = time.monotonic() - t
        if fc & 0x80:
            return tid, ("exception", payload[0]), rtt
        n = payload[0] // 2
        return tid, list(struct.unpack(f">{n}H", payload[1:1 + 2 * n])), rtt

    def _exact(self, n):
        buf = b""
        while len(buf) < n:
            chunk = self.sock.recv(n - len(buf))
            if not chunk:
                raise ConnectionError("closed by the rig")
            buf += chunk
        return buf

    def close(self):
        self.sock.close()


def counter(regs):
    return (regs[0] << 16) | regs[1]


def test_delay_every_reply():
    with start_virtual_rig(["--pattern", "ramp", "--delay-ms", "40"]) as (proc, host, port):
        c = RawClient(host, port)
        rtts = [c.read(220, 2)[2] for _ in range(5)]
        c.close()
    assert min(rtts) >= 0.040
    assert max(rtts) < 0.040 + 0.5


def test_late_reply_every_nth_keeps_order():
    args = ["--pattern", "ramp", "--late-reply-every", "3", "--late-ms", "250"]
    with start_virtual_rig(args) as (proc, host, port):
        c = RawClient(host, port)
        rtts = [c.read(220, 2)[2] for _ in range(6)]
        # Pipelined: request 3 is late, request 4 is sent right after it and must
        # not overtake it (a real gateway answers in order).
        c.read(220, 2)  # request 7
        c.read(220, 2)  # request 8
        t0 = c.send_read(220, 2)  # request 9: late
        t1 = c.send_read(220, 2)  # request 10
        got = [c.recv_reply()[0] for _ in range(2)]
        c.close()
    late = [rtts[2], rtts[5]]
    on_time = [rtts[i] for i in (0, 1, 3, 4)]
    assert min(late) >= 0.250
    assert max(on_time) < 0.2
    assert got == [t0, t1]


def test_exception_every_nth():
    with start_virtual_rig(["--pattern", "ramp", "--exception-every", "4"]) as (proc, host, port):
        c = RawClient(host, port)
        replies = [c.read(220, 2)[1] for _ in range(8)]
        c.close()
    for i, r in enumerate(replies, start=1):
        if i % 4 == 0:
            assert r == ("exception", 6), (i, r)  # SLAVE_DEVICE_BUSY
        else:
            assert isinstance(r, list) and len(r) == 2, (i, r)


def test_drop_every_s_closes_connections_but_keeps_listening():
    with start_virtual_rig(["--pattern", "ramp", "--drop-every-s", "0.4"]) as (proc, host, port):
        c = RawClient(host, port)
        c.read(220, 2)
        time.sleep(0.6)
        with pytest.raises((ConnectionError, OSError)):
            c.read(220, 2)
            c.read(220, 2)
        c.close()
        c = RawClient(host, port)  # the listener stayed
        assert isinstance(c.read(220, 2)[1], list)
        c.close()
        drops = events(proc, "drop")
        assert drops and drops[0]["index"] == 1 and drops[0]["connections"] >= 1


@pytest.mark.parametrize("reset", [False, True])
def test_restart_same_port_counter_continues_or_resets(reset):
    args = ["--pattern", "ramp", "--rate-hz", "1000", "--restart-at-s", "0.5",
            "--restart-down-s", "0.6"]
    if reset:
        args.append("--restart-resets-counter")
    with start_virtual_rig(args) as (proc, host, port):
        t_ready = time.monotonic()
        c = RawClient(host, port)
        before = counter(c.read(220, 2)[1])
        time.sleep(max(0.0, t_ready + 0.8 - time.monotonic()))
        with pytest.raises((ConnectionError, OSError)):
            c.read(220, 2)  # the connection was closed at 0.5 s
        c.close()
        with pytest.raises(ConnectionRefusedError):
            RawClient(host, port)  # nothing listens while down
        time.sleep(max(0.0, t_ready + 1.4 - time.monotonic()))
        c = RawClient(host, port)  # back on the same port
        after = counter(c.read(220, 2)[1])
        c.close()
        kinds = [e["kind"] for e in events(proc)]
        assert "restart-down" in kinds and "restart-up" in kinds
    if reset:
        assert after < 900  # restarted at 0 at ~1.1 s
    else:
        assert after >= 1300 and after > before  # kept counting through the outage


def test_garbage_from_a_client_does_not_hurt_the_rig():
    with start_virtual_rig(["--pattern", "ramp"]) as (proc, host, port):
        bad = socket.create_connection((host, port), timeout=2)
        bad.sendall(bytes(range(256)) * 4)  # not Modbus: bad lengths, protocol ids, functions
        bad.sendall(struct.pack(">HHHBB", 1, 0, 2, 9, 0x5A))  # an unknown function code
        time.sleep(0.2)
        bad.close()
        c = RawClient(host, port)
        assert isinstance(c.read(220, 2)[1], list)
        c.close()
        assert proc.poll() is None


def test_served_log_lists_exactly_the_replies_sent(tmp_path):
    log = tmp_path / "served.csv"
    args = ["--pattern", "ramp", "--served-log", str(log), "--exception-every", "4",
            "--late-reply-every", "3", "--late-ms", "300"]
    with start_virtual_rig(args) as (proc, host, port):
        c = RawClient(host, port)
        got = [counter(c.read(220, 2)[1]), counter(c.read(6, 2, unit=1)[1])]  # requests 1, 2
        c.send_read(220, 2)  # request 3: late; we hang up before it comes
        c.close()
        time.sleep(0.4)
        c = RawClient(host, port)
        got.append(counter(c.read(220, 2)[1]))       # new connection: request 1
        c.read(0, 4, unit=2)                          # 2
        c.read(0, 4, unit=2)                          # 3: late, delivered
        assert c.read(220, 2)[1] == ("exception", 6)  # 4: exception, not a read reply
        c.close()
    rows = read_served_log(log)
    assert [(r[1], r[2], r[3]) for r in rows] == [(9, 220, 2), (1, 6, 2), (9, 220, 2), (2, 0, 4), (2, 0, 4)]
    assert [rows[0][4], rows[1][4], rows[2][4]] == got
    assert all(a[0] <= b[0] for a, b in zip(rows, rows[1:]))
