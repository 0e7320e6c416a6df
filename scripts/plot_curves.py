#!/usr/bin/env python3
"""Training curves of one or more runs as a PNG (OpenCV only: no matplotlib on
Debian's minimal installs).

  python3 scripts/plot_curves.py OUT.png NAME=RUN_DIR [NAME=RUN_DIR ...] [--column G_L1]

Two panels from each RUN_DIR/log.csv: the column against the step, and
against wall-clock minutes (the cumulative s_per_iter of each log window), so
runs that learn alike but at different speeds can be told apart at a glance.
"""
import argparse
import csv
import sys

import cv2
import numpy as np

COLOURS = [(200, 90, 30), (40, 140, 230), (60, 170, 60), (150, 60, 170)]  # BGR


def read_log(run, column):
    steps, minutes, values, t = [], [], [], 0.0
    with open(f"{run}/log.csv") as f:
        rows = list(csv.DictReader(f))
    prev = 0
    for r in rows:
        step = int(r["step"])
        t += float(r["s_per_iter"]) * (step - prev) / 60.0
        prev = step
        steps.append(step)
        minutes.append(t)
        values.append(float(r[column]))
    if not steps:
        sys.exit(f"plot_curves: {run}/log.csv has no rows")
    return np.array(steps, float), np.array(minutes), np.array(values)


def panel(series, xlabel, ylabel, w=560, h=360, m=(70, 20, 20, 50)):
    """series: [(name, x, y, colour)] -> BGR image with axes, ticks and legend."""
    img = np.full((h, w, 3), 255, np.uint8)
    left, top, right, bottom = m
    xs = np.concatenate([s[1] for s in series])
    ys = np.concatenate([s[2] for s in series])
    x0, x1 = 0.0, xs.max()
    y0, y1 = min(0.0, ys.min()), ys.max() * 1.05
    X = lambda x: int(left + (x - x0) / (x1 - x0) * (w - left - right))
    Y = lambda y: int(h - bottom - (y - y0) / (y1 - y0) * (h - top - bottom))
    font = cv2.FONT_HERSHEY_SIMPLEX
    for i in range(6):  # grid and tick labels
        xv, yv = x0 + (x1 - x0) * i / 5, y0 + (y1 - y0) * i / 5
        cv2.line(img, (X(xv), top), (X(xv), h - bottom), (230, 230, 230), 1)
        cv2.line(img, (left, Y(yv)), (w - right, Y(yv)), (230, 230, 230), 1)
        cv2.putText(img, f"{xv:.0f}" if x1 > 20 else f"{xv:.1f}", (X(xv) - 14, h - bottom + 18), font, 0.4, (60, 60, 60), 1,
                    cv2.LINE_AA)
        cv2.putText(img, f"{yv:.1f}", (8, Y(yv) + 4), font, 0.4, (60, 60, 60), 1, cv2.LINE_AA)
    cv2.rectangle(img, (left, top), (w - right, h - bottom), (90, 90, 90), 1)
    for k, (name, x, y, colour) in enumerate(series):
        pts = np.array([[X(a), Y(b)] for a, b in zip(x, y)], np.int32)
        cv2.polylines(img, [pts], False, colour, 2, cv2.LINE_AA)
        cv2.line(img, (w - right - 150, top + 18 + 18 * k), (w - right - 125, top + 18 + 18 * k), colour, 2)
        cv2.putText(img, name, (w - right - 118, top + 22 + 18 * k), font, 0.45, (30, 30, 30), 1, cv2.LINE_AA)
    cv2.putText(img, xlabel, (left + (w - left - right) // 2 - 40, h - 12), font, 0.5, (30, 30, 30), 1, cv2.LINE_AA)
    cv2.putText(img, ylabel, (left + 6, top + 14), font, 0.5, (30, 30, 30), 1, cv2.LINE_AA)
    return img


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("runs", nargs="+", help="NAME=RUN_DIR")
    ap.add_argument("--column", default="G_L1")
    a = ap.parse_args()
    by_step, by_time = [], []
    for k, spec in enumerate(a.runs):
        name, _, run = spec.partition("=")
        if not run:
            sys.exit(f"plot_curves: '{spec}' is not NAME=RUN_DIR")
        steps, minutes, values = read_log(run, a.column)
        colour = COLOURS[k % len(COLOURS)]
        by_step.append((name, steps, values, colour))
        by_time.append((name, minutes, values, colour))
    img = np.hstack([panel(by_step, "step", a.column), panel(by_time, "minutes", a.column)])
    if not cv2.imwrite(a.out, img):
        sys.exit(f"plot_curves: cannot write {a.out}")


if __name__ == "__main__":
    main()
