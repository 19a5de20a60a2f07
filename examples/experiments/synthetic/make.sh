#!/bin/sh
# Writes the synthetic reference experiment into OUTDIR (default out/synthetic):
# sample.h5 (8×8×3 mm, 0.1 mm voxels, 1 mm compact over trabecular), three recordings
# with noise σ = 0.02 N, a bias and a 2 ms lag on the sweeps, their truth files, and a
# copy of experiment.toml and params_true.toml. Usage: make.sh BURRBENCH [OUTDIR]
set -eu
BURRBENCH=${1:?usage: make.sh BURRBENCH [OUTDIR]}
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${2:-out/synthetic}
PROTOCOLS="$HERE/../../protocols"
mkdir -p "$OUT"
cp "$HERE/experiment.toml" "$HERE/params_true.toml" "$OUT/"
"$BURRBENCH" sample synth --extent-mm 8 8 3 --voxel-mm 0.1 --compact-mm 1.0 --seed 1 --out "$OUT/sample.h5"
"$BURRBENCH" synth --sample "$OUT/sample.h5" --protocol "$PROTOCOLS/plunge.toml" --params "$OUT/params_true.toml" \
  --out "$OUT/plunge.h5" --truth "$OUT/plunge.truth.json" --noise-N 0.02 --bias-N 0.05,-0.03,0.1 --lag-ms 0 --seed 11
"$BURRBENCH" synth --sample "$OUT/sample.h5" --protocol "$PROTOCOLS/sweep.toml" --params "$OUT/params_true.toml" \
  --out "$OUT/sweep.h5" --truth "$OUT/sweep.truth.json" --noise-N 0.02 --bias-N 0.05,-0.03,0.1 --lag-ms 2 --seed 12
"$BURRBENCH" synth --sample "$OUT/sample.h5" --protocol "$PROTOCOLS/polish.toml" --params "$OUT/params_true.toml" \
  --out "$OUT/polish.h5" --truth "$OUT/polish.truth.json" --noise-N 0.02 --bias-N 0.05,-0.03,0.1 --lag-ms 2 --seed 13
echo "experiment ready: $OUT/experiment.toml"
