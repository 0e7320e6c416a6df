#!/usr/bin/env bash
# Rebuilds docs/age.png (docs/REALISM.md "Age and dissection"): the
# young-volcano preset through `generate --size 1025`, top row with
# --age-myr 0.1 / 1 / 3.5 / 5 (subsidence and erosion together), bottom row
# with --maturity 0.1 / 1 / 3.5 / 5 (erosion alone). Each tile is the
# canvas's central 4.8 km, hill-shaded, titled with its peak, its land
# above half the peak and its drainage density (`realism --dissection`).
# Prints the statistics.
# Needs python3-numpy and python3-opencv.
set -euo pipefail
cd "$(dirname "$0")/.."
R=build/cli/reefgen
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
for v in 0.1 1 3.5 5; do
  $R -q generate --preset young-volcano --size 1025 --age-myr "$v" -o "$W/age-$v" >/dev/null
  $R -q generate --preset young-volcano --size 1025 --maturity "$v" -o "$W/maturity-$v" >/dev/null
done
for v in 0.1 1 3.5 5; do
  for k in age maturity; do $R realism "$W/$k-$v.height.exr" --dissection --json > "$W/$k-$v.stats.json"; done
done
cat "$W"/*.stats.json
python3 - "$W" <<'EOF'
import json, os, sys
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
import cv2, numpy as np
w = sys.argv[1]
T = 300  # tile side, px

def tile(name, flag):
    h = cv2.imread(f"{w}/{name}.height.exr", cv2.IMREAD_UNCHANGED)
    h = (h[:, :, 0] if h.ndim == 3 else h).astype(np.float64)
    n = h.shape[0]
    gy, gx = np.gradient(h, 6000.0 / n)
    light = np.clip(0.62 + (-gx - gy) * 0.55 / np.sqrt(1 + gx * gx + gy * gy), 0, 1)
    land_bgr, sea_bgr = np.array([225, 225, 225]), np.array([150, 100, 45])
    img = np.where((h > 0)[..., None], land_bgr * (0.2 + 0.9 * light)[..., None], sea_bgr * (0.75 + 0.4 * light)[..., None])
    a = n // 10
    img = cv2.resize(np.clip(img, 0, 255).astype(np.uint8)[a:n - a, a:n - a], (T, T), interpolation=cv2.INTER_AREA)
    d = json.load(open(f"{w}/{name}.stats.json"))["dissection"]
    lines = [f"{flag}, peak {h.max():.0f} m",
             f"{100 * d['land_above_half_peak']:.0f} % above half, {d['drainage_density_per_km']:.1f} km/km2"]
    for k, text in enumerate(lines):
        cv2.putText(img, text, (6, 16 + 14 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 160), 1, cv2.LINE_AA)
    return img

values = ("0.1", "1", "3.5", "5")
top = [tile(f"age-{v}", f"--age-myr {v}") for v in values]
bottom = [tile(f"maturity-{v}", f"--maturity {v}") for v in values]
cv2.imwrite("docs/age.png", np.vstack([np.hstack(top), np.hstack(bottom)]), [cv2.IMWRITE_PNG_COMPRESSION, 9])
EOF
echo docs/age.png
