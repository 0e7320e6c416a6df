#!/usr/bin/env bash
# pix2pix speed against the Python reference, in one session on one machine:
# ROUNDS alternating runs of `reefgen bench WHAT` and scripts/reference/bench_ref.py,
# medians of each, and reefgen's speed-up over the reference (> 1: reefgen is faster).
#   bash scripts/bench-model.sh [train|infer|all] [ROUNDS] [extra flags, e.g. --ngf 32]
# Flags for reefgen only (the reference has no such choice) go in RG_FLAGS:
#   RG_FLAGS="--engine torch" bash scripts/bench-model.sh infer 5
#   RG_FLAGS="--precision bf16" bash scripts/bench-model.sh infer 5
#   RG_FLAGS="--precision bf16" bash scripts/bench-model.sh train 5   # bf16 convolutions, fp32 weights
#   RG_FLAGS="--engine torch" bash scripts/bench-model.sh train 5     # LibTorch's own convolutions
#   DNNL_MAX_CPU_ISA=AVX2 OPENBLAS_CORETYPE=Haswell REEFGEN_CPU_PATH=avx2 bash scripts/bench-model.sh all 5  # the AVX2 class
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:-all}; rounds=${2:-3}; shift $(( $# > 2 ? 2 : $# )) || true
[ -x build/cli/reefgen-torch ] || bash scripts/build.sh >&2
py=/usr/bin/python3; [ -x "$py" ] || py=python3
"$py" -c 'import torch' 2>/dev/null || { echo "bench-model: python3-torch missing (bash scripts/install-deps.sh)" >&2; exit 1; }
run() {  # run WHAT KEY REPS
  local w=$1 key=$2 reps=$3 c=() p=()
  for r in $(seq 1 "$rounds"); do
    c+=("$(build/cli/reefgen bench "$w" --reps "$reps" "${@:4}" ${RG_FLAGS:-} 2>/dev/null | "$py" -c "import json,sys; print(json.load(sys.stdin)['$key'])")")
    p+=("$("$py" scripts/reference/bench_ref.py "$w" --reps "$reps" "${@:4}" | "$py" -c "import json,sys; print(json.load(sys.stdin)['$key'])")")
  done
  "$py" - "$w" "$key" "${c[*]}" "${p[*]}" "$(cpu_line build/cli/reefgen)" <<'PY'
import statistics, sys
w, key, c, p = sys.argv[1], sys.argv[2], list(map(float, sys.argv[3].split())), list(map(float, sys.argv[4].split()))
mc, mp = statistics.median(c), statistics.median(p)
speedup = mc / mp if key.endswith("_per_s") else mp / mc  # rates: higher is better; times: lower
print(f"{w:5s} {key:16s} reefgen {mc:9.3f}  python-reference {mp:9.3f}  speed-up {speedup:5.2f}x   "
      f"(rounds: reefgen {c}, reference {p})  [{sys.argv[5]}]")
PY
}
extra=("$@")
# Every figure is written down next to the CPU it came from (and any cap:
# DNNL_MAX_CPU_ISA=AVX2 measures the AVX2 class on an AVX-512 machine, for
# reefgen and the Python reference alike, since both run Debian's libdnnl).
source scripts/cpu-line.sh
cpu_line build/cli/reefgen
if [ "$what" = train ] || [ "$what" = all ]; then run train s_per_iter 3 "${extra[@]}"; fi
if [ "$what" = infer ] || [ "$what" = all ]; then
  run infer ms_batchstats 10 "${extra[@]}"
  run infer sketches_per_s 10 "${extra[@]}"
fi
