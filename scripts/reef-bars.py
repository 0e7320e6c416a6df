#!/usr/bin/env python3
"""The painted-sketch bars of the reef (docs/REEF.md): paints two sketches the
model has never seen, runs `reefgen infer --size 1025` on them and measures

  * a subsided atoll (dark blue rim, dark cyan lagoon) with 7 green motu dots
    on its rim: how many dots come back as islets (>= 50 % of the dot above
    +0.3 m), and the crest at -1 m or higher along rays (realism --reef);
  * a bright island with a lagoon ring, painted as the paper's authors painted
    Mayotte: the share of the painted lagoon below sea level.

Usage: python3 scripts/reef-bars.py [-m MODEL] [--out DIR] [--bin build/cli/reefgen] [--age-myr T]
(--age-myr: both inferred at that age, as `infer --age-myr T`.)
Prints one JSON object on stdout. Needs Debian's python3-opencv and numpy.
"""
import argparse
import colorsys
import json
import math
import os
import subprocess
import sys

import cv2
import numpy as np

SIDE = 256
HUES = {"island": 60, "beach": 120, "lagoon": 180, "reef": 240, "abyss": 0}


def colour(region, lam):
    r, g, b = colorsys.hsv_to_rgb(HUES[region] / 360.0, 1.0, 1.0 - 0.75 * lam)
    return (int(round(b * 255)), int(round(g * 255)), int(round(r * 255)))  # BGR


def radius(theta, base, wobble, phase):
    return base * (1 + wobble * (0.6 * np.sin(3 * theta + phase) + 0.4 * np.sin(5 * theta + 2 * phase)))


def ring_mask(r_in, r_out, wobble=0.06, phase=0.7):
    yy, xx = np.mgrid[0:SIDE, 0:SIDE].astype(np.float64)
    dx, dy = xx - (SIDE - 1) / 2, yy - (SIDE - 1) / 2
    r, th = np.hypot(dx, dy), np.arctan2(-dy, dx)
    return (r >= radius(th, r_in, wobble, phase)) & (r < radius(th, r_out, wobble, phase)) if r_in > 0 else \
        (r < radius(th, r_out, wobble, phase))


def paint_atoll(lam=0.9, dots=7):
    img = np.zeros((SIDE, SIDE, 3), np.uint8)
    img[:] = colour("abyss", lam)
    img[ring_mask(0, 88)] = colour("reef", lam)
    img[ring_mask(0, 72)] = colour("lagoon", lam)
    centres = []
    for k in range(dots):
        th = 2 * math.pi * (k + 0.3) / dots
        r = radius(th, 80, 0.06, 0.7)
        cx, cy = (SIDE - 1) / 2 + r * math.cos(th), (SIDE - 1) / 2 - r * math.sin(th)
        cv2.circle(img, (int(round(cx)), int(round(cy))), 5, colour("beach", lam), -1)
        centres.append((cx, cy))
    return img, centres


def paint_bright_lagoon(lam=0.1):
    img = np.zeros((SIDE, SIDE, 3), np.uint8)
    img[:] = colour("abyss", lam)
    img[ring_mask(0, 98)] = colour("reef", lam)
    img[ring_mask(0, 86)] = colour("lagoon", lam)
    img[ring_mask(0, 58)] = colour("beach", lam)
    img[ring_mask(0, 50)] = colour("island", lam)
    return img


def infer(binary, model, sketch, out, age_myr=None):
    cmd = [binary, "-q", "infer", sketch, "-o", out, "--size", "1025"]
    if model:
        cmd += ["-m", model]
    if age_myr is not None:
        cmd += ["--age-myr", str(age_myr)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    h = cv2.imread(out + ".height.exr", cv2.IMREAD_UNCHANGED)
    return h if h.ndim == 2 else h[..., 0]


def reef_report(binary, exr):
    out = subprocess.run([binary, "realism", exr, "--reef", "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.splitlines()[-1])["reef"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-m", "--model", default="")
    ap.add_argument("--out", default="out/reef-bars")
    ap.add_argument("--bin", default="build/cli/reefgen")
    ap.add_argument("--age-myr", type=float, default=None)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    atoll, centres = paint_atoll()
    cv2.imwrite(os.path.join(a.out, "atoll-sketch.png"), atoll)
    h = infer(a.bin, a.model, os.path.join(a.out, "atoll-sketch.png"), os.path.join(a.out, "atoll"), a.age_myr)
    scale = h.shape[0] / SIDE
    islets = 0
    yy, xx = np.mgrid[0:h.shape[0], 0:h.shape[1]]
    shares = []
    for cx, cy in centres:
        dot = np.hypot(xx - (cx + 0.5) * scale + 0.5, yy - (cy + 0.5) * scale + 0.5) <= 5 * scale
        share = float((h[dot] > 0.3).mean())
        shares.append(round(share, 3))
        islets += share >= 0.5
    reef = reef_report(a.bin, os.path.join(a.out, "atoll.height.exr"))
    bright = paint_bright_lagoon()
    cv2.imwrite(os.path.join(a.out, "lagoon-sketch.png"), bright)
    hb = infer(a.bin, a.model, os.path.join(a.out, "lagoon-sketch.png"), os.path.join(a.out, "lagoon"), a.age_myr)
    lagoon = cv2.resize((ring_mask(58, 86)).astype(np.uint8), hb.shape[::-1], interpolation=cv2.INTER_NEAREST) > 0
    wet = float((hb[lagoon] < 0).mean())
    print(json.dumps({"atoll_motu_islets": islets, "atoll_motu_dot_shares": shares,
                      "atoll_crest_at_sea": reef["crest_at_sea"], "atoll_crest_median_m": reef["crest_median_m"],
                      "atoll_lagoon_median_m": reef["lagoon_median_m"], "atoll_flat_floor_share": reef["flat_floor_share"],
                      "bright_lagoon_below_sea": round(wet, 4),
                      "bright_lagoon_median_m": float(np.median(hb[lagoon]))}))


if __name__ == "__main__":
    sys.exit(main())
