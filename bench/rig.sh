#!/usr/bin/env bash
# Acquisition speed against the virtual rig (issue 4): prints figure | measured | target | ok.
#   1. two TCP devices polled at 1 kHz each for 60 s on loopback: achieved rate, period
#      jitter p99, device samples lost (counter-verified; devices sample at 500 Hz so a
#      poll on time sees every sample at least once). Meanwhile bench_host_wakeup
#      measures how late this host wakes a real-time thread, and every poll gap is
#      checked against the host's stalls.
#   1b. the same two devices drained through their FIFO blocks at 1 kHz for 60 s
#   1c. the force sensor's 96-deep FIFO, read in 12 blocks a poll at 50 Hz, 1 kHz device
#   2. maximum request rate of `burrbench acquire` vs pymodbus' sync client and mbpoll
#      (rig/virtual/measure_rate.py) on the same rig
#   3. RTU through the paced relay at 115200 baud at the rate the bus budget allows
# Usage: bench/rig.sh BUILD_DIR [SECONDS=60]. The machine may be shared: figures are
# what this run saw, not a guarantee.
set -euo pipefail
build=${1:-build}
seconds=${2:-60}
here=$(cd "$(dirname "$0")" && pwd)
src=$(dirname "$here")
export BURRBENCH="$build/apps/burrbench" BURRBENCH_SOURCE_DIR="$src"
export PROBE="$build/bench/bench_host_wakeup" JOURNAL_BENCH="$build/bench/bench_rig_journal"
cmake --build "$build" --target bench_rig_journal -j 2 >/dev/null
[[ -x "$BURRBENCH" ]] || cmake --build "$build" --target burrbench -j 2 >/dev/null
[[ -x "$PROBE" ]] || cmake --build "$build" --target bench_host_wakeup -j 2 >/dev/null
exec /usr/bin/python3 - "$seconds" <<'PY'
import json, os, subprocess, sys, tempfile
import numpy as np
src = os.environ["BURRBENCH_SOURCE_DIR"]
sys.path.insert(0, os.path.join(src, "tests", "rig"))
import rig_helpers as rh
from virtual_helpers import start_virtual_rig, start_virtual_rig_rtu

seconds = float(sys.argv[1])
# A real device answers within its own time budget, however busy the host is; the virtual
# rig is a Python process sharing this host's cores. So that the figures measure the
# acquisition and not the simulator's scheduling, the rig's own processes (server, pty
# relay, socat) get SCHED_FIFO when allowed (RIG_BENCH_RT=0 disables this).
RT = os.environ.get("RIG_BENCH_RT", "1") != "0"
rt_used = []

def realtime(pid):
    if not RT:
        return
    pids, todo = [], [pid]
    while todo:
        p = todo.pop()
        pids.append(p)
        for t in os.listdir(f"/proc/{p}/task"):
            try:
                with open(f"/proc/{p}/task/{t}/children") as f:
                    todo += [int(c) for c in f.read().split()]
            except OSError:
                pass
    for p in pids:
        r = subprocess.run(["chrt", "-a", "-f", "-p", "15", str(p)], capture_output=True)
        rt_used.append(r.returncode == 0)

def rtt_row(name, s):
    rtt = (s["t_recv_ns"] - s["t_send_ns"]) / 1e3
    row(f"{name}: reply time p50 / p99 (the rig's share)", f"{np.percentile(rtt, 50):.0f} / {np.percentile(rtt, 99):.0f} us", "-", True)
tmp = tempfile.mkdtemp(prefix="bench-rig-")
rows = []

def row(fig, measured, target, ok):
    rows.append((fig, measured, target, "yes" if ok else "NO"))

def host_stalls(text):
    """bench_host_wakeup output -> ([(cpu, deadline_ns, late_ns)], {cpu: (wakeups, worst_ns, policy)})"""
    late, done = [], {}
    for line in text.splitlines():
        f = line.split()
        if f and f[0] == "late":
            late.append((int(f[1]), int(f[2]), int(f[3])))
        elif f and f[0] == "done":
            done[int(f[1])] = (int(f[2]), int(f[3]), f[4])
    return late, done

# 1. two devices at 1 kHz for `seconds`, the host probe alongside
with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "500"]) as (proc, host, port):
    realtime(proc.pid)
    body = (rh.tcp_device("ft_sensor", port, 9, 180, 42, 1000, rh.FT_CHANNELS, counter=220)
            + rh.tcp_device("stage", port, 1, 0, 8, 1000, rh.STAGE_CHANNELS, counter=6))
    probe = subprocess.Popen([os.environ["PROBE"], str(seconds + 2), "500"], stdout=subprocess.PIPE, text=True)
    out = rh.acquire(tmp, rh.write_map(tmp, body, "two.toml"), seconds, out="two.h5", timeout=seconds + 120)
    late, done = host_stalls(probe.communicate(timeout=60)[0])
rec = rh.read_recording(out)
cpus = sorted(done)
row("host: wakeups > 0.5 / > 2 ms late per CPU (probe at SCHED_FIFO)",
    " / ".join(f"{sum(1 for c, _, _ in late if c == cpu)}, {sum(1 for c, _, l in late if c == cpu and l > 2_000_000)} of {done[cpu][0]}"
               for cpu in cpus), "-", True)
row("host: latest wakeup per CPU", " / ".join(f"{done[cpu][1] / 1e6:.1f} ms" for cpu in cpus)
    + ("" if all(done[c][2] == "fifo" for c in cpus) else " (probe not real-time)"), "-", True)
for name in ("ft_sensor", "stage"):
    s = rec[name]
    n = s["t_ns"].size
    span = (s["t_send_ns"][-1] - s["t_send_ns"][0]) / 1e9
    achieved = (n - 1) / (span * 1000.0)
    d = np.diff(s["t_send_ns"]) / 1e3 - 1000.0
    jit = np.percentile(np.abs(d), 99)
    k = np.unique(s["device_counter"])
    lost = int(k[-1] - k[0] + 1 - k.size)
    row(f"{name} 1 kHz for {seconds:.0f} s: achieved rate", f"{100 * achieved:.3f} %", ">= 99.9 %", achieved >= 0.999)
    row(f"{name}: period jitter p99", f"{jit:.0f} us", "<= 200 us", jit <= 200)
    row(f"{name}: device samples lost (counter)", f"{lost}", "0", lost == 0)
    rtt_row(name, s)
    # Polls after which device samples were missing, and how many of them the host
    # explains: some CPU woke a real-time thread > 0.5 ms late between the two polls.
    t, c = s["t_send_ns"], s["device_counter"]
    skips = np.nonzero(np.diff(c) > 1)[0]
    explained = sum(1 for i in skips if any(d - 1_000_000 < t[i + 1] and d + l > t[i] for _, d, l in late))
    row(f"{name}: polls that missed samples / during a host stall", f"{skips.size} / {explained}", "-", True)

# 1b. the same devices drained through their FIFO blocks (8 and 16 deep) at 1 kHz
with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "500"]) as (proc, host, port):
    realtime(proc.pid)
    fifo_map = rh.preset("virtual-fifo", port, rate_hz=1000).replace("device_rate_hz = 1000", "device_rate_hz = 500")
    fifo_map = fifo_map[:fifo_map.index('[[devices]]\nname = "spindle"')]  # the two FIFO devices only
    out = rh.acquire(tmp, rh.write_map(tmp, fifo_map, "fifo.toml"), seconds, out="fifo.h5", timeout=seconds + 120)
rec = rh.read_recording(out)
for name, depth in (("ft_sensor", 8), ("stage", 16)):
    s = rec[name]
    k = s["device_counter"]
    lost = int(k[-1] - k[0] + 1 - np.unique(k).size)
    polls = np.unique(s["t_send_ns"])
    row(f"FIFO {name} ({depth} deep, 500 Hz device, 1 kHz polls): samples lost", f"{lost} of {k[-1] - k[0] + 1}", "0", lost == 0)
    row(f"FIFO {name}: longest gap between polls with data / FIFO span",
        f"{np.diff(polls).max() / 1e6:.1f} ms / {depth * 2} ms", "-", True)

# 1c. the force sensor's deep FIFO (96 records, read in 12 blocks a poll) at a 1 kHz
# device rate and 50 Hz polls for `seconds`, the host probe alongside (issue 11, fault 7:
# the 8-deep FIFO spans 8 ms against host stalls of 5-60 ms on a shared VM)
with start_virtual_rig(["--pattern", "ramp", "--rate-hz", "1000", "--ft-fifo-depth", "96"]) as (proc, host, port):
    realtime(proc.pid)
    deep_map = rh.preset("virtual-fifo-deep", port)
    deep_map = deep_map[:deep_map.index('[[devices]]\nname = "stage"')]  # the force sensor only
    probe = subprocess.Popen([os.environ["PROBE"], str(seconds + 2), "500"], stdout=subprocess.PIPE, text=True)
    out = rh.acquire(tmp, rh.write_map(tmp, deep_map, "deep.toml"), seconds, out="deep.h5", timeout=seconds + 120)
    late, done = host_stalls(probe.communicate(timeout=60)[0])
rec = rh.read_recording(out)
s = rec["ft_sensor"]
k = s["device_counter"]
lost = int(k[-1] - k[0] + 1 - np.unique(k).size)
polls = np.unique(s["t_send_ns"])
row("FIFO ft_sensor (96 deep in 12 blocks, 1 kHz device, 50 Hz polls): samples lost", f"{lost} of {k[-1] - k[0] + 1}", "0", lost == 0)
row("FIFO ft_sensor deep: longest gap between polls with data / FIFO span",
    f"{np.diff(polls).max() / 1e6:.1f} ms / 96 ms", "-", True)
row("host alongside: latest wakeup per CPU", " / ".join(f"{done[c][1] / 1e6:.1f} ms" for c in sorted(done)), "-", True)

# 2. maximum request rate (42 registers, one device, back to back)
def burrbench_max(port, secs=3.0):
    body = rh.tcp_device("ft_sensor", port, 9, 180, 42, 100000, rh.FT_CHANNELS[:1], counter=220)
    out = rh.acquire(tmp, rh.write_map(tmp, body, "max.toml"), secs, out="max.h5")
    s = rh.read_recording(out)["ft_sensor"]
    os.remove(out)
    return (s["t_ns"].size - 1) / ((s["t_send_ns"][-1] - s["t_send_ns"][0]) / 1e9)

def reference_rates(port, seconds, mbpoll_procs):
    ref = json.loads(subprocess.run(["/usr/bin/python3", os.path.join(src, "rig", "virtual", "measure_rate.py"),
                                     "--port", str(port), "--seconds", str(seconds), "--mbpoll-procs", mbpoll_procs,
                                     "--json"], capture_output=True, text=True, check=True).stdout)
    return {r["client"]: r["rate"] for r in ref}

def pin(pid, cpus):
    for t in os.listdir(f"/proc/{pid}/task"):
        os.sched_setaffinity(int(t), cpus)

# Interleaved rounds, best of each client: the machine's load drifts between runs. The
# rig and every client share CPU 0: on this VM a wakeup across CPUs adds ~65 us to each
# round trip, which would measure the hypervisor rather than the client's own cost.
with start_virtual_rig(["--pattern", "ramp"]) as (proc, host, port):
    realtime(proc.pid)
    all_cpus = os.sched_getaffinity(0)
    pin(proc.pid, {0})
    os.sched_setaffinity(0, {0})  # inherited by burrbench and measure_rate.py
    best = {}
    for _ in range(3):
        rates = {"burrbench": burrbench_max(port, 2.0), **reference_rates(port, 2, "")}
        best = {k: max(v, best.get(k, 0.0)) for k, v in rates.items()}
    best.update({k: v for k, v in reference_rates(port, 3, "1").items() if k.startswith("mbpoll")})
    os.sched_setaffinity(0, all_cpus)
ours = best["burrbench"]
row("max request rate, burrbench acquire (best of 3, one CPU)", f"{ours:.0f} req/s", "-", True)
row("  vs pymodbus sync client", f"{ours / best['pymodbus']:.2f}x ({best['pymodbus']:.0f} req/s)", ">= 1", ours >= best["pymodbus"])
row("  vs mbpoll (1 process)", f"{ours / best['mbpoll x1']:.1f}x ({best['mbpoll x1']:.0f} req/s)", ">= 1", ours >= best["mbpoll x1"])
row("  the rig's capacity: a bare-socket Python client", f"{best['raw']:.0f} req/s ({ours / best['raw']:.2f}x)", "-", True)

# 3. RTU at 115200 baud through the paced relay, at the highest rate the map may ask: the
#    bus budget (docs/rig.md) allows 90 % of the bus, counting each frame's 1.75 ms silence.
poll_s = (8 + 5 + 2 * 42) * 10 / 115200.0 + 2 * 1.75e-3
req = int(0.9 / poll_s)
with start_virtual_rig_rtu(["--pattern", "ramp", "--baud", "115200"]) as (proc, pty):
    realtime(proc.pid)
    body = rh.rtu_device("ft_sensor", pty, 9, 180, 42, req, rh.FT_CHANNELS[:1], counter=220, timeout_ms=200)
    out = rh.acquire(tmp, rh.write_map(tmp, body, "rtu.toml"), 5.0, out="rtu.h5")
s = rh.read_recording(out)["ft_sensor"]
rate = (s["t_ns"].size - 1) / ((s["t_send_ns"][-1] - s["t_send_ns"][0]) / 1e9)
rtt_row("RTU", s)
row("RTU 115200 baud, 42 registers: request rate at the bus budget", f"{rate:.1f} of {req} req/s ({100 * rate / req:.1f} %)",
    ">= 95 %", rate >= 0.95 * req)

# 5. host-side cost per sample: decoding a 42-register block, journal append (+ fsync share)
jb = json.loads(subprocess.run([os.environ["JOURNAL_BENCH"], "--benchmark_format=json"], capture_output=True,
                               text=True, check=True).stdout)["benchmarks"]
cpu_us = {b["name"]: b["cpu_time"] * {"ns": 1e-3, "us": 1.0, "ms": 1e3}[b["time_unit"]] for b in jb}
real_us = {b["name"]: b["real_time"] * {"ns": 1e-3, "us": 1.0, "ms": 1e3}[b["time_unit"]] for b in jb}
row("decode a 42-register block (CPU)", f"{cpu_us['BM_DecodeFtBlock']:.3f} us", "<< 1000 us", cpu_us["BM_DecodeFtBlock"] < 100)
row("journal append, fsync every 100 samples (wall)", f"{real_us['BM_JournalAppend/100']:.1f} us", "<< 1000 us",
    real_us["BM_JournalAppend/100"] < 100)

load = os.getloadavg()[0]
w = max(len(r[0]) for r in rows)
rt = "SCHED_FIFO" if rt_used and all(rt_used) else ("partly SCHED_FIFO" if any(rt_used) else "normal priority")
print(f"\nrig acquisition bench (load average {load:.1f} on {os.cpu_count()} cores; virtual rig at {rt}; a shared machine lowers every figure)")
print(f"{'figure':<{w}} | {'measured':<40} | {'target':<10} | ok")
for r in rows:
    print(f"{r[0]:<{w}} | {r[1]:<40} | {r[2]:<10} | {r[3]}")
import shutil
shutil.rmtree(tmp, ignore_errors=True)
PY
