#!/usr/bin/env bash
# Rebuilds docs/amplify-painted.png: three painted sketches of
# tests/data/painted answered by the shipped model through `infer --size 1025`
# (hypsometric previews, whole canvas). Top row: without the later choices
# (the whole base-grid erosion time, the model's beach plain kept, its ponds
# kept: {"amplify_duration_scale": 1, "amplify_plain_smooth_m": 0,
# "amplify_low_island_m": 0, "amplify_pond_max_m2": 0}); bottom row: the
# defaults (half the time, the plain's rings smoothed off, the model's ponds
# raised to land), docs/EROSION.md. Prints the realism statistics of both.
# (The picture in docs/ was drawn when the top row also had the 2D-noise
# lobes, a switch since removed.)
# Needs python3-numpy and python3-opencv.
set -euo pipefail
cd "$(dirname "$0")/.."
R=build/cli/reefgen
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
echo '{"amplify_duration_scale": 1, "amplify_plain_smooth_m": 0, "amplify_low_island_m": 0, "amplify_pond_max_m2": 0}' > "$W/before.json"
names=(07-polygon-aa 03-two-islands 06-long-arc)
for n in "${names[@]}"; do
  $R -q infer "tests/data/painted/$n.png" --size 1025 --erosion "$W/before.json" -o "$W/before-$n" --preview >/dev/null
  $R -q infer "tests/data/painted/$n.png" --size 1025 -o "$W/now-$n" --preview >/dev/null
done
for set in before now; do
  echo "$set:"
  for n in "${names[@]}"; do $R realism "$W/$set-$n.height.exr"; done
done
python3 - "$W" "${names[@]}" <<'EOF2'
import sys, cv2, numpy as np
w, names = sys.argv[1], sys.argv[2:]
rows = []
for tag, title in (("before", "before: 2D lobes, whole erosion time, plain kept, ponds kept"),
                   ("now", "defaults: lobes along flow lines, half the time, plain smoothed, ponds filled")):
    tiles = []
    for n in names:
        im = cv2.imread(f"{w}/{tag}-{n}.preview.png")
        tiles.append(cv2.resize(im, (600, 600), interpolation=cv2.INTER_AREA))
    row = np.hstack(tiles)
    cv2.putText(row, title, (10, 28), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (0, 0, 255), 2)
    rows.append(row)
cv2.imwrite("docs/amplify-painted.png", np.vstack(rows), [cv2.IMWRITE_PNG_COMPRESSION, 9])
EOF2
echo docs/amplify-painted.png
