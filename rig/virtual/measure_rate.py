#!/usr/bin/python3
"""Maximum request rate of the virtual rig with reference clients (for bench/ and README).

    /usr/bin/python3 rig/virtual/measure_rate.py [--seconds 3] [--json]
        [--host H --port P]          # an already running rig; default: start one (--pattern ramp)
        [--mbpoll-procs 1,40]

Clients, each reading unit 9 registers 180..221 (42 registers) back to back:
  pymodbus   pymodbus 3.0 ModbusTcpClient (sync), one connection
  raw        a minimal Python socket client, one connection, one request in flight
  mbpoll xN  N concurrent `mbpoll` processes (Debian mbpoll polls at most every 10 ms,
             so one process cannot exceed ~100 req/s; N of them load the server)
Prints one line per client: name, requests, seconds, req/s, errors.
"""
import argparse
import json
import os
import re
import socket
import struct
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
UNIT, START, COUNT = 9, 180, 42


def pymodbus_rate(host, port, seconds):
    from pymodbus.client import ModbusTcpClient
    c = ModbusTcpClient(host, port=port, timeout=2)
    if not c.connect():
        raise OSError(f"cannot connect to {host}:{port}")
    n = err = 0
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        r = c.read_holding_registers(START, COUNT, slave=UNIT)
        n += 1
        err += r.isError()
    dt = time.perf_counter() - t0
    c.close()
    return n, dt, err


def raw_rate(host, port, seconds):
    s = socket.create_connection((host, port), timeout=2)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    need = 9 + 2 * COUNT
    n = err = 0
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        s.sendall(struct.pack(">HHHBBHH", n & 0xFFFF, 0, 6, UNIT, 3, START, COUNT))
        got = b""
        while len(got) < need:
            chunk = s.recv(need - len(got))
            if not chunk:
                raise OSError("connection closed")
            got += chunk
            if len(got) >= 9 and got[7] & 0x80:
                err += 1
                break
        n += 1
    dt = time.perf_counter() - t0
    s.close()
    return n, dt, err


def mbpoll_rate(host, port, seconds, procs):
    # A list of 200 times the same slave makes one mbpoll process poll back to back
    # within its poll period instead of once per period.
    slaves = ",".join([str(UNIT)] * 200)
    cmd = ["mbpoll", "-m", "tcp", "-p", str(port), "-a", slaves, "-0", "-r", str(START),
           "-c", str(COUNT), "-l", "10", "-o", "1", host]
    ps = [subprocess.Popen(["timeout", "-s", "INT", str(seconds)] + cmd, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
          for _ in range(procs)]
    n = err = 0
    for p in ps:
        out, _ = p.communicate()
        # On SIGINT mbpoll prints "T frames transmitted, R received, E errors, ..."
        m = re.search(r"(\d+) frames transmitted, (\d+) received, (\d+) errors",
                      out.decode(errors="replace"))
        if m is None:
            raise OSError("mbpoll printed no statistics")
        n += int(m.group(2))
        err += int(m.group(3))
    return n, float(seconds), err


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, default=0, help="a running rig; 0 = start one")
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--mbpoll-procs", default="1,40")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    rig = None
    host, port = a.host, a.port
    if port == 0:
        rig = subprocess.Popen([sys.executable, os.path.join(HERE, "virtual_rig.py"), "--pattern",
                                "ramp", "--port", "0"], stdout=subprocess.PIPE,
                               stderr=subprocess.DEVNULL)
        line = rig.stdout.readline().decode().split()
        if len(line) < 3 or line[0] != "READY":
            raise SystemExit("the virtual rig did not start")
        host, port = line[2].rsplit(":", 1)
        port = int(port)
    results = []
    try:
        for name, fn in (("pymodbus", pymodbus_rate), ("raw", raw_rate)):
            n, dt, err = fn(host, port, a.seconds)
            results.append({"client": name, "requests": n, "seconds": dt, "rate": n / dt, "errors": err})
        for procs in (int(x) for x in a.mbpoll_procs.split(",") if x):
            n, dt, err = mbpoll_rate(host, port, max(1, int(round(a.seconds))), procs)
            results.append({"client": f"mbpoll x{procs}", "requests": n, "seconds": dt,
                            "rate": n / dt, "errors": err})
    finally:
        if rig is not None:
            rig.terminate()
            rig.wait()
    if a.json:
        print(json.dumps(results))
    else:
        print(f"{'client':<12} {'requests':>9} {'s':>6} {'req/s':>9} {'errors':>7}")
        for r in results:
            print(f"{r['client']:<12} {r['requests']:>9} {r['seconds']:>6.2f} {r['rate']:>9.0f} {r['errors']:>7}")


if __name__ == "__main__":
    main()
