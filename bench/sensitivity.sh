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
b = {x["name"]: x["cpu_time"] for x in json.load(open(sys.argv[1]))["benchmarks"]}
print(f"replay with forward sensitivities (3 s at 1 kHz, eroding; load average {os.getloadavg()[0]:.1f})")
print(f"{'R/l':>4} {'directions':>10} {'ms':>9} {'x plain':>8} {'central differences (1+2N replays)':>36}")
for rl in (10, 20):
    plain = b[f"BM_replay/{rl}/0/min_time:1.000"]
    for n in (0, 1, 4, 8):
        t = b[f"BM_replay/{rl}/{n}/min_time:1.000"]
        print(f"{rl:>4} {n:>10} {t:>9.1f} {t/plain:>8.2f} {1+2*n:>36}")
PY
