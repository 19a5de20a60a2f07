#!/usr/bin/env bash
# Memory and time of replay and calibrate on a lab's CT block against the drilled region
# alone: the synthetic experiment's recordings (examples/experiments/synthetic) replayed on
# its own 8×8×3 mm sample and on a 30×30×15 mm block (`sample synth`, 13.5 M voxels of
# 0.1 mm) with the same drilling in its top. Each worker copies only the rows of a sample
# its replays reach (model/reach.hpp, docs/model.md "Memory"), so the block should cost
# about its own size once (the sample as read), not once per worker. Prints wall time
# and peak RSS of each (best of 2) and their ratios. Usage: memory.sh BUILD_DIR
set -euo pipefail
source "$(dirname "$0")/prelude.bash"
exp="$work/exp"
sh "$here/../examples/experiments/synthetic/make.sh" "$bb" "$exp" >/dev/null 2>&1
"$bb" sample synth --extent-mm 30 30 15 --out "$exp/block.h5" >/dev/null 2>&1
# The block's top lies at z = 15 mm, the sample's at 3 mm: the same drilling, moved up
# and into the block's middle.
sed -e 's/path = "sample.h5"/path = "block.h5"/' \
    -e 's/translation_mm = \[0.0, 0.0, 0.0\]/translation_mm = [11.0, 11.0, 12.0]/' \
    "$exp/experiment.toml" > "$exp/block.toml"
run() {  # name, burrbench args...: best wall s and its peak RSS (MiB) of 2 runs
  local name=$1 best="" rss=""
  shift
  for _ in 1 2; do
    rm -rf "$work/$name" "$work/$name.h5"
    /usr/bin/time -f "%e %M" -o "$work/time" "$bb" "$@" >/dev/null 2>&1
    read -r wall kb < "$work/time"
    if [[ -z "$best" ]] || awk "BEGIN{exit !($wall < $best)}"; then best=$wall; rss=$((kb / 1024)); fi
  done
  echo "$best $rss"
}
fit=(--starts 1 --no-profiles --no-discretization-check --no-cross-validation)
read -r rs rm < <(run rs replay --experiment "$exp/experiment.toml" --params "$exp/params_true.toml" --out "$work/rs.h5")
read -r rb rbm < <(run rb replay --experiment "$exp/block.toml" --params "$exp/params_true.toml" --out "$work/rb.h5")
read -r cs cm < <(run cs calibrate --experiment "$exp/experiment.toml" --out "$work/cs" "${fit[@]}")
read -r cb cbm < <(run cb calibrate --experiment "$exp/block.toml" --out "$work/cb" "${fit[@]}")
/usr/bin/python3 - "$rs" "$rm" "$rb" "$rbm" "$cs" "$cm" "$cb" "$cbm" "$work/cs/fit.json" "$work/cb/fit.json" <<'PY'
import json, os, sys
rs, rm, rb, rbm, cs, cm, cb, cbm = map(float, sys.argv[1:9])
a, b = (json.load(open(p))["parameters"] for p in sys.argv[9:11])
print(f"memory: the synthetic drilling on its 80x80x30 sample and on a 300x300x150 block, 2 threads, load {os.getloadavg()[0]:.1f}")
print(f"{'figure':<52} | {'sample':>14} | {'block':>14} | block/sample")
print(f"{'replay: wall s, peak MiB':<52} | {rs:6.2f} {rm:7.0f} | {rb:6.2f} {rbm:7.0f} | {rb / rs:.2f}x, {rbm / rm:.2f}x")
print(f"{'calibrate, one start: wall s, peak MiB':<52} | {cs:6.2f} {cm:7.0f} | {cb:6.2f} {cbm:7.0f} | {cb / cs:.2f}x, {cbm / cm:.2f}x")
# The block holds other bone around the drilling (its own synthetic trabecular core), so
# the fits differ; shown so that a fit that failed on the block is not read as fast.
def value(p):  # a constant that is not identifiable has no estimate, only the value held
    v = p["estimate"] if p["estimate"] is not None else p["held"]
    return f"{v:.4g}" + ("" if p["estimate"] is not None else " (held)")
print("calibrate, estimates on the sample | on the block: " + ", ".join(
    f"{p['class_name']} {p['name']} {value(p)} | {value(q)}" for p, q in zip(a, b)))
PY
