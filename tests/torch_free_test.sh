#!/usr/bin/env bash
# A reefgen built without LibTorch (-DREEFGEN_WITH_TORCH=OFF): the generator,
# erosion, layers and GIS commands work; a network command says in one line
# how to get it, and exits non-zero.
set -uo pipefail
BIN="$1"
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
fail=0
"$BIN" -q generate --preset atoll --size 64 --layers --geotiff -o "$T/a" >/dev/null || { echo "FAIL: generate"; fail=1; }
[ -s "$T/a.splat0.png" ] && [ -s "$T/a.height.tif" ] || { echo "FAIL: no layers or GeoTIFF"; fail=1; }
"$BIN" -q erode "$T/a.height.exr" -o "$T/b" >/dev/null || { echo "FAIL: erode"; fail=1; }
if "$BIN" infer x.png -o "$T/c" >/dev/null 2>"$T/err"; then echo "FAIL: infer ran"; fail=1; fi
[ "$(wc -l < "$T/err")" = 1 ] && grep -q "REEFGEN_WITH_TORCH=ON" "$T/err" || { echo "FAIL: infer message: $(cat "$T/err")"; fail=1; }
# Nothing of LibTorch is linked.
n=$(ldd "$BIN" | grep -c -E "libtorch|libc10")
[ "$n" = 0 ] || { echo "FAIL: $BIN links $n LibTorch libraries"; fail=1; }
[ ! -e "$(dirname "$BIN")/reefgen-torch" ] || { echo "FAIL: reefgen-torch was built"; fail=1; }
exit $fail
