#!/usr/bin/env bash
# Fuzzes every parser a user's file reaches with libFuzzer (clang, AddressSanitizer +
# UndefinedBehaviorSanitizer), for a set time each, and prints per target
#   target | executions (per second) | finding? | ok?
# Targets (bench/fuzz/fuzz_*.cpp): NRRD, MetaImage, TIFF/PNG slices, Scanco ISQ, CSV
# recordings, the CSV column map, the experiment manifest, the study manifest, parameter
# sets, fit results (JSON), acceptance criteria, density phantoms, sensor loads, register
# maps, tare files, protocols, acquisition journals (as `recover` reads them) and the HDF5
# readers (recording, sample, prediction) through an in-memory file image.
# Usage: bench/fuzz.sh [SECONDS]      (default 60 per target; env FUZZ_SECONDS also works;
# env FUZZ_JOBS runs that many targets at once, default 1)
# `make fuzz` runs it (`make bench` does not). Env FUZZ_TARGETS (space-separated) runs a
# subset. A non-number $1 is ignored. The fuzz build lives in its own dir (env
# FUZZ_BUILD, default build-fuzz). Seeds are written here (the binary ones by
# fuzz_seed_writer, i.e. burrbench's own writers), the growing corpus and any crash
# artifacts land in $FUZZ_BUILD/fuzz-work/<target>/. Run it under `nice` on a shared machine.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
secs=${FUZZ_SECONDS:-60}
if [[ ${1:-} =~ ^[0-9]+$ ]]; then secs=$1; fi
build=${FUZZ_BUILD:-$root/build-fuzz}
PYTHON=/usr/bin/python3
targets=(fuzz_nrrd fuzz_metaimage fuzz_slices fuzz_isq fuzz_csv fuzz_csv_map fuzz_manifest fuzz_study fuzz_params
         fuzz_fit_json fuzz_criteria fuzz_density fuzz_sensor_loads fuzz_rig_map fuzz_tare fuzz_protocol fuzz_journal
         fuzz_recording_h5 fuzz_sample_h5 fuzz_prediction_h5)
if [[ -n ${FUZZ_TARGETS:-} ]]; then read -r -a targets <<<"$FUZZ_TARGETS"; fi  # e.g. FUZZ_TARGETS=fuzz_fit_json

log=$(mktemp)
trap 'rm -f "$log"' EXIT
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache); fi
if ! { cmake -S "$root" -B "$build" -DBURRBENCH_FUZZ=ON -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
         -DCMAKE_BUILD_TYPE=RelWithDebInfo -DBURRBENCH_WERROR=OFF "${launcher[@]}" &&
       cmake --build "$build" --target "${targets[@]}" fuzz_seed_writer -j 2; } >"$log" 2>&1; then
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

# --- seeds of the targets added in issue 59 ---
# Files of the repository that are valid inputs as they stand.
for f in "$root"/examples/experiments/*/params_true.toml; do seed fuzz_params "$(basename "$(dirname "$f")")" <"$f"; done
seed fuzz_criteria release <"$root/examples/criteria/release.toml"
printf 'format = "burrbench.criteria"\nformat_version = "1.0"\n[[criterion]]\nmetric = "rmse"\naxis = ["x", "magnitude"]\nmax = 0.5\ndata = "calibrate"\nsegment = "plunge"\n' \
  | seed fuzz_criteria minimal
for f in "$root"/examples/rigs/*.toml; do seed fuzz_rig_map "$(basename "$f" .toml)" <"$f"; done
for f in "$root"/examples/protocols/*.toml "$root"/examples/experiments/demo/{plunge,polish,sweep}.toml; do
  seed fuzz_protocol "$(basename "$(dirname "$f")")_$(basename "$f" .toml)" <"$f"
done
printf 'format = "burrbench.tare"\nformat_version = "1.0"\ndevice = "ft_sensor"\nsamples = 200\nt_monotonic_ns = 123456789\nt_wall_ns = 1790000000000000000\nrig_sha256 = "00"\nbias = [0.3, -0.1, 2.0, 15.0, -8.0, 3.0]\nstddev = [0.01, 0.01, 0.02, 0.5, 0.5, 0.4]\n' \
  | seed fuzz_tare written
printf 'format = "burrbench.density"\nformat_version = "1.0"\ntissue_density_mg_cm3 = 1200\n[[rod]]\ndensity_mg_cm3 = 0\ncenter_mm = [1, 1, 1.5]\nradius_mm = 0.6\nlength_mm = 2.0\n[[rod]]\ndensity_mg_cm3 = 800\ncenter_mm = [3, 1, 1.5]\nradius_mm = 0.6\n' \
  | seed fuzz_density rods
printf 'format = "burrbench.density"\nformat_version = "1.0"\nslope_mg_cm3_per_grey = 0.25\nintercept_mg_cm3 = -100\n' | seed fuzz_density qc
printf 'format = "burrbench.sensor_loads"\nformat_version = "1.0"\nunloaded = "empty.toml"\ngravity_rig = [0, 0, -1]\ng_m_s2 = 9.81\n[[loads]]\ntare = "w0.toml"\nmass_kg = 0.5\npoint_rig_mm = [40, 0, 60]\n[[loads]]\ntare = "pull.toml"\nforce_rig_N = [4.0, 0, 0]\npoint_rig_mm = [0, 0, 70]\n' \
  | seed fuzz_sensor_loads two_loads
printf 'format = "burrbench.study"\nformat_version = "1.0"\nname = "seed study"\ndescription = "two specimens"\ncriteria = "criteria.toml"\n[fit]\nstarts = 2\nprofiles = false\ncross_validation = true\ndiscretization_check = false\n[[specimen]]\nid = "S1"\nexperiment = "S1/experiment.toml"\n[[specimen]]\nid = "S1-again.b"\nexperiment = "S1/experiment.toml"\n' \
  | seed fuzz_study two_specimens
# The column map alone (fuzz_csv_map reads it against a fixed LabVIEW export).
printf 'format = "burrbench.csv_map"\nformat_version = "1.0"\ndelimiter = "\\t"\ndecimal = ","\nheader_line = 2\n[columns."Time (ms)"]\nchannel = "t_s"\nunit = "ms"\n[columns."X [um]"]\nchannel = "x_mm"\nunit = "um"\n[columns.Y]\nchannel = "y_mm"\n[columns.Z]\nchannel = "z_mm"\noffset = 1.0\n[columns.Fx]\nchannel = "fx_N"\nscale = -1.0\n[columns.Fy]\nchannel = "fy_N"\nunit = "kN"\n[columns.Fz]\nchannel = "fz_N"\n[columns.Tx]\nchannel = "tx_Nmm"\n[columns.Ty]\nchannel = "ty_Nmm"\n[columns.Tz]\nchannel = "tz_Nmm"\n[columns.rpm]\nchannel = "spindle_rpm"\n' \
  | seed fuzz_csv_map labview
# Slices (PNG 8/16 bit, TIFF 8/16 bit, a two-page TIFF, two slices) by the tests'
# independent writers, and Scanco ISQ files.
"$PYTHON" - "$work" "$root/tests/data_schema" <<'PY'
import os, struct, sys
import numpy as np
work, fixtures = sys.argv[1], sys.argv[2]
sys.path.insert(0, fixtures)
from fixtures_volumes import write_png, write_tiff
marker = b"\0\0FILE\0\0"
d = os.path.join(work, "fuzz_slices", "seeds")
os.makedirs(d, exist_ok=True)
img8 = np.arange(12, dtype=np.uint8).reshape(3, 4) * 20
img16 = img8.astype(np.uint16) * 300
def blob(writer, img, **kw):
    p = os.path.join(d, ".tmp")
    writer(p, img, **kw)
    b = open(p, "rb").read()
    os.remove(p)
    return b
seeds = {"png8": blob(write_png, img8), "png16": blob(write_png, img16), "tif8": blob(write_tiff, img8),
         "tif16": blob(write_tiff, img16), "tif_two_pages": blob(write_tiff, img8, pages=2),
         "png_bad_text_crc": blob(write_png, img8, bad_text_crc=True)}
seeds["two_slices"] = seeds["png8"] + marker + seeds["png8"]
for k, v in seeds.items():
    open(os.path.join(d, k), "wb").write(v)
d = os.path.join(work, "fuzz_isq", "seeds")
os.makedirs(d, exist_ok=True)
def isq(vol, dim_um, offset_blocks=0):
    nz, ny, nx = vol.shape
    h = bytearray(512)
    h[0:16] = b"CTDATA-HEADER_V1"
    ints = {16: 3, 20: vol.nbytes, 24: vol.nbytes // 512, 28: 17, 32: 2135, 44: nx, 48: ny, 52: nz, 56: dim_um[0],
            60: dim_um[1], 64: dim_um[2], 68: dim_um[2] // nz, 72: dim_um[2] // nz, 88: 4096, 508: offset_blocks}
    for off, val in ints.items():
        struct.pack_into("<i", h, off, val)
    h[128:168] = b"SEED".ljust(40, b" ")
    return bytes(h) + b"\x5a" * (512 * offset_blocks) + vol.astype("<i2").tobytes()
vol = (np.arange(2 * 3 * 4) * 100 - 500).astype(np.int16).reshape(2, 3, 4)
open(os.path.join(d, "small"), "wb").write(isq(vol, (4 * 18, 3 * 18, 2 * 18)))
open(os.path.join(d, "offset"), "wb").write(isq(vol, (4 * 18, 3 * 18, 2 * 18), offset_blocks=1))
PY
# HDF5 files and journals from burrbench's own writers (fuzz_seed_writer, this build).
bin=$(mktemp -d)
"$build/bench/fuzz_seed_writer" "$bin" "$root/examples/rigs/virtual-fifo.toml" >/dev/null
for f in recording recording_nocounter; do seed fuzz_recording_h5 "$f" <"$bin/$f.h5"; done
for f in sample sample_counter8; do seed fuzz_sample_h5 "$f" <"$bin/$f.h5"; done
seed fuzz_prediction_h5 prediction <"$bin/prediction.h5"
for f in session session_unfinished; do seed fuzz_journal "$f" <"$bin/$f.journal"; done
rm -rf "$bin"

# --- run ---
# AddressSanitizer's quarantine is 8 MiB, not 256: freed memory is reused sooner, so an
# execution touches far fewer fresh pages (each a trip through the hypervisor on a VM:
# the TOML parsers ran ~1.6x faster); a use after free within one execution is still caught.
# Inputs up to 64 KiB; the binary formats' seeds are larger (HDF5 files of a few streams,
# journals of 4 KiB blocks): 512 KiB for those.
max_len() { case $1 in fuzz_*_h5 | fuzz_journal) echo 524288 ;; *) echo 65536 ;; esac; }
# One target: its libFuzzer run, then its line of the table in $work/<target>/result.
fuzz_one() {
  local t=$1 d=$work/$1 lsan="" rc execs rate figure
  mkdir -p "$d/corpus" "$d/artifacts" "$d/seeds"
  # libhdf5's own leaks on corrupt object headers are not findings (fuzz/lsan_hdf5.supp).
  [[ $t != fuzz_*_h5 ]] || lsan=suppressions=$here/fuzz/lsan_hdf5.supp
  set +e
  ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0:quarantine_size_mb=8 LSAN_OPTIONS=$lsan \
    UBSAN_OPTIONS=print_stacktrace=1 "$build/bench/$t" -max_total_time="$secs" -max_len="$(max_len "$t")" -rss_limit_mb=2048 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$d/artifacts/" "$d/corpus" "$d/seeds" >"$d/log" 2>&1
  rc=$?
  set -e
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$d/log" | grep -o '[0-9]*$' | tail -1 || true)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$d/log" | grep -o '[0-9]*$' | tail -1 || true)
  figure="${execs:-?} (${rate:-?}/s)"
  if [[ $rc -eq 0 ]] && ! grep -q 'ERROR: \|runtime error:' "$d/log"; then
    printf '%-20s | %-28s | %-22s | %s\n' "$t" "$figure" "none" "ok" >"$d/result"
  else
    printf '%-20s | %-28s | %-22s | %s\n' "$t" "$figure" "FINDING (see $d/log)" "NO" >"$d/result"
  fi
}

# FUZZ_JOBS targets at a time (default 1): 20 targets of 600 s are 3.3 h one after another,
# 1.7 h two at a time on two cores. Each line is printed as its target ends.
jobs=${FUZZ_JOBS:-1}
[[ $jobs =~ ^[1-9][0-9]*$ ]] || { echo "fuzz.sh: FUZZ_JOBS: expected a whole number >= 1, got '$jobs'" >&2; exit 2; }
printf '%-20s | %-28s | %-22s | %s\n' "target" "executions in ${secs} s" "finding" "ok?"
declare -A running=()  # pid -> target
finish_one() {  # waits for any running target, prints its line
  local pid
  wait -n -p pid "${!running[@]}" || true
  cat "$work/${running[$pid]}/result"
  unset "running[$pid]"
}
for t in "${targets[@]}"; do
  rm -f "$work/$t/result"
  while ((${#running[@]} >= jobs)); do finish_one; done
  fuzz_one "$t" &
  running[$!]=$t
done
while ((${#running[@]} > 0)); do finish_one; done
status=0
for t in "${targets[@]}"; do grep -q '| ok$' "$work/$t/result" 2>/dev/null || status=1; done
exit $status
