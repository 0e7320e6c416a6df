#!/usr/bin/env python3
"""Data-parallel scaling model of `reefgen train` (docs/TRAINING.md).

Per step every rank all-reduces G's and D's gradients (float32, ring
all-reduce: each rank sends and receives 2(W-1)/W of the bytes) and, with
BatchNorm, 44 small all-reduces of per-channel sums (22 forward, 22 backward;
latency-bound: 2(W-1) hops each). No overlap of communication and compute is
assumed (the trainer all-reduces after each backward).

usage: scripts/scaling_model.py [SECONDS_PER_SAMPLE_NGF32 SECONDS_PER_SAMPLE_NGF64]
  seconds per sample of one rank's compute (default: this repository's
  measurement on a 2-core AMD EPYC, docs/BENCHMARKS.md).
"""
import sys

NETS = {  # parameters of G + D (run.json), BatchNorm sync all-reduces per step
    "ngf 32 (shipped: instance norm)": (9_790_209 + 694_753, 0),
    "ngf 64 (paper: BatchNorm)": (54_409_857 + 2_766_657, 44),
}
LINKS_GBIT = [1, 10, 25]
LATENCY_S = 50e-6  # per hop, TCP over Ethernet
RANKS = [1, 2, 4, 8, 16, 32, 64]


def allreduce_s(params, bn_calls, world, gbit):
    if world == 1:
        return 0.0
    grads = 2 * (world - 1) / world * params * 4 / (gbit * 1e9 / 8) + 2 * (world - 1) * LATENCY_S
    return grads + bn_calls * 2 * (world - 1) * LATENCY_S


def main():
    t = [float(x) for x in sys.argv[1:3]] if len(sys.argv) >= 3 else [0.15, 0.575]
    for (name, (params, bn)), ts in zip(NETS.items(), t):
        print(f"\n{name}: {params * 4 / 1e6:.1f} MB of gradients per step, compute {ts:.2f} s per sample per rank")
        print("| ranks | " + " | ".join(f"all-reduce s/step @ {g} Gbit/s" for g in LINKS_GBIT)
              + " | " + " | ".join(f"per-rank batch where comm = compute @ {g}" for g in LINKS_GBIT)
              + " | efficiency at batch 1 @ 10 Gbit/s |")
        print("|---" * (2 * len(LINKS_GBIT) + 2) + "|")
        for w in RANKS:
            ar = [allreduce_s(params, bn, w, g) for g in LINKS_GBIT]
            bstar = [a / ts for a in ar]
            eff = ts / (ts + ar[1])
            print(f"| {w} | " + " | ".join(f"{a:.3f}" for a in ar) + " | "
                  + " | ".join(f"{b:.2f}" for b in bstar) + f" | {eff:.2f} |")


if __name__ == "__main__":
    main()
