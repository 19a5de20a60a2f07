#!/usr/bin/env bash
# Solution verification on a sample much larger than its drilling reaches: the synthetic
# experiment's sample split by 4 (320×320×120 voxels of 0.025 mm), verified on the part
# within reach of the burr (the default) and on the whole sample (--whole-sample). Prints
# wall time and peak memory of each (best of 3), their ratios, and the largest relative
# difference between the two studies' figures (rounding only). Then the two quadratures
# side by side (lens, cube; docs/model.md "The cube quadrature"): each recording's voxel
# error and observed order at R/l 10 (the example's 0.1 mm) and R/l 20 (split by 2), with
# erosion and without (the contact force alone: what is left with erosion is erosion's).
# Usage: verify.sh BUILD_DIR
set -euo pipefail
source "$(dirname "$0")/prelude.bash"
sh "$here/../examples/experiments/synthetic/make.sh" "$bb" "$work/exp" >/dev/null 2>&1
"$bb" sample resample "$work/exp/sample.h5" --split 4 --out "$work/exp/sample_s4.h5" >/dev/null
sed 's/path = "sample.h5"/path = "sample_s4.h5"/' "$work/exp/experiment.toml" > "$work/exp/experiment_s4.toml"
run() {  # name, extra flags: best wall s and its peak RSS (MiB) of 3 runs
  local best="" rss=""
  for _ in 1 2 3; do
    rm -f "$work/$1.json"
    /usr/bin/time -f "%e %M" -o "$work/time" "$bb" verify "$work/exp/experiment_s4.toml" \
      --params "$work/exp/params_true.toml" --out "$work/$1.json" "${@:2}" >/dev/null 2>&1
    read -r wall kb < "$work/time"
    if [[ -z "$best" ]] || awk "BEGIN{exit !($wall < $best)}"; then best=$wall; rss=$((kb / 1024)); fi
  done
  echo "$best $rss"
}
read -r part_s part_mb < <(run part)
read -r whole_s whole_mb < <(run whole --whole-sample)
/usr/bin/python3 - "$work" "$part_s" "$part_mb" "$whole_s" "$whole_mb" <<'PY'
import json, os, sys
work, ps, pm, ws, wm = sys.argv[1], *map(float, sys.argv[2:])
a, b = (json.load(open(os.path.join(work, f"{n}.json"))) for n in ("part", "whole"))
# The study's figures: per level the force changes and peak, per recording the errors.
pairs = [(la[k], lb[k]) for ra, rb in zip(a["recordings"], b["recordings"])
         for la, lb in zip(ra["levels"], rb["levels"]) for k in ("rms_change_N", "max_change_N", "peak_N")]
pairs += [(ra[k], rb[k]) for ra, rb in zip(a["recordings"], b["recordings"])
          for k in ("voxel_error_N", "step_error_N", "error_N")]
diff = max(abs(x - y) / abs(y) if y else abs(x) for x, y in pairs)
r = a["reach"][0]
share = 100 * r["replayed_dims"][0] * r["replayed_dims"][1] * r["replayed_dims"][2] / (r["dims"][0] * r["dims"][1] * r["dims"][2])
print(f"verify, synthetic sample split by 4 ({'x'.join(map(str, r['dims']))} voxels), load {os.getloadavg()[0]:.1f}")
print(f"{'figure':<58} | value")
print(f"{'part within reach: voxels replayed at l':<58} | {'x'.join(map(str, r['replayed_dims']))} ({share:.3g} %)")
print(f"{'wall s, part within reach / whole sample':<58} | {ps:.2f} / {ws:.2f} = {ws / ps:.2f}x less")
print(f"{'peak memory MiB, part within reach / whole sample':<58} | {pm:.0f} / {wm:.0f} = {wm / pm:.2f}x less")
label = f"largest relative difference of the {len(pairs)} force figures"
print(f"{label:<58} | {diff:.2g}")
PY

"$bb" sample resample "$work/exp/sample.h5" --split 2 --out "$work/exp/sample_s2.h5" >/dev/null
sed 's/path = "sample.h5"/path = "sample_s2.h5"/' "$work/exp/experiment.toml" > "$work/exp/experiment_s2.toml"
for q in lens cube; do
  for e in "" _s2; do
    "$bb" verify "$work/exp/experiment$e.toml" --params "$work/exp/params_true.toml" --quadrature $q \
      --out "$work/q_${q}$e.json" >/dev/null 2>&1
    "$bb" verify "$work/exp/experiment$e.toml" --params "$work/exp/params_true.toml" --quadrature $q --no-erosion \
      --out "$work/q_${q}${e}_forces.json" >/dev/null 2>&1
  done
done
/usr/bin/python3 - "$work" <<'PY'
import json, os, sys
work = sys.argv[1]
def load(q, e, f): return json.load(open(os.path.join(work, f"q_{q}{e}{f}.json")))
def cell(r):
    o = r["voxel_order"]
    return f"{r['voxel_error_N']:.4f} N p {'n/o' if o is None else f'{o:.2f}'}"
print()
print("quadratures side by side on the synthetic example: voxel error (Richardson, N) and observed order p")
print(f"{'R/l':>4} {'erosion':<8} {'recording':<9} | {'lens':<20} | {'cube':<20} | cube/lens")
for e, rl in (("", 10), ("_s2", 20)):
    for f, name in (("", "on"), ("_forces", "off")):
        a, b = load("lens", e, f), load("cube", e, f)
        for ra, rb in zip(a["recordings"], b["recordings"]):
            print(f"{rl:>4} {name:<8} {ra['id']:<9} | {cell(ra):<20} | {cell(rb):<20} | {rb['voxel_error_N'] / ra['voxel_error_N']:.2f}")
        print(f"{rl:>4} {name:<8} {'largest':<9} | {a['largest_error_N']:.4f} N {'':<11} | {b['largest_error_N']:.4f} N {'':<11} | "
              f"{b['largest_error_N'] / a['largest_error_N']:.2f}   (sigma {a['sigma_N']:.3g} N)")
PY
