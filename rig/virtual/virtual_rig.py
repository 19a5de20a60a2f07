#!/usr/bin/python3
"""burrbench virtual rig: a force/torque sensor, a feed stage and a spindle on Modbus.

Usage (see README.md next to this file):
  /usr/bin/python3 rig/virtual/virtual_rig.py --pattern ramp --port 0
  /usr/bin/python3 rig/virtual/virtual_rig.py --recording R.h5 --port 0
  /usr/bin/python3 rig/virtual/virtual_rig.py --pattern ramp --rtu --baud 115200
Prints `READY tcp 127.0.0.1:PORT` or `READY rtu /path/to/pty` once serving; stops on
SIGTERM/SIGINT within a fraction of a second. Exit 2 on bad arguments or input.
"""
import argparse
import asyncio
import logging
import os
import signal
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from devices import Playback, make_contexts  # noqa: E402
from server import (Faults, FaultMixin, RtuRig, ServedLog, TcpRig, log_event,  # noqa: E402
                    run_fault_schedule)
from sources import PATTERNS, PatternSource, RecordingError, RecordingSource  # noqa: E402


def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="virtual_rig.py",
        description="Serve a burrbench recording or a test pattern as Modbus devices "
                    "(unit 9 F/T sensor, unit 1 stage, unit 2 spindle).")
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--recording", metavar="R.h5", help="play this recording in real time")
    what.add_argument("--pattern", choices=sorted(PATTERNS), help="serve a deterministic pattern")
    p.add_argument("--rate-hz", type=float, default=1000.0,
                   help="device sample rate of --pattern (default 1000)")
    p.add_argument("--stage-rate-hz", type=float, default=0.0,
                   help="sample rate of the stage (unit 1) with --pattern; default --rate-hz")
    p.add_argument("--spindle-rate-hz", type=float, default=0.0,
                   help="sample rate of the spindle (unit 2) with --pattern; default --rate-hz")
    p.add_argument("--spindle-rated-Nmm", type=float, default=10.0,
                   help="rated torque of the spindle drive (N·mm): its load register (unit 2, address 4) "
                        "counts 0.1 %% of it, like a VFD (default 10: 0.01 N·mm a count)")
    p.add_argument("--loop", action="store_true",
                   help="repeat the recording (counters keep counting); default: hold the last sample")
    p.add_argument("--host", default="127.0.0.1", help="TCP address to bind (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=0, help="TCP port, 0 = a free one (default)")
    p.add_argument("--rtu", action="store_true", help="serve Modbus RTU on a pty pair instead of TCP")
    p.add_argument("--baud", type=int, default=115200, help="RTU baud rate, paced 8N1 (default 115200)")
    f = p.add_argument_group("fault injection (deterministic; counts are per connection, 1-based)")
    f.add_argument("--delay-ms", type=float, default=0.0, help="added delay before every reply")
    f.add_argument("--late-reply-every", type=int, default=0, metavar="N",
                   help="every Nth request is answered --late-ms later")
    f.add_argument("--late-ms", type=float, default=0.0, help="extra delay of a late reply")
    f.add_argument("--exception-every", type=int, default=0, metavar="N",
                   help="every Nth request gets exception 06 SLAVE_DEVICE_BUSY")
    f.add_argument("--drop-every-s", type=float, default=0.0, metavar="X",
                   help="close all TCP connections every X s (the listener stays)")
    f.add_argument("--late-sample-every", type=int, default=0, metavar="N",
                   help="every Nth request is read (and answered) --late-sample-ms later")
    f.add_argument("--late-sample-ms", type=float, default=0.0, help="how late, in ms")
    f.add_argument("--status-every", type=int, default=0, metavar="N",
                   help="the force sensor's status word (register 222) sets its overload bit (0x0002) "
                        "on every Nth sample (sample index k with k %% N == 0)")
    f.add_argument("--wrong-unit-every", type=int, default=0, metavar="N",
                   help="every Nth reply carries the unit id + 1 (TCP)")
    f.add_argument("--busy-at-s", type=float, default=0.0, metavar="X",
                   help="from X s after READY every read is answered SLAVE_DEVICE_BUSY ...")
    f.add_argument("--busy-for-s", type=float, default=0.0, metavar="Y",
                   help="... for Y s (default 0: never busy)")
    f.add_argument("--restart-at-s", type=float, default=0.0, metavar="X",
                   help="at X s stop serving (TCP: close listener and connections; RTU: fall silent)")
    f.add_argument("--restart-down-s", type=float, default=1.0, metavar="Y",
                   help="then come back on the same port after Y s (default 1)")
    f.add_argument("--restart-resets-counter", action="store_true",
                   help="after the restart counters start again at 0 (default: they continue)")
    p.add_argument("--counter-start", type=int, default=0, metavar="N",
                   help="device counters start at N instead of 0 (e.g. 65236: a uint16 counter read "
                        "from the low word wraps 0.3 s in at 1 kHz)")
    p.add_argument("--ft-fifo-depth", type=int, default=0, metavar="N",
                   help="unit 9 also serves a deep FIFO of N records from register 1000 (counter) "
                        "and 1002 (records of 14 registers: u32 counter, Fx..Tz float32), read in "
                        "several blocks (default 0: off)")
    p.add_argument("--stage-fifo-depth", type=int, default=0, metavar="N",
                   help="unit 1 also serves a deep FIFO of N records from register 1000 (counter) "
                        "and 1002 (records of 8 registers: u32 counter, x, y, z int32 um) (default 0: off)")
    p.add_argument("--served-log", metavar="FILE",
                   help="write one CSV line per read reply sent: t_mono_ns,unit,address,count,counter")
    p.add_argument("-v", "--verbose", action="store_true", help="pymodbus debug logging")
    a = p.parse_args(argv)
    bad = []
    if a.rate_hz <= 0 or a.rate_hz > 100000:
        bad.append("--rate-hz: expected 0 < rate <= 100000")
    for name in ("stage_rate_hz", "spindle_rate_hz"):
        if getattr(a, name) < 0 or getattr(a, name) > 100000:
            bad.append(f"--{name.replace('_', '-')}: expected 0 < rate <= 100000")
    if not (a.spindle_rated_Nmm > 0) or a.spindle_rated_Nmm > 1e9:
        bad.append("--spindle-rated-Nmm: expected 0 < torque <= 1e9 (N·mm)")
    if not 0 <= a.port <= 65535:
        bad.append("--port: expected 0..65535")
    if a.baud <= 0:
        bad.append("--baud: expected > 0")
    for name in ("delay_ms", "late_ms", "drop_every_s", "restart_at_s", "restart_down_s", "busy_at_s", "busy_for_s",
                 "late_sample_ms"):
        if getattr(a, name) < 0:
            bad.append(f"--{name.replace('_', '-')}: expected >= 0")
    for name in ("late_reply_every", "exception_every", "wrong_unit_every", "status_every", "late_sample_every"):
        if getattr(a, name) < 0:
            bad.append(f"--{name.replace('_', '-')}: expected >= 0")
    if a.late_reply_every and a.late_ms <= 0:
        bad.append("--late-ms: expected > 0 with --late-reply-every")
    for name in ("ft_fifo_depth", "stage_fifo_depth"):
        if not 0 <= getattr(a, name) <= 4000:
            bad.append(f"--{name.replace('_', '-')}: expected 0..4000")
    if not 0 <= a.counter_start < 2 ** 32:
        bad.append("--counter-start: expected 0 <= N < 2^32 (the counter registers are uint32)")
    if a.rtu and a.drop_every_s:
        bad.append("--drop-every-s: expected TCP (an RTU line has no connection to drop)")
    if bad:
        p.error("; ".join(bad))
    return a


async def serve(args, source):
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    faults = Faults(args.delay_ms, args.late_reply_every, args.late_ms, args.exception_every,
                    args.drop_every_s, args.restart_at_s, args.restart_down_s,
                    args.restart_resets_counter, args.busy_at_s, args.busy_for_s, args.wrong_unit_every,
                    args.late_sample_every, args.late_sample_ms)
    playback = Playback(source, args.counter_start, args.status_every, args.ft_fifo_depth, args.stage_fifo_depth,
                        args.spindle_rated_Nmm)
    contexts = make_contexts(playback)
    served = ServedLog(args.served_log, playback) if args.served_log else None
    FaultMixin.served_log = served
    link = None
    if args.rtu:
        from rtu_link import RtuLink
        link = RtuLink(args.baud)
        try:
            link.start()
            rig = RtuRig(contexts, link.server_path, args.baud, faults)
            await rig.start()
        except Exception:
            link.stop()
            raise
        ready = f"READY rtu {link.client_path}"
    else:
        rig = TcpRig(contexts, args.host, args.port, faults)
        await rig.start()
        ready = f"READY tcp {args.host}:{rig.port}"
    # Playback (sample 0) and the fault schedule start when we announce READY.
    playback.restart_clock()
    faults.start_ns = playback.start_ns
    log_event("start", playback_start_ns=playback.start_ns)
    tasks = await run_fault_schedule(rig, playback, faults)
    if served is not None:
        tasks.append(asyncio.create_task(flush_every(served, 0.1)))
    print(ready, flush=True)
    try:
        await stop.wait()
    finally:
        for t in tasks:
            t.cancel()
        await rig.stop()
        if link is not None:
            link.stop()
        if served is not None:
            served.close()


async def flush_every(log, period_s):
    while True:
        await asyncio.sleep(period_s)
        log.flush()


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.CRITICAL)
    # pymodbus logs every cancelled handler (each client disconnect) as an ERROR.
    logging.getLogger("pymodbus").setLevel(logging.DEBUG if args.verbose else logging.CRITICAL)
    try:
        source = (RecordingSource(args.recording, loop=args.loop) if args.recording
                  else PatternSource(args.pattern, args.rate_hz,
                                     {"stage": args.stage_rate_hz, "spindle": args.spindle_rate_hz}))
    except RecordingError as exc:
        print(f"virtual_rig: {exc}", file=sys.stderr)
        return 2
    try:
        asyncio.run(serve(args, source))
    except OSError as exc:
        print(f"virtual_rig: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
