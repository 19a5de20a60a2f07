#!/usr/bin/env bash
# Calibration figures: wall time / replays per second / iterations on the synthetic
# reference experiment (R/l = 10, two classes, plunge + sweep + polish, all nuisances
# free except depth offset, ≈ 15 s at 1 kHz), and the coverage of the 95 % intervals over
# seeded repetitions. Usage: calibration.sh BUILD_DIR [REPS]
set -euo pipefail
build=$(cd "${1:-build}" && pwd)
reps=${2:-20}
B="$build/apps/burrbench"
G="$build/bench/bench_calibration_reference"
PY=/usr/bin/python3
cmake --build "$build" --target burrbench bench_calibration_reference -j 2 > /dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# 1. speed on the reference experiment (time scale 3 ≈ 15 s of recordings)
m=$("$G" "$work/ref" "$B" 1 3)
t0=$(date +%s.%N)
/usr/bin/time -f "%U %S" -o "$work/ref.cpu" \
  "$B" calibrate --experiment "$m" --out "$work/ref/out" --no-cross-validation > "$work/ref.log" 2>&1
t1=$(date +%s.%N)
cpu=$($PY -c "u,s=open('$work/ref.cpu').read().split()[-2:]; print(f'{float(u)+float(s):.1f}')")
load=$(cut -d' ' -f1 /proc/loadavg)
read -r wall iters replays dur <<<"$($PY - "$work/ref/out/fit.json" "$t0" "$t1" "$work/ref" <<'PY'
import json, sys, glob
f = json.load(open(sys.argv[1]))
wall = float(sys.argv[3]) - float(sys.argv[2])
dur = 0.0
for t in glob.glob(sys.argv[4] + "/*.truth.json"):
    dur += json.load(open(t)).get("samples", 0) / 1000.0
print(f"{wall:.1f} {f['solver']['iterations']} {f['solver']['replays']} {dur:.1f}")
PY
)"
rps=$($PY -c "print(f'{$replays/$wall:.1f}')")

# 2. coverage of the 95 % intervals of the physics constants (and lags) over seeds
hits=0; total=0; lag_hits=0; lag_total=0
for seed in $(seq 1 "$reps"); do
  m=$("$G" "$work/cov$seed" "$B" "$seed" "${COVERAGE_TIME_SCALE:-0.5}")
  "$B" calibrate --experiment "$m" --out "$work/cov$seed/out" --no-cross-validation > /dev/null 2>&1 || { total=$((total+6)); lag_total=$((lag_total+5)); continue; }  # a failed fit covers nothing
  read -r h t lh lt <<<"$($PY - "$work/cov$seed/out/fit.json" "$work/cov$seed/truth.toml" <<'PY'
import json, sys, tomllib
f = json.load(open(sys.argv[1]))
truth = tomllib.load(open(sys.argv[2], "rb"))["classes"]
h = t = 0
for p in f["parameters"]:
    if p["fixed"]:
        continue
    tv = truth[p["class_name"]][{"alpha": "alpha_N_per_mm2", "c1": "c1_N_per_mm2", "mu": "mu"}[p["name"]]]
    t += 1
    if p["identifiable"] and p["ci95_low"] <= tv <= p["ci95_high"]:
        h += 1
lh = lt = 0
for n in f["nuisance"]:
    if n["name"] == "lag" and not n["fixed"]:
        lt += 1
        lh += n["ci95_low"] <= 4.0 <= n["ci95_high"]
print(h, t, lh, lt)
PY
)"
  hits=$((hits+h)); total=$((total+t)); lag_hits=$((lag_hits+lh)); lag_total=$((lag_total+lt))
  rm -rf "$work/cov$seed"
done
cov=$($PY -c "print(f'{100*$hits/max(1,$total):.1f}')")
lcov=$($PY -c "print(f'{100*$lag_hits/max(1,$lag_total):.1f}')")
ok() { $PY -c "import sys; print('ok' if $1 else 'FAIL')"; }
printf '%-52s %-14s %-14s %s\n' figure value target ok?
printf '%-52s %-14s %-14s %s\n' "calibrate reference (${dur} s of data) wall time" "${wall} s" "<= 60 s" "$(ok "$wall <= 60")"
printf '%-52s %-14s %-14s %s\n' "  CPU time (user+sys; load avg $load)" "${cpu} s" "-" "-"
printf '%-52s %-14s %-14s %s\n' "  replays per second" "$rps" "-" "-"
printf '%-52s %-14s %-14s %s\n' "  solver iterations" "$iters" "-" "-"
printf '%-52s %-14s %-14s %s\n' "95 % interval coverage, physics ($reps seeds)" "$cov % ($hits/$total)" ">= 90 %" "$(ok "$cov >= 90")"
printf '%-52s %-14s %-14s %s\n' "95 % interval coverage, lag ($reps seeds)" "$lcov % ($lag_hits/$lag_total)" ">= 90 %" "$(ok "$lcov >= 90")"
