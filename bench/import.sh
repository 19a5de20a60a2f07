#!/usr/bin/env bash
# Wall time and peak memory of segmenting a grey CT (`sample import --ct`): a lab's
# micro-CT has 10⁸–10⁹ voxels, so the bytes held per voxel decide whether it fits in RAM.
# The CT is N³ int16 voxels of 0.05 mm (default N = 320, 32.8 M voxels): air around a
# block with a 1.25 mm compact shell over a porous core, grey noise σ = 60. Prints wall s,
# peak RSS (MiB) and peak bytes per voxel (best of 2). Usage: import.sh BUILD_DIR [N]
set -euo pipefail
source "$(dirname "$0")/prelude.bash"
n=${2:-320}
/usr/bin/python3 - "$work/ct.nrrd" "$n" <<'PY'
import sys
import numpy as np
path, n = sys.argv[1], int(sys.argv[2])
rng = np.random.default_rng(1)
z, y, x = np.ogrid[0:n, 0:n, 0:n]
m = n // 16
inside = (x >= m) & (x < n - m) & (y >= m) & (y < n - m) & (z >= m) & (z < n - m)
shell = inside & ((x < m + 25) | (x >= n - m - 25) | (y < m + 25) | (y >= n - m - 25) | (z < m + 25) | (z >= n - m - 25))
g = np.full((n, n, n), -1000, np.int16)
g[inside & (rng.random((n, n, n)) < 0.35)] = 900
g[shell] = 1500
g = (g + rng.normal(0, 60, g.shape)).astype(np.int16)
head = (f"NRRD0004\ntype: int16\ndimension: 3\nsizes: {n} {n} {n}\nspace: 3D-right-handed\n"
        "space directions: (0.05,0,0) (0,0.05,0) (0,0,0.05)\nspace origin: (0,0,0)\nendian: little\nencoding: raw\n\n")
with open(path, "wb") as f:
    f.write(head.encode() + g.tobytes(order="C"))
PY
best="" rss=""
for _ in 1 2; do
  rm -f "$work/s.h5"
  /usr/bin/time -f "%e %M" -o "$work/time" "$bb" sample import --ct "$work/ct.nrrd" --out "$work/s.h5" >/dev/null 2>&1
  read -r wall kb < "$work/time"
  if [[ -z "$best" ]] || awk "BEGIN{exit !($wall < $best)}"; then best=$wall; rss=$kb; fi
done
awk -v n="$n" -v w="$best" -v kb="$rss" -v load="$(cut -d' ' -f1 /proc/loadavg)" 'BEGIN {
  v = n * n * n
  printf "import: a %d^3 int16 grey CT (%.1f M voxels) segmented, load %s\n", n, v / 1e6, load
  printf "wall %.2f s, peak %.0f MiB, %.1f bytes per voxel\n", w, kb / 1024, kb * 1024 / v }'
