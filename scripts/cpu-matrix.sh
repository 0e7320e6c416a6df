#!/usr/bin/env bash
# Runs the CPU-dependent tests (the oneDNN engine, the Python-reference
# equivalence, bf16, the vector paths) once per CPU class this machine can
# be capped down to: AVX2, AVX-512, AVX-512 with bf16, AMX — each with
# DNNL_MAX_CPU_ISA (oneDNN's own cap) and REEFGEN_CPU_PATH (reefgen's loops).
# A class above this CPU is skipped by name, never failed; a check a class
# cannot do (bf16 below AVX-512) skips inside the tests with its reason.
#
#   bash scripts/cpu-matrix.sh            # every class this CPU has, from a built ./build
#   bash scripts/cpu-matrix.sh AVX2       # one class
# Exit status: non-zero when any class fails. docs/BENCHMARKS.md "CPU classes".
set -euo pipefail
cd "$(dirname "$0")/.."
[ -d build ] || { echo "cpu-matrix: no ./build: run bash scripts/build.sh first" >&2; exit 2; }
source scripts/cpu-line.sh
cpu_line build/cli/reefgen
flags=$(grep -m1 '^flags' /proc/cpuinfo || true)
has() { [[ " $flags " == *" $1 "* ]]; }
# class name, what /proc/cpuinfo must show, REEFGEN_CPU_PATH for it
classes=("AVX2:avx2:avx2" "AVX512_CORE:avx512bw:avx512" "AVX512_CORE_BF16:avx512_bf16:avx512" "AVX512_CORE_AMX:amx_bf16:avx512")
wanted=("$@")
# The tests whose results depend on the kernels a CPU class picks.
pattern='Reference\.|FastUNet\.|DnnlConv\.|Infer\.Bf16|Infer\.Precision|Infer\.Hidden|VectorPath|FastAtan2'
failed=0
for c in "${classes[@]}"; do
  IFS=: read -r isa flag path <<<"$c"
  if [ ${#wanted[@]} -gt 0 ] && [[ " ${wanted[*]} " != *" $isa "* ]]; then continue; fi
  if ! has "$flag"; then
    echo "cpu-matrix: $isa skipped: this CPU has no $flag"
    continue
  fi
  echo "cpu-matrix: $isa (DNNL_MAX_CPU_ISA=$isa REEFGEN_CPU_PATH=$path)"
  if (cd build && DNNL_MAX_CPU_ISA=$isa REEFGEN_CPU_PATH=$path ctest -R "$pattern" -j "$(nproc)" --output-on-failure >"/tmp/cpu-matrix-$isa.log" 2>&1); then
    echo "cpu-matrix: $isa passed ($(grep -m1 'tests passed' "/tmp/cpu-matrix-$isa.log"))"
  else
    echo "cpu-matrix: $isa FAILED: /tmp/cpu-matrix-$isa.log" >&2
    failed=1
  fi
done
exit $failed
