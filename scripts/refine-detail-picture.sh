#!/usr/bin/env bash
# Rebuilds docs/refine-detail-4097.png: the young-volcano preset at 4097²,
# three 500 px crops at 1:1 (flank, lowland, summit), hill-shaded: the finer
# levels as they were before 2026-11-25 ({"refine_diffusivity_scale": 1,
# "refine_detail_scale": 1, "refine_random_receivers": false}, top row), the
# same less diffused without random receivers (middle row: grid-aligned
# rills), and the defaults (bottom row), docs/EROSION.md. Prints the realism
# statistics of all three. Needs python3-numpy and python3-opencv.
set -euo pipefail
cd "$(dirname "$0")/.."
R=build/cli/reefgen
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
python3 - "$W" <<'EOF2'
import json, sys
s = json.load(open("configs/presets/young-volcano.json"))
s["erosion"] = {"refine_diffusivity_scale": 1, "refine_detail_scale": 1, "refine_random_receivers": False}
json.dump(s, open(sys.argv[1] + "/smooth-spec.json", "w"))
s["erosion"] = {"refine_diffusivity_scale": 0.3, "refine_detail_scale": 2, "refine_random_receivers": False}
json.dump(s, open(sys.argv[1] + "/d8-spec.json", "w"))
EOF2
$R -q generate --spec "$W/smooth-spec.json" --size 4097 -o "$W/smooth" >/dev/null
$R -q generate --spec "$W/d8-spec.json" --size 4097 -o "$W/d8" >/dev/null
$R -q generate --preset young-volcano --size 4097 -o "$W/default" >/dev/null
$R realism "$W/smooth.height.exr" "$W/d8.height.exr" "$W/default.height.exr"
OPENCV_IO_ENABLE_OPENEXR=1 python3 - "$W" <<'EOF2'
import sys, cv2, numpy as np
w = sys.argv[1]
def shade(h, px):
    gy, gx = np.gradient(h, px)
    sl = np.arctan(np.hypot(gx, gy)); asp = np.arctan2(-gx, gy); az = np.deg2rad(315); alt = np.deg2rad(45)
    return np.clip(np.sin(alt) * np.cos(sl) + np.cos(alt) * np.sin(sl) * np.cos(az - asp), 0, 1)
rows = []
for name, title in (("smooth", "before: diffusion x1, detail x1, steepest receivers"),
                    ("d8", "diffusion x0.3, detail x2, steepest receivers"),
                    ("default", "defaults: diffusion x0.3, detail x2, random receivers")):
    h = cv2.imread(f"{w}/{name}.height.exr", cv2.IMREAD_UNCHANGED).astype(np.float64)
    if h.ndim == 3: h = h[..., 0]
    n = h.shape[0]; s = shade(h, 6000.0 / n)
    crops = [s[int(fy * n):int(fy * n) + 500, int(fx * n):int(fx * n) + 500] for fy, fx in ((0.34, 0.31), (0.6, 0.55), (0.45, 0.45))]
    row = cv2.cvtColor((np.hstack(crops) * 255).astype(np.uint8), cv2.COLOR_GRAY2BGR)
    cv2.putText(row, title, (10, 28), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (0, 0, 255), 2)
    rows.append(row)
cv2.imwrite("docs/refine-detail-4097.png", np.vstack(rows), [cv2.IMWRITE_PNG_COMPRESSION, 9])
EOF2
echo docs/refine-detail-4097.png
