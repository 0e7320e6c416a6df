#!/usr/bin/env python3
"""Paints the hand-painted-style test sketches of tests/data/painted/.

Each sketch is painted as a person would in an image editor: a red (abyss)
canvas, then blobs of blue (reef), cyan (lagoon), green (beach) and yellow
(island) laid on top with a soft round brush, so edges are anti-aliased blends
of two colours; some are saved as JPEG, some are darker (subsided), some cut
by the canvas edge. Shapes come from wobbly hand-like outlines, not from the
generator. Needs Debian's python3-opencv and python3-numpy; the PNG/JPEG files
are committed, this script is their provenance:

    /usr/bin/python3 scripts/paint_sketches.py tests/data/painted
"""
import colorsys
import math
import os
import sys

import cv2
import numpy as np

W = 256
HUES = {"island": 60, "beach": 120, "lagoon": 180, "reef": 240, "abyss": 0}


def colour(region, lam):
    """BGR of a region at subsidence lam, V = 1 - 0.75 lam (docs/INFERENCE.md)."""
    r, g, b = colorsys.hsv_to_rgb(HUES[region] / 360.0, 1.0, 1.0 - 0.75 * lam)
    return np.array([b, g, r], np.float32) * 255


def wobbly(cx, cy, r, rng, wobble=0.25, n=9, aspect=1.0, angle=0.0):
    """A closed hand-drawn outline: radius r modulated by a few random harmonics."""
    th = np.linspace(0, 2 * math.pi, 360, endpoint=False)
    rad = np.ones_like(th)
    for k in range(2, n):
        rad += wobble / k * rng.uniform(-1, 1) * np.cos(k * th + rng.uniform(0, 2 * math.pi))
    x, y = r * rad * np.cos(th) * aspect, r * rad * np.sin(th)
    ca, sa = math.cos(angle), math.sin(angle)
    return np.stack([cx + ca * x - sa * y, cy + sa * x + ca * y], 1)


def arc(cx, cy, r, a0, a1, width, rng):
    """A thick curved stroke (an elongated island or a reef arc)."""
    t = np.linspace(a0, a1, 120)
    rr = r * (1 + 0.05 * np.sin(3 * t + rng.uniform(0, 6)))
    mid = np.stack([cx + rr * np.cos(t), cy + rr * np.sin(t)], 1)
    return mid, width


class Canvas:
    def __init__(self, lam_bg=0.0):
        self.img = np.empty((W, W, 3), np.float32)
        self.img[:] = colour("abyss", lam_bg)

    def fill(self, poly, region, lam, soft=2.0):
        m = np.zeros((W * 4, W * 4), np.uint8)  # 4x supersampled: anti-aliased edge
        cv2.fillPoly(m, [np.round(poly * 4).astype(np.int32)], 255, lineType=cv2.LINE_AA)
        self._lay(m, region, lam, soft)

    def stroke(self, mid, width, region, lam, soft=2.0):
        m = np.zeros((W * 4, W * 4), np.uint8)
        pts = np.round(mid * 4).astype(np.int32)
        for i in range(len(pts) - 1):  # round brush dabs along the path
            cv2.line(m, tuple(map(int, pts[i])), tuple(map(int, pts[i + 1])), 255, int(width * 4), cv2.LINE_AA)
        self._lay(m, region, lam, soft)

    def _lay(self, m, region, lam, soft):
        a = cv2.resize(m, (W, W), interpolation=cv2.INTER_AREA).astype(np.float32) / 255
        if soft > 0:
            a = cv2.GaussianBlur(a, (0, 0), soft)
        self.img = self.img * (1 - a[..., None]) + colour(region, lam) * a[..., None]

    def noise(self, rng, amount=6.0):
        self.img += rng.normal(0, amount, self.img.shape).astype(np.float32)

    def save(self, path, jpeg=None):
        out = np.clip(self.img, 0, 255).astype(np.uint8)
        if jpeg:
            cv2.imwrite(path, out, [cv2.IMWRITE_JPEG_QUALITY, jpeg])
        else:
            cv2.imwrite(path, out)


def volcano(c, rng, cx, cy, r, lam, lagoon=True, soft=2.0, aspect=1.0, angle=0.0):
    """Reef, lagoon, beach, island blobs painted outside in, as a person would."""
    c.fill(wobbly(cx, cy, r, rng, aspect=aspect, angle=angle), "reef", lam, soft)
    if lagoon:
        c.fill(wobbly(cx, cy, r * 0.82, rng, aspect=aspect, angle=angle), "lagoon", lam, soft)
    c.fill(wobbly(cx + rng.uniform(-3, 3), cy, r * (0.55 if lagoon else 0.78), rng, aspect=aspect, angle=angle), "beach", lam, soft)
    c.fill(wobbly(cx + rng.uniform(-4, 4), cy + rng.uniform(-4, 4), r * (0.42 if lagoon else 0.62), rng,
                  aspect=aspect, angle=angle), "island", lam, soft)


def main(out):
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(2026)
    S = {}
    # Full brightness (young islands: lam = 0).
    c = Canvas(); volcano(c, rng, 128, 128, 92, 0.0); c.noise(rng); S["01-young-volcano.png"] = c
    c = Canvas(); volcano(c, rng, 40, 150, 95, 0.0); c.noise(rng); S["02-on-the-left-border.png"] = c
    c = Canvas(); volcano(c, rng, 80, 85, 55, 0.0); volcano(c, rng, 180, 175, 62, 0.0); c.noise(rng); S["03-two-islands.png"] = c
    c = Canvas(); volcano(c, rng, 128, 128, 110, 0.0, lagoon=False, soft=3.0); c.noise(rng); S["04-fringing-reef-big.png"] = c
    c = Canvas(); volcano(c, rng, 128, 128, 85, 0.0, soft=1.0); S["05-jpeg-q60.jpg"] = (c, 60)
    c = Canvas()  # Figure-14-like odd layout: a long curved island with its reef
    mid, w = arc(128, 150, 80, math.pi * 1.05, math.pi * 1.95, 58, rng); c.stroke(mid, w, "reef", 0.0, 2.5)
    c.stroke(mid, 40, "beach", 0.0, 2.0); c.stroke(mid, 24, "island", 0.0, 2.0); c.noise(rng); S["06-long-arc.png"] = c
    c = Canvas()  # hard-edged polygon island (a vector tool), only anti-aliasing
    for reg, s in (("reef", 1.0), ("lagoon", 0.8), ("beach", 0.55), ("island", 0.4)):
        poly = np.array([[128 + s * 100 * math.cos(a), 128 + s * 80 * math.sin(a)] for a in np.linspace(0, 2 * math.pi, 7)[:-1]])
        c.fill(poly, reg, 0.0, soft=0)
    S["07-polygon-aa.png"] = c
    c = Canvas(); volcano(c, rng, 128, 128, 90, 0.0, aspect=1.6, angle=0.6); c.noise(rng); S["08-elongated.png"] = c
    c = Canvas(); volcano(c, rng, 200, 40, 80, 0.0); volcano(c, rng, 60, 200, 45, 0.0); c.noise(rng, 10); S["09-corner-and-small.png"] = c
    # Darker = subsided.
    c = Canvas(0.3); volcano(c, rng, 128, 128, 95, 0.3); c.noise(rng); S["10-barrier-reef-dim.png"] = c
    c = Canvas(0.5); volcano(c, rng, 128, 128, 90, 0.5); c.noise(rng); S["11-half-sunk.png"] = c
    c = Canvas(0.9)  # atoll: a reef ring round a lagoon, no island
    c.fill(wobbly(128, 128, 100, rng), "reef", 0.9, 2.0); c.fill(wobbly(128, 128, 80, rng), "lagoon", 0.9, 2.0); c.noise(rng)
    S["12-atoll-dark.png"] = c
    c = Canvas(0.6)  # C-shaped reef open to the sea, with motu (small islets) on it
    mid, w = arc(128, 128, 85, 0.3, 2 * math.pi - 0.3, 26, rng); c.stroke(mid, w, "reef", 0.6, 2.0)
    c.fill(wobbly(128, 128, 72, rng, 0.15), "lagoon", 0.6, 2.0)
    for a in (1.0, 2.4, 3.9, 5.2):
        c.fill(wobbly(128 + 85 * math.cos(a), 128 + 85 * math.sin(a), 8, rng), "beach", 0.6, 1.0)
    c.noise(rng); S["13-open-atoll-motu.png"] = c
    c = Canvas()  # three islands at three brightnesses
    volcano(c, rng, 70, 70, 50, 0.0); volcano(c, rng, 190, 90, 50, 0.4); volcano(c, rng, 120, 195, 50, 0.8); c.noise(rng)
    S["14-three-ages.png"] = c
    for name, v in S.items():
        if isinstance(v, tuple):
            v[0].save(os.path.join(out, name), jpeg=v[1])
        else:
            v.save(os.path.join(out, name))
    print(len(S), "sketches in", out)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "tests/data/painted")
