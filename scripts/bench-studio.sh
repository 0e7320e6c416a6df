#!/usr/bin/env bash
# reefgen studio's stroke-to-update time (bar: p95 ≤ 300 ms at 256² on
# 2 cores): a fresh `reefgen studio`, Debian's chromium (headless, software
# WebGL), N painted strokes; each is timed from the stroke's end to the frame
# after the new heights are drawn (request -> heights returned -> drawn).
# Prints one JSON line: median, p95, the server's share and the phases.
#   bash scripts/bench-studio.sh [STROKES=40] [--size 256|512|1024] [--burst] [--screenshot FILE]
# (bar: p95 ≤ 300 ms at 256², ≤ 600 ms at 1024², also for the last of
# 10 strokes in 2 s: --burst)
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-40}; shift $(( $# > 0 ? 1 : 0 )) || true
[ -x build/cli/reefgen-torch ] || bash scripts/build.sh >&2
source scripts/cpu-line.sh
cpu_line build/cli/reefgen >&2
bash tests/studio_test.sh build/cli/reefgen build/studio/npm/node_modules --strokes "$n" "$@"
