#!/usr/bin/env bash
# reefgen.torch.PairStream against `reefgen dataset build` (bar: the
# stream on 2 DataLoader workers delivers >= 90 % of the build's pairs/s on
# 2 threads), the same recipe, alternating rounds in one run, medians.
# usage: bash scripts/bench-python.sh [PAIRS=300] [ROUNDS=3]
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/cli/reefgen ] && ls build/python/reefgen/_reefgen*.so >/dev/null 2>&1 || bash scripts/build.sh >&2
source scripts/cpu-line.sh
N=${1:-300}; ROUNDS=${2:-3}
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
cpu_line build/cli/reefgen
for r in $(seq "$ROUNDS"); do
  rm -rf "$T/d"
  s=$(date +%s.%N)
  build/cli/reefgen -q dataset build --count "$N" --seed "$r" --threads 2 --out "$T/d" >/dev/null
  e=$(date +%s.%N)
  build=$(/usr/bin/python3 -c "print(f'{$N / ($e - $s):.1f}')")
  stream=$(PYTHONPATH=build/python /usr/bin/python3 - "$N" "$r" <<'PY'
import sys, time
from torch.utils.data import DataLoader
from reefgen.torch import PairStream
n, seed = int(sys.argv[1]), int(sys.argv[2])
t = time.perf_counter()
got = sum(1 for _ in DataLoader(PairStream(None, seed=seed, count=n), batch_size=None, num_workers=2))
print(f"{got / (time.perf_counter() - t):.1f}")
PY
)
  echo "round $r: dataset build $build pairs/s (2 threads, files), PairStream $stream pairs/s (2 workers, in memory)"
done
