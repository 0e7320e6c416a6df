#!/usr/bin/env bash
# Sets up a fresh machine and runs the whole test suite (GoogleTest + CLI
# end-to-end), as CI does. Tests use tiny sizes: the suite takes seconds.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
# The CPU class decides which checks run (bf16 ones need AVX-512; they are
# skipped with their reason elsewhere): one line at the top of the log.
source scripts/cpu-line.sh
cpu_line build/cli/reefgen
cd build
ctest --output-on-failure -j "$(nproc)"
