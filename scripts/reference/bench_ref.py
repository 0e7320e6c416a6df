#!/usr/bin/env python3
"""Python reference timings for `reefgen bench train|infer` (same JSON keys).

The original pix2pix networks (pix2pix_ref.py) in Debian's python3-torch,
same threads, same setting, median of --reps after one warm-up.
  python3 bench_ref.py train --ngf 64 --reps 5
  python3 bench_ref.py infer --reps 20
"""
import argparse
import json
import os
import statistics
import sys
import time

import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pix2pix_ref as ref  # noqa: E402


def timed(f):
    t = time.perf_counter()
    f()
    return time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("what", choices=["train", "infer"])
    ap.add_argument("--ngf", type=int, default=64)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--batch", type=int, default=8)
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(1)
    depth = min(8, a.size.bit_length() - 1)
    G = ref.UnetGenerator(3, 1, depth, a.ngf)
    D = ref.NLayerDiscriminator(4, a.ngf, 3)
    ref.init_weights(G)
    ref.init_weights(D)
    x = torch.rand(1, 3, a.size, a.size) * 2 - 1
    y = torch.rand(1, 1, a.size, a.size) * 2 - 1
    out = {"bench": a.what, "impl": "python-reference", "ngf": a.ngf, "size": a.size, "threads": a.threads,
           "reps": a.reps}
    if a.what == "train":
        # One optimiser pair for all steps, as in a real run.
        opt_g = torch.optim.Adam(G.parameters(), lr=2e-4, betas=(0.5, 0.999))
        opt_d = torch.optim.Adam(D.parameters(), lr=2e-4, betas=(0.5, 0.999))
        bce, l1 = torch.nn.BCEWithLogitsLoss(), torch.nn.L1Loss()

        def step():
            fake = G(x)
            for p in D.parameters():
                p.requires_grad_(True)
            opt_d.zero_grad()
            pf = D(torch.cat([x, fake], 1).detach())
            pr = D(torch.cat([x, y], 1))
            ((bce(pf, torch.zeros_like(pf)) + bce(pr, torch.ones_like(pr))) * 0.5).backward()
            opt_d.step()
            for p in D.parameters():
                p.requires_grad_(False)
            opt_g.zero_grad()
            pg = D(torch.cat([x, fake], 1))
            (bce(pg, torch.ones_like(pg)) + l1(fake, y) * 100.0).backward()
            opt_g.step()

        G.train(); D.train()
        step()
        out["s_per_iter"] = round(statistics.median(timed(step) for _ in range(a.reps)), 4)
    else:
        with torch.no_grad():
            G.train(); ref.dropout_off(G)
            G(x)
            out["ms_batchstats"] = round(1e3 * statistics.median(timed(lambda: G(x)) for _ in range(a.reps)), 2)
            G.eval()
            G(x)
            out["ms_running_stats"] = round(1e3 * statistics.median(timed(lambda: G(x)) for _ in range(a.reps)), 2)
            xb = torch.rand(a.batch, 3, a.size, a.size) * 2 - 1
            G.train(); ref.dropout_off(G)
            G(xb)
            t = statistics.median(timed(lambda: G(xb)) for _ in range(max(1, a.reps // 2)))
            out["batch"] = a.batch
            out["sketches_per_s"] = round(a.batch / t, 2)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
