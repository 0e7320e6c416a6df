#!/usr/bin/env bash
# Runs tests/studio/browser_test.mjs against a fresh `reefgen studio` on a free
# port (REEFGEN_BROWSER_SCRIPT=ux_test.mjs runs that one instead). Skips (exit
# 77, saying why) where chromium, node or playwright-core is missing.
# Usage: studio_test.sh REEFGEN NODE_MODULES_DIR [script args...]
set -u
BIN="$1"; MODULES="$(cd "$2" 2>/dev/null && pwd || echo "$2")"; shift 2
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
# CI sets REEFGEN_REQUIRE_BROWSER=1: a missing piece is then a failure, not a skip.
skip() { if [ "${REEFGEN_REQUIRE_BROWSER:-0}" = 1 ]; then echo "FAIL (required): $*"; exit 1; fi; echo "SKIP: $*"; exit 77; }
[ -x "$CHROMIUM" ] || skip "no chromium at $CHROMIUM (apt-get install chromium)"
command -v node >/dev/null || skip "no node (apt-get install nodejs)"
[ -d "$MODULES/playwright-core" ] || skip "playwright-core not installed in $MODULES (npm was missing at configure time)"
T=$(mktemp -d)
"$BIN" -q studio --port 0 --out "$T/out" > "$T/url" 2>"$T/err" &
pid=$!
trap 'kill $pid 2>/dev/null; wait $pid 2>/dev/null; rm -rf "$T"' EXIT
for _ in $(seq 1 100); do [ -s "$T/url" ] && break; sleep 0.1; done
url=$(head -1 "$T/url")
[ -n "$url" ] || { echo "FAIL: studio did not start: $(cat "$T/err")"; exit 1; }
SCRIPT=${REEFGEN_BROWSER_SCRIPT:-browser_test.mjs}
# The browser's own temporary files (.org.chromium.Chromium.*) go in T too,
# so none is left in the system's temporary folder.
TMPDIR="$T" REEFGEN_NODE_MODULES="$MODULES" node "$(dirname "$0")/studio/$SCRIPT" "$url" "$@"
rc=$?
if [ "$SCRIPT" = browser_test.mjs ]; then
  ls "$T/out"/*.glb >/dev/null 2>&1 || { echo "FAIL: the export did not land in the studio's --out folder"; rc=1; }
fi
# Ctrl-C stops it cleanly.
kill -INT $pid; wait $pid; src=$?
[ "$src" = 0 ] || { echo "FAIL: studio exited $src on SIGINT"; rc=1; }
exit $rc
