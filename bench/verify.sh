#!/usr/bin/env bash
# Solution verification on a sample much larger than its drilling reaches: the synthetic
# experiment's sample split by 4 (320×320×120 voxels of 0.025 mm), verified on the part
# within reach of the burr (the default) and on the whole sample (--whole-sample). Prints
# wall time and peak memory of each (best of 3), their ratios, and the largest relative
# difference between the two studies' figures (rounding only). Usage: verify.sh BUILD_DIR
set -euo pipefail
build=$(cd "${1:-build}" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
bb="$build/apps/burrbench"
cmake --build "$build" --target burrbench -j 2 >/dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
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
def nums(x, p=""):
    if isinstance(x, dict):
        for k, v in x.items():
            if k not in ("wall_s", "reach"):
                yield from nums(v, f"{p}/{k}")
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from nums(v, f"{p}[{i}]")
    elif isinstance(x, (int, float)) and not isinstance(x, bool):
        yield p, float(x)
A, B = dict(nums(a)), dict(nums(b))
diff = max(abs(A[k] - B[k]) / abs(B[k]) if B[k] else abs(A[k]) for k in B)
r = a["reach"][0]
share = 100 * r["replayed_dims"][0] * r["replayed_dims"][1] * r["replayed_dims"][2] / (r["dims"][0] * r["dims"][1] * r["dims"][2])
print(f"verify, synthetic sample split by 4 ({'x'.join(map(str, r['dims']))} voxels), load {os.getloadavg()[0]:.1f}")
print(f"{'figure':<58} | value")
print(f"{'part within reach: voxels replayed at l':<58} | {'x'.join(map(str, r['replayed_dims']))} ({share:.3g} %)")
print(f"{'wall s, part within reach / whole sample':<58} | {ps:.2f} / {ws:.2f} = {ws / ps:.2f}x less")
print(f"{'peak memory MiB, part within reach / whole sample':<58} | {pm:.0f} / {wm:.0f} = {wm / pm:.2f}x less")
label = f"largest relative difference of the {len(B)} figures"
print(f"{label:<58} | {diff:.2g}")
PY
