#!/usr/bin/env bash
# The world bars, measured: an archipelago sketch → a world, N runs
# (median), wall time and peak RSS of each, then `reefgen realism` on the last
# world (pits, terraces, valleys, seams). The CPU model and its flags first.
#   bash scripts/bench-world.sh [RUNS=3] [SKETCH_SIDE=2048] [WORLD_SIDE=16385] [OUT=/tmp/reefgen-bench-world] [FLAGS]
# FLAGS: more world flags, e.g. "--layers --for unity,unreal,gis" (the finished
# world: layers and bundles in tiles past 8192²).
# (bars on 2 cores: 2048² → 16385² ≤ 10 min and ≤ 12 GB; 1024² → 8193² ≤ 3 min;
# realism at full size pits ≤ 1 %, terraces ≤ 3 %, valleys ≥ 0.30, seams ≤ 2.5)
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}; sketch=${2:-2048}; side=${3:-16385}; out=${4:-/tmp/reefgen-bench-world}; flags=${5:-}
[ -x build/cli/reefgen-torch ] || bash scripts/build.sh >&2
source scripts/cpu-line.sh
cpu_line build/cli/reefgen
B=build/cli/reefgen
mkdir -p "$out"
$B -q sketch random --size "${sketch}x${sketch}" --islands 24 --seed 1 -o "$out/sea.png" >/dev/null
times=()
for r in $(seq 1 "$runs"); do
  /usr/bin/time -f "%e %M" -o "$out/time.$r" $B -q world "$out/sea.png" --size "$side" --precision auto -o "$out/world" $flags >/dev/null
  read -r secs kb < "$out/time.$r"
  echo "run $r: ${sketch}² sketch → ${side}² world${flags:+ $flags}: ${secs} s, peak RSS $(( kb / 1024 )) MiB"
  times+=("$secs")
done
median=$(printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}')
echo "median of $runs: ${median} s"
$B realism "$out/world.height.exr" --sketch "$out/sea.png"
