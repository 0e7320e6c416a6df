#!/usr/bin/env python3
"""docs/INFERENCE.md's table "What each colour means, at each brightness":
heights of a dataset's held-out pairs (val and test) by painted colour and
brightness band — median (10th…90th percentile), share above sea level.

Usage: python3 scripts/colour-table.py DATASET_DIR   (needs python3-opencv, numpy)
"""
import glob
import os
import sys

os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")
import cv2
import numpy as np

NAMES = ["yellow island", "green beach", "cyan lagoon", "blue reef", "red abyss"]
BANDS = [(0, 0.1, "bright, λ 0–0.1"), (0.1, 0.3, "λ 0.1–0.3"), (0.3, 0.5, "λ 0.3–0.5"), (0.5, 0.7, "λ 0.5–0.7"),
         (0.7, 0.9, "λ 0.7–0.9"), (0.9, 1.01, "dark, λ 0.9–1")]


def main():
    root = sys.argv[1]
    files = sorted(glob.glob(os.path.join(root, "val", "*.label.png")) + glob.glob(os.path.join(root, "test", "*.label.png")))
    cells = {(r, b): [] for r in range(5) for b in range(len(BANDS))}
    for f in files:
        lab = cv2.imread(f, cv2.IMREAD_COLOR)
        h = cv2.imread(f.replace(".label.png", ".height.exr"), cv2.IMREAD_UNCHANGED)
        h = h if h.ndim == 2 else h[..., 0]
        hsv = cv2.cvtColor(lab, cv2.COLOR_BGR2HSV_FULL).astype(np.float64)
        hue = hsv[..., 0] * 360 / 256
        region = np.select([hue < 30, hue < 90, hue < 150, hue < 210, hue < 300], [4, 0, 1, 2, 3], 4)
        lam = (1 - hsv[..., 2] / 255) / 0.75
        for r in range(5):
            for b, (lo, hi, _) in enumerate(BANDS):
                m = (region == r) & (lam >= lo) & (lam < hi)
                if m.any():
                    cells[(r, b)].append(h[m][:: max(1, int(m.sum() // 400))])
    print("| colour | " + " | ".join(b[2] for b in BANDS) + " |")
    print("|---|" + "---|" * len(BANDS))
    for r in range(5):
        row = []
        for b in range(len(BANDS)):
            if not cells[(r, b)]:
                row.append("—")
                continue
            v = np.concatenate(cells[(r, b)])
            p10, p50, p90 = np.percentile(v, [10, 50, 90])
            dry = 100 * (v > 0).mean()
            row.append(f"{p50:.0f} ({p10:.0f}…{p90:.0f}), {dry:.0f} % dry".replace("-", "−"))
        print(f"| {NAMES[r]} | " + " | ".join(row) + " |")
    print(f"\n{len(files)} pairs")


if __name__ == "__main__":
    main()
