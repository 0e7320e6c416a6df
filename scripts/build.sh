#!/usr/bin/env bash
# Installs the dependencies (if missing) and builds reefgen into ./build:
# everything, or only the targets given (scripts/demo.sh builds `reefgen`,
# not the test suites: a quarter of the build's CPU time, ninja's log).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
cmake -S . -B build "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DREEFGEN_WERROR="${REEFGEN_WERROR:-OFF}" >/dev/null
cmake --build build -j "$(nproc)" ${1:+--target "$@"}
