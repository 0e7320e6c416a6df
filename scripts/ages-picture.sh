#!/usr/bin/env bash
# Rebuilds docs/ages.png (docs/REALISM.md "Age and dissection"): five ages
# (0.1 / 0.5 / 1 / 2 / 5 My) across, down the generator's young-volcano
# preset at seeds 1 and 2 (`generate --size 1025 --age-myr T`) and the
# shipped model on tests/data/painted/01-young-volcano.png at seeds 1 and 2
# (`infer --size 1025 --age-myr T`); each tile the canvas's central 4.8 km,
# hill-shaded, titled with its peak and its valley depth's 90th percentile
# (`realism --drainage`). A last row: Kauaʻi and the Big Island from DEM
# (SRTM, public domain NASA/USGS; KAUAI.npy and BIGISLAND.npy as
# ../shared/dem holds them, arguments 2 and 3), each fit to its tile — they
# are 10–40× wider, so they show the organisation, not the scale.
# Usage: bash scripts/ages-picture.sh [OUT.png [KAUAI.npy BIGISLAND.npy]]
# Needs python3-numpy and python3-opencv.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-docs/ages.png}
R=build/cli/reefgen-torch
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
ages=(0.1 0.5 1 2 5)
for s in 1 2; do
  for t in "${ages[@]}"; do
    $R -q generate --preset young-volcano --seed "$s" --size 1025 --age-myr "$t" -o "$W/gen-$s-$t" >/dev/null
    $R -q infer tests/data/painted/01-young-volcano.png --seed "$s" --size 1025 --age-myr "$t" -o "$W/mod-$s-$t" >/dev/null
    for k in gen mod; do $R realism --json --drainage "$W/$k-$s-$t.height.exr" > "$W/$k-$s-$t.stats.json"; done
  done
done
python3 - "$W" "$OUT" "${2:-}" "${3:-}" <<'PYEOF'
import json, os, sys
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
import cv2, numpy as np
w, out, kauai, big = sys.argv[1:5]
T = 256

def shade(h, cell_m, crop):
    n = h.shape[0]
    gy, gx = np.gradient(h, cell_m)
    light = np.clip(0.62 + (-gx - gy) * 0.55 / np.sqrt(1 + gx * gx + gy * gy), 0, 1)
    land, sea = np.array([225, 225, 225]), np.array([150, 100, 45])
    img = np.where((h > 0)[..., None], land * (0.2 + 0.9 * light)[..., None], sea * (0.75 + 0.4 * light)[..., None])
    img = np.clip(img, 0, 255).astype(np.uint8)
    if crop:
        a = n // 10
        img = img[a:n - a, a:n - a]
    return cv2.resize(img, (T, T), interpolation=cv2.INTER_AREA)

def title(img, lines):
    for k, text in enumerate(lines):
        cv2.putText(img, text, (5, 14 + 13 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.36, (0, 0, 160), 1, cv2.LINE_AA)
    return img

def tile(name, label):
    h = cv2.imread(f"{w}/{name}.height.exr", cv2.IMREAD_UNCHANGED).astype(np.float64)
    d = json.load(open(f"{w}/{name}.stats.json"))["drainage"]
    return title(shade(h, 6000.0 / h.shape[0], True), [label, f"peak {h.max():.0f} m, valleys p90 {d['valley_depth_p90_m']:.0f} m"])

rows = []
for kind, who in (("gen", "generator"), ("mod", "model")):
    for s in (1, 2):
        rows.append(np.hstack([tile(f"{kind}-{s}-{t}", f"{who} seed {s}, {t} My") for t in ("0.1", "0.5", "1", "2", "5")]))
refs = []
for path, cell, label in ((kauai, 90, "Kauai, SRTM 90 m (5.1 My)"), (big, 180, "Big Island, SRTM 180 m (0-0.5 My)")):
    if path:
        h = np.load(path).astype(np.float64)
        s = max(h.shape)
        pad = np.full((s, s), -50.0)
        pad[:h.shape[0], :h.shape[1]] = h
        refs.append(title(shade(pad, cell, False), [label, f"{s * cell / 1000:.0f} km across (not to scale)"]))
if refs:
    blank = np.full((T, T, 3), 255, np.uint8)
    rows.append(np.hstack(refs + [blank] * (5 - len(refs))))
cv2.imwrite(out, np.vstack(rows), [cv2.IMWRITE_PNG_COMPRESSION, 9])
print(out)
PYEOF
