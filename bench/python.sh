#!/usr/bin/env bash
# Two replays from Python on two threads against the same two in sequence (issue 15: the
# module releases the GIL while the model runs). Wall time, best of 3 each, so run it on
# an otherwise idle machine; the load average is printed alongside. Usage: python.sh BUILD_DIR
set -euo pipefail
build=$(cd "${1:-build}" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
cmake --build "$build" --target burrbench burrbench_python -j 2 >/dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
sh "$here/../examples/experiments/synthetic/make.sh" "$build/apps/burrbench" "$work/exp" >/dev/null 2>&1
PYTHONPATH="$build/python" /usr/bin/python3 - "$work/exp" <<'PY'
import os, sys, threading, time
from pathlib import Path
import burrbench
d = Path(sys.argv[1])
args = (d / "experiment.toml", d / "params_true.toml", 25.0)  # a finer step: about a second each
burrbench.replay(*args)  # warm the page cache

def sequential():
    burrbench.replay(*args)
    burrbench.replay(*args)

def two_threads():
    threads = [threading.Thread(target=burrbench.replay, args=args) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()

def best(f):
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)

s, p = best(sequential), best(two_threads)
print(f"two replays from Python (load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
print(f"sequential {s:.2f} s, two threads {p:.2f} s, ratio {p / s:.2f} (target < 1; 0.5 on two idle cores)")
PY
