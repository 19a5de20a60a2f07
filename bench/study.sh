#!/usr/bin/env bash
# A study of 8 synthetic specimens (examples/study/make.py) through `burrbench study run
# --cores 2` (Snakemake) against the same jobs run one after another in a shell loop:
# wall time of each and their ratio (issue 16). Usage: study.sh BUILD_DIR
set -euo pipefail
source "$(dirname "$0")/prelude.bash"
/usr/bin/python3 "$here/../examples/study/make.py" "$bb" "$work/study" --specimens 8 --seed 1 --starts 4 >/dev/null
t0=$(date +%s.%N)
"$bb" study run "$work/study/study.toml" --out "$work/snakemake" --cores 2 >/dev/null 2>&1
t1=$(date +%s.%N)
mkdir -p "$work/loop/specimens"
for d in "$work"/study/P*/; do
  id=$(basename "$d")
  "$bb" calibrate "$d/experiment.toml" --out "$work/loop/specimens/$id/cal" --starts 4 --no-profiles \
    --no-cross-validation --no-discretization-check >/dev/null 2>&1
  "$bb" validate "$d/experiment.toml" --params "$work/loop/specimens/$id/cal/params.toml" \
    --fit "$work/loop/specimens/$id/cal/fit.json" --criteria "$work/study/criteria.toml" \
    --out "$work/loop/specimens/$id/gate" --no-verification >/dev/null 2>&1 || [ $? -eq 1 ]
done
"$bb" study summarize "$work/study/study.toml" --results "$work/loop" >/dev/null
t2=$(date +%s.%N)
/usr/bin/python3 - "$t0" "$t1" "$t2" <<'PY'
import os, sys
t0, t1, t2 = map(float, sys.argv[1:])
par, seq = t1 - t0, t2 - t1
print(f"study of 8 specimens (calibrate + validate each, then summarize; load average {os.getloadavg()[0]:.1f} "
      f"on {os.cpu_count()} cores)")
print(f"  study run --cores 2 (Snakemake): {par:7.1f} s")
print(f"  sequential loop:                 {seq:7.1f} s")
print(f"  ratio sequential / Snakemake:    {seq / par:7.2f} x")
PY
