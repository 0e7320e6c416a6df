#!/usr/bin/env bash
# Sets up a fresh machine and runs the whole test suite (GoogleTest + CLI
# end-to-end), as CI does. Tests use tiny sizes; on a built tree both suites
# take about 6–7 minutes on 2 cores (AMD EPYC, 2026-11-28; no test is timed: speed is benchmarked apart,
# docs/BENCHMARKS.md).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
# The CPU class decides which checks run (bf16 ones need AVX-512; they are
# skipped with their reason elsewhere): one line at the top of the log.
source scripts/cpu-line.sh
cpu_line build/cli/reefgen
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
# The tests' temporary files go in one folder of the suite's own, removed at
# the end whatever happens; whatever a half leaves in it is named and fails
# the run (a suite cleans up what it made, also when a test fails).
suite_tmp=$(mktemp -d "${TMPDIR:-/tmp}/reefgen-suite.XXXXXX")
trap 'rm -rf "$suite_tmp"' EXIT
nothing_left() {  # nothing_left WHICH-HALF
  local left
  left=$(ls -A "$suite_tmp")
  [ -z "$left" ] || { echo "test.sh: the $1 tests left these in the temporary folder: $(echo $left)" >&2; exit 1; }
}
cd build
TMPDIR="$suite_tmp" ctest --output-on-failure -j "$(nproc)"
nothing_left LibTorch
# The torch-free half (generator, erosion, layers, GIS) builds and passes its
# tests without LibTorch (-DREEFGEN_WITH_TORCH=OFF: nothing of it is found or
# linked), as on a machine that has no libtorch-dev. It is compiled file by
# file (no unity batches): a file that leans on a header another file of its
# batch included fails here, not in a developer's build folder.
cd ..
cmake -S . -B build-notorch "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DREEFGEN_WITH_TORCH=OFF -DREEFGEN_UNITY_BUILD=OFF \
  -DREEFGEN_WERROR="${REEFGEN_WERROR:-OFF}" >/dev/null
cmake --build build-notorch -j "$(nproc)"
(cd build-notorch && TMPDIR="$suite_tmp" ctest --output-on-failure -j "$(nproc)")
nothing_left LibTorch-free
