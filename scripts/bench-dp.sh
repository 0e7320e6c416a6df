#!/usr/bin/env bash
# Data-parallel scaling on this machine (docs/TRAINING.md, docs/BENCHMARKS.md):
# the same global batch of 2 trained by 1 rank x 2 threads and by
# 2 ranks x 1 thread (`train --nproc 2`), alternating, REPS times each.
# Prints steps/s medians, their ratio and the all-reduce time per step.
#   scripts/bench-dp.sh DATA [CONFIG...]     (default configs: paper, shipped)
# DATA: a 256² dataset (reefgen dataset build). Steps: STEPS (default 30, the
# first log window of 5 is dropped as warm-up). DP_FLAGS: extra flags for the
# 2-rank runs, e.g. DP_FLAGS="--bucket-mb 4".
set -euo pipefail
data=${1:?usage: scripts/bench-dp.sh DATA [CONFIG...]}
shift
here=$(cd "$(dirname "$0")/.." && pwd)
bin=${REEFGEN:-$here/build/cli/reefgen}
configs=("$@")
[ ${#configs[@]} -gt 0 ] || configs=("$here/configs/train/paper.json" "$here/configs/train/shipped.json")
steps=${STEPS:-30}
reps=${REPS:-3}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$here/scripts/cpu-line.sh"
cpu_line "$bin"
# mean s_per_iter and allreduce_s over the log rows after the first (warm-up) window
stats() { awk -F, 'NR>2 {s+=$8; a+=$9; n++} END {printf "%.4f %.4f\n", s/n, a/n}' "$1/log.csv"; }
for cfg in "${configs[@]}"; do
  one=() two=() ar=()
  for r in $(seq 1 "$reps"); do
    "$bin" -q train --config "$cfg" --data "$data" --out "$tmp/one$r" --batch-size 2 --threads 2 \
      --max-steps "$steps" --log-every 5 >/dev/null
    "$bin" -q train --config "$cfg" --data "$data" --out "$tmp/two$r" --batch-size 1 --threads 1 --nproc 2 \
      --max-steps "$steps" --log-every 5 ${DP_FLAGS:-} >/dev/null
    read -r s1 _ < <(stats "$tmp/one$r")
    read -r s2 a2 < <(stats "$tmp/two$r")
    one+=("$s1") two+=("$s2") ar+=("$a2")
    rm -rf "$tmp/one$r" "$tmp/two$r"
  done
  med() { printf '%s\n' "$@" | sort -g | awk '{v[NR]=$1} END {print v[int((NR+1)/2)]}'; }
  m1=$(med "${one[@]}") m2=$(med "${two[@]}") ma=$(med "${ar[@]}")
  awk -v c="$(basename "$cfg")" -v a="$m1" -v b="$m2" -v r="$ma" 'BEGIN {
    printf "%s: 1 rank x 2 threads %.3f s/step (%.2f steps/s); 2 ranks x 1 thread %.3f s/step (%.2f steps/s), all-reduce %.3f s/step; ratio %.2f\n",
      c, a, 1/a, b, 1/b, r, a/b }'
done
