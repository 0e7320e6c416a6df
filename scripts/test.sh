#!/usr/bin/env bash
# Sets up a fresh machine and runs the whole test suite (GoogleTest + CLI
# end-to-end), as CI does. Tests use tiny sizes: the suite takes seconds.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
cd build
ctest --output-on-failure -j "$(nproc)"
