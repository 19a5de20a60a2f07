#!/usr/bin/env bash
# Speed of the model kernel against issue 3's targets (single thread). Usage: model.sh BUILD_DIR
# Figures are CPU time per step (Google Benchmark cpu_time), so other load on the machine
# inflates them less than wall time would; the load average is printed alongside.
set -euo pipefail
build=${1:-build}
exe="$build/bench/bench_model_kernel"
cmake --build "$build" --target bench_model_kernel -j 2 >/dev/null  # never time a stale kernel
out=$(mktemp)
trap 'rm -f "$out"' EXIT
"$exe" --benchmark_format=json --benchmark_out="$out" --benchmark_out_format=json >/dev/null
/usr/bin/python3 - "$out" <<'PY'
import json, os, sys
runs = {b["name"].split("/")[0]: b for b in json.load(open(sys.argv[1]))["benchmarks"]}
def us(name):
    b = runs[name]
    scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3}[b["time_unit"]]
    return b["cpu_time"] * scale
rows = [
    ("paper R=0.75 l=0.3, depth R/4: force+erosion step", us("BM_paper_R075_l03_depth_R4"), "us", 0.3, "<="),
    ("micro-CT R=1 l=0.05, depth R/4: force+erosion step", us("BM_microct_R1_l005_depth_R4"), "us", 10.0, "<="),
    ("micro-CT R=1 l=0.05, buried: force+erosion step", us("BM_microct_R1_l005_buried"), "us", 50.0, "<="),
    ("replay 15 s at 1 kHz, R/l=10: x real time", 15e6 / us("BM_replay_15s_1kHz_R_over_l_10"), "x", 200.0, ">="),
]
print(f"model kernel speed (single thread; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
print(f"{'figure':<55} {'measured':>12} {'target':>12}  ok?")
for name, v, unit, tgt, op in rows:
    ok = v <= tgt if op == "<=" else v >= tgt
    print(f"{name:<55} {v:>10.3g} {unit:<2}{op:>3}{tgt:>7g} {unit:<2} {'ok' if ok else 'MISSED'}")
cube = us("BM_cube_microct_R1_l005_depth_R4")
print(f"{'cube quadrature, micro-CT depth R/4 step (no target)':<55} {cube:>10.3g} us = {cube / us('BM_microct_R1_l005_depth_R4'):.2f}x the lens")
PY
