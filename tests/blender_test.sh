#!/usr/bin/env bash
# Debian's Blender imports reefgen's Blender bundle (docs/ENGINES.md): the GLB
# and the displacement script, checked against the EXR by tests/blender_check.py
# at one size whose GLB has a vertex per pixel and one past the GLB's
# 1025² cap. Skipped (exit 77) without blender unless REEFGEN_REQUIRE_BLENDER=1
# (CI sets it: .ci/run installs Debian's blender).
set -u
BIN="$1"
if ! command -v blender >/dev/null; then
  [ "${REEFGEN_REQUIRE_BLENDER:-0}" = 1 ] && { echo "FAIL: blender missing and REEFGEN_REQUIRE_BLENDER=1"; exit 1; }
  echo "SKIP: blender not installed (apt-get install blender)"; exit 77
fi
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
CHECK="$(cd "$(dirname "$0")" && pwd)/blender_check.py"
fail=0
for size in 65 1100; do
  mkdir -p "$T/$size"
  "$BIN" -q generate --preset young-volcano --seed 3 --size "$size" -o "$T/$size/isl" --for blender >/dev/null ||
    { echo "FAIL: generate --size $size --for blender"; fail=1; continue; }
  # Blender's own EXR reader, glTF importer and modifier stack; the check exits 1 on any mismatch.
  # No sound system (Blender 3.4's PulseAudio client left a pulse-* folder
  # in TMPDIR, which the suite counts as a leftover), and Blender's own
  # temporary files in T.
  mkdir -p "$T/tmp"
  if TMPDIR="$T/tmp" timeout 300 blender -b -noaudio --factory-startup --python-exit-code 1 --python "$CHECK" -- "$T/$size/isl.blender" isl \
      >"$T/log" 2>&1 && grep -q "^PASS" "$T/log"; then
    grep -E "^(EXR|GLB|displace)" "$T/log" | sed "s/^/size $size: /"
  else
    echo "FAIL: size $size:"; grep -v "^$" "$T/log" | tail -15; fail=1
  fi
done
[ "$fail" = 0 ] && echo "blender bundle: imports checked"
exit "$fail"
