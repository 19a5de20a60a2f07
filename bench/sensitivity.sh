#!/usr/bin/env bash
# Cost of the forward sensitivities: a replay with N directions against a plain replay
# (CPU time, Google Benchmark), at R/l = 10 and 20. Usage: sensitivity.sh BUILD_DIR
set -euo pipefail
build=${1:-build}
exe="$build/bench/bench_sensitivity_replay"
cmake --build "$build" --target bench_sensitivity_replay -j 2 >/dev/null
out=$(mktemp)
trap 'rm -f "$out"' EXIT
"$exe" --benchmark_format=json --benchmark_out="$out" --benchmark_out_format=json >/dev/null
/usr/bin/python3 - "$out" <<'PY'
import json, os, sys
runs = json.load(open(sys.argv[1]))["benchmarks"]
b = {x["name"]: x["cpu_time"] for x in runs}
carried = {x["name"]: int(x.get("carried", 0)) for x in runs}
print(f"replay with forward sensitivities (3 s at 1 kHz, eroding; load average {os.getloadavg()[0]:.1f})")
print(f"{'R/l':>4} {'directions':>10} {'carried':>8} {'ms':>9} {'x plain':>8} {'central differences (1+2N replays)':>36}")
for rl in (10, 20):
    plain = b[f"BM_replay/{rl}/0/1/min_time:1.000"]
    for n, derive in ((0, 1), (1, 1), (4, 1), (8, 1), (8, 0)):
        name = f"BM_replay/{rl}/{n}/{derive}/min_time:1.000"
        t = b[name]
        note = "" if derive else "   (every direction carried)"
        print(f"{rl:>4} {n:>10} {carried[name]:>8} {t:>9.1f} {t/plain:>8.2f} {1+2*n:>36}{note}")
PY
