#!/usr/bin/env bash
# Fuzzes the NRRD, MetaImage, CSV-recording, experiment-manifest (TOML) and fit (JSON)
# parsers with libFuzzer (clang, AddressSanitizer + UndefinedBehaviorSanitizer) for a set
# time each and prints
#   figure (execs) | target (no finding) | ok?
# Usage: bench/fuzz.sh [SECONDS]      (default 60 per target; env FUZZ_SECONDS also works)
# `make fuzz` runs it (`make bench` does not). Env FUZZ_TARGETS (space-separated) runs a
# subset. A non-number $1 is ignored. The fuzz build lives in its own dir (env
# FUZZ_BUILD, default build-fuzz). Seeds are written here, the
# growing corpus and any crash artifacts land in $FUZZ_BUILD/fuzz-work/<target>/.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
secs=${FUZZ_SECONDS:-60}
if [[ ${1:-} =~ ^[0-9]+$ ]]; then secs=$1; fi
build=${FUZZ_BUILD:-$root/build-fuzz}
PYTHON=/usr/bin/python3
targets=(fuzz_nrrd fuzz_metaimage fuzz_csv fuzz_manifest fuzz_fit_json)
if [[ -n ${FUZZ_TARGETS:-} ]]; then read -r -a targets <<<"$FUZZ_TARGETS"; fi  # e.g. FUZZ_TARGETS=fuzz_fit_json

log=$(mktemp)
trap 'rm -f "$log"' EXIT
if ! { cmake -S "$root" -B "$build" -DBURRBENCH_FUZZ=ON -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
         -DCMAKE_BUILD_TYPE=RelWithDebInfo -DBURRBENCH_WERROR=OFF &&
       cmake --build "$build" --target "${targets[@]}" -j 2; } >"$log" 2>&1; then
  cat "$log" >&2
  echo "fuzz.sh: build failed" >&2
  exit 1
fi

work=$build/fuzz-work
seed() {  # seed TARGET NAME < bytes
  mkdir -p "$work/$1/seeds"
  cat >"$work/$1/seeds/$2"
}
marker() { printf '\0\0FILE\0\0'; }

# --- seeds (small valid inputs; the fuzzer mutates from here) ---
{ printf 'NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,0.5)\nspace origin: (1,2,3)\n\n'
  printf '\0\1\2\1\0\1\2\1'; } | seed fuzz_nrrd attached_raw
{ printf 'NRRD0005\n# c\ntype: short\ndimension: 3\nsizes: 2 1 2\nendian: big\nencoding: gzip\nspace: left-posterior-superior\nspace directions: (-1,0,0) (0,1,0) (0,0,2)\nspace origin: (0,0,0)\nkinds: domain domain domain\nk:=v\n\n'
  printf '\0\1\0\2\1\0\377\377' | gzip -c; } | seed fuzz_nrrd attached_gzip
{ printf 'NRRD0004\ntype: float\ndimension: 3\nsizes: 1 1 2\nendian: little\nencoding: raw\nspacings: 1 1 1\nbyte skip: -1\ndata file: d.raw\n'
  marker; printf '\0\0\0\077\0\0\200\077'; } | seed fuzz_nrrd detached_float
{ printf 'ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nCompressedData = False\nTransformMatrix = 1 0 0 0 1 0 0 0 1\nOffset = 0 0 0\nElementSpacing = 0.1 0.1 0.1\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n'
  printf '\0\1\2\1\0\1\2\1'; } | seed fuzz_metaimage mha
{ printf 'ObjectType = Image\nNDims = 3\nElementByteOrderMSB = True\nCompressedData = True\nElementSpacing = 1 1 2\nOffset = 1 2 3\nDimSize = 2 1 1\nElementType = MET_SHORT\nElementDataFile = d.zraw\n'
  marker; printf '\0\1\377\376' | gzip -c; } | seed fuzz_metaimage mhd_zraw
printf 't_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N,tx_Nmm,ty_Nmm,tz_Nmm,spindle_rpm\n0,1,2,3,4,5,6,7,8,9,60000\n0.001,1.5,2,3,4e-1,5,6,7,8,9,60000\n' \
  | seed fuzz_csv canonical
{ printf 'LabVIEW\nTime (ms)\tX [um]\tY\tZ\tFx\tFy\tFz\tnote\n0\t1\t2\t3\t0,5\t5\t6\t"a\tb"\n2\t1\t2\t3\t1,5\t5\t6\tx\n'
  marker
  printf 'format = "burrbench.csv_map"\nformat_version = "1.0"\ndelimiter = "\\t"\ndecimal = ","\nheader_line = 2\n'
  printf '[columns."Time (ms)"]\nchannel = "t_s"\nunit = "ms"\n[columns."X [um]"]\nchannel = "x_mm"\nunit = "um"\n'
  printf '[columns.Y]\nchannel = "y_mm"\n[columns.Z]\nchannel = "z_mm"\noffset = 1.0\n[columns.Fx]\nchannel = "fx_N"\nscale = -1.0\n'
  printf '[columns.Fy]\nchannel = "fy_N"\nunit = "kN"\n[columns.Fz]\nchannel = "fz_N"\n'; } | seed fuzz_csv labview_map
cat <<'TOML' | seed fuzz_manifest contracts_example
format = "burrbench.experiment"
format_version = "1.0"
name = "demo"
description = "free text"
[[samples]]
id = "S1"
path = "sample.h5"
[burr]
radius_mm = 1.0
shaft_axis_rig = [0.0, 0.0, 1.0]
spin_sign = 1
tool_offset_mm = [0.0, 0.0, 0.0]
[sensor]
rotation_sensor_to_rig = [[1,0,0],[0,1,0],[0,0,1]]
measures = "force_on_sample"
sigma_N = 0.02
[[recordings]]
id = "plunge"
path = "plunge.h5"
sample = "S1"
role = "calibrate"
lag_ms = 0.0
  [recordings.registration]
  rotation = [[1,0,0],[0,1,0],[0,0,1]]
  translation_mm = [0.0, 0.0, 0.0]
  [[recordings.segments]]
  start_s = 0.0
  end_s = 5.0
  use = true
  label = "plunge"
[[recordings]]
id = "sweep"
path = "sweep.h5"
sample = "S1"
role = "validate"
  [recordings.registration]
  fiducials_rig_mm = [[0,0,0],[1,0,0],[0,1,0]]
  fiducials_vol_mm = [[1,0,0],[2,0,0],[1,1,0]]
[fit]
loss = "huber"
loss_scale = 3.0
buried = "exclude"
seed = 1
multistart = 4
  [fit.classes.compact]
  alpha = { initial = 20.0, lower = 0.1, upper = 1000.0, fixed = false }
  c1    = { initial = 10.0, lower = 0.01, upper = 1000.0 }
  mu    = { initial = 0.3,  lower = 0.01, upper = 2.0 }
  [fit.nuisance]
  bias = true
  lag = true
  lag_bounds_ms = [-20.0, 20.0]
  depth_offset = false
TOML

# Nesting seeds (issue 12): 20 000 levels of dotted keys, inline tables and arrays (toml++
# recursed once per level and overflowed the stack before the nesting pre-scan).
"$PYTHON" - "$work/fuzz_manifest/seeds" <<'PY'
import os, sys
d = sys.argv[1]
os.makedirs(d, exist_ok=True)
n = 20000
seeds = {"nest_dotted": "a" + ".a" * n + " = 1\n",
         "nest_inline": "a = " + "{b = " * (n // 3) + "1" + "}" * (n // 3) + "\n",
         "nest_array": "a = " + "[" * n + "]" * n + "\n"}
for name, text in seeds.items():
    open(os.path.join(d, name), "w").write('format = "burrbench.experiment"\nformat_version = "1.0"\n' + text)
PY

# The fit seed: a whole fit.json as calibrate writes it (from the regular build's fixture
# writer when it exists), and the same nesting bombs in JSON.
bb=${BURRBENCH:-$root/build/apps/burrbench}
if [[ -x $bb ]]; then
  fx=$(mktemp -d)
  "$bb" debug write-fixtures "$fx" >/dev/null 2>&1 && [[ -f $fx/fit.json ]] && seed fuzz_fit_json fixture <"$fx/fit.json"
  rm -rf "$fx"
fi
printf '{"format": "burrbench.fit", "format_version": "1.0", "parameters": [], "nuisance": [], "x": null}\n' \
  | seed fuzz_fit_json minimal
"$PYTHON" - "$work/fuzz_fit_json/seeds" <<'PY'
import os, sys
d = sys.argv[1]
os.makedirs(d, exist_ok=True)
n = 20000
for name, text in {"nest_array": "[" * n + "]" * n, "nest_object": '{"a":' * n + "1" + "}" * n}.items():
    open(os.path.join(d, name), "w").write('{"format": "burrbench.fit", "format_version": "1.0", "x": ' + text + "}")
PY

# --- run ---
printf '%-40s | %-32s | %s\n' "figure (execs in ${secs} s)" "target" "ok?"
status=0
for t in "${targets[@]}"; do
  d=$work/$t
  mkdir -p "$d/corpus" "$d/artifacts"
  set +e
  ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 UBSAN_OPTIONS=print_stacktrace=1 \
    "$build/bench/$t" -max_total_time="$secs" -max_len=65536 -rss_limit_mb=2048 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$d/artifacts/" "$d/corpus" "$d/seeds" >"$d/log" 2>&1
  rc=$?
  set -e
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$d/log" | grep -o '[0-9]*$' | tail -1)
  if [[ $rc -eq 0 ]] && ! grep -q 'ERROR: \|runtime error:' "$d/log"; then
    printf '%-40s | %-32s | %s\n' "$t: ${execs:-?} execs" "no finding in ${secs} s" "ok"
  else
    status=1
    printf '%-40s | %-32s | %s\n' "$t: ${execs:-?} execs" "no finding in ${secs} s" "NO: FINDING (see $d/log)"
  fi
done
exit $status
