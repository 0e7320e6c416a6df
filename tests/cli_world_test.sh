#!/usr/bin/env bash
# End-to-end checks, part 3: `reefgen world` with the shipped model (sizes,
# aspect, amplification, seams, resume, tiles, refusals).
source "$(dirname "$0")/cli_lib.sh"
SHIPPED="$(dirname "$0")/../models/reef-256.pt"

# 6f. Worlds (docs/WORLDS.md): an archipelago sketch at the model's scale
# keeps its size and aspect; an island larger than the model's
# islands gets one massif whose summit is in its painted mountain; --size
# amplifies a square world, drained and without a measurable seam.
if "$BIN" -q sketch random --size 768x512 --islands 8 --seed 3 -o "$T/w/sea.png" >/dev/null 2>"$T/err" \
   && "$BIN" -q world "$T/w/sea.png" --raw -o "$T/w/sea" >/dev/null 2>"$T/err"; then
  "$PY" -c "import cv2,sys; a=cv2.imread(sys.argv[1]); assert a.shape[:2]==(512,768), a.shape" "$T/w/sea.png" && ok || bad "sketch random --size 768x512 is not 768×512"
  OPENCV_IO_ENABLE_OPENEXR=1 "$PY" -c "import cv2,sys; h=cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED); assert h.shape==(512,768), h.shape" \
    "$T/w/sea.height.exr" && ok || bad "world --raw of a 768×512 sketch is not 768×512"
  "$BIN" realism "$T/w/sea.height.exr" --sketch "$T/w/sea.png" --json | "$PY" -c "
import json, sys
r = json.load(sys.stdin)
assert r['painted_land_above_sea'] >= 0.97 and r['painted_abyss_below_20m'] >= 0.97, r
" && ok || bad "world --raw: painted land not above the sea, or bright abyss not deep (realism --sketch)"
else bad "sketch random WxH / world --raw: $(cat "$T/err")"; fi
"$PY" - "$T/w/big.png" <<'PYEOF'
import cv2, numpy as np, sys
img = np.zeros((640, 640, 3), np.uint8); img[:] = (0, 0, 255)           # abyss (BGR red)
for r, bgr in ((230, (255, 0, 0)), (200, (255, 255, 0)), (175, (0, 255, 0)), (160, (0, 255, 255))):
    cv2.circle(img, (320, 320), r, bgr, -1)                              # reef, lagoon, beach, mountain
cv2.imwrite(sys.argv[1], img)
PYEOF
if "$BIN" -q world "$T/w/big.png" --raw -o "$T/w/big" >/dev/null 2>"$T/err"; then
  OPENCV_IO_ENABLE_OPENEXR=1 "$PY" -c "
import cv2, numpy as np, sys
h = cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED)
s = cv2.GaussianBlur(h, (0, 0), 20)
y, x = np.unravel_index(np.argmax(s), s.shape)
core = np.hypot(*np.mgrid[0:640, 0:640] - 319.5) < 160
assert np.hypot(y - 319.5, x - 319.5) < 100, (y, x)
assert (h[core] > 0).mean() > 0.97, (h[core] > 0).mean()
" "$T/w/big.height.exr" && ok || bad "a 15 km island: no single summit in its painted mountain"
else bad "world on a large island: $(cat "$T/err")"; fi
if "$BIN" -q world "$T/w/big.png" --size 1025 -o "$T/w/big1025" >/dev/null 2>"$T/err"; then
  "$BIN" realism "$T/w/big1025.height.exr" --json | "$PY" -c "
import json, sys
r = json.load(sys.stdin)
assert r['size_px'] == [1025, 1025] and r['pits'] <= 0.01 and r['seams_rows'] <= 2.5 and r['seams_cols'] <= 2.5, r
" && ok || bad "world --size 1025: not drained or seamed"
  # Streamed (a band of rows at a time): the same statistics, the column
  # seams within 1 % (their medians come from histograms).
  "$BIN" realism "$T/w/big1025.height.exr" --json > "$T/w/whole.json" \
    && "$BIN" realism "$T/w/big1025.height.exr" --json --stream > "$T/w/streamed.json" \
    && "$PY" - "$T/w/whole.json" "$T/w/streamed.json" <<'PYEOF' && ok || bad "realism --stream differs from the whole field's"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
for k in ("land_share", "flank_cells", "terraces", "valleys", "seams_rows", "pits"):
    assert a[k] == b[k], (k, a[k], b[k])
assert abs(a["seams_cols"] - b["seams_cols"]) <= 0.01 * a["seams_cols"], (a["seams_cols"], b["seams_cols"])
PYEOF
else bad "world --size 1025: $(cat "$T/err")"; fi
if "$BIN" -q world "$T/w/sea.png" --size 1024 -o "$T/w/sea1024" >/dev/null 2>"$T/err"; then
  "$BIN" realism "$T/w/sea1024.height.exr" --json | "$PY" -c "
import json, sys
r = json.load(sys.stdin)
assert r['size_px'] == [1024, 683] and r['pits'] <= 0.01 and r['seams_rows'] <= 2.5 and r['seams_cols'] <= 2.5, r
" && ok || bad "world --size 1024 of a 768×512 sketch: not 1024×683, drained and seamless"
  "$BIN" -q world "$T/w/sea.png" --size 1024 -o "$T/w/sea1024t1" --threads 1 >/dev/null 2>"$T/err" \
    && cmp -s "$T/w/sea1024.height.exr" "$T/w/sea1024t1.height.exr" && ok || bad "world: other bytes with --threads 1 $(cat "$T/err")"
else bad "world --size on a sketch that is not square: $(cat "$T/err")"; fi
"$BIN" infer "$T/w/sea.png" -o "$T/w/as-island" 2>&1 >/dev/null | grep -q "note: .*sea.png: 768x512 read as one 6 km island.*reefgen world" \
  && ok || bad "infer of a 768x512 sketch does not point to reefgen world"
expect_error "the engine bundles take square worlds" world "$T/w/sea.png" --size 1024 --for unity -o "$T/e/x"
expect_error "no such sketch file" world "$T/w/none.png" -o "$T/w/x"
# A sketch too small or not square for a bundle: one line naming --size, no
# empty bundle folder (nor the output folders the run made) left behind, and
# the fix it names works.
"$PY" -c "import cv2, numpy as np, sys; cv2.imwrite(sys.argv[1], np.full((1, 1, 3), (255, 120, 0), np.uint8)); \
cv2.imwrite(sys.argv[2], np.full((1, 40, 3), (255, 120, 0), np.uint8))" "$T/w/dot.png" "$T/w/row.png"
expect_error "pass --size N" infer "$T/w/dot.png" --for unity -o "$T/e/deep/c"
expect_error "pass --size N" infer "$T/w/row.png" --for godot,gis -o "$T/e/deep/r"
"$BIN" -q infer "$T/w/row.png" --for unity --size 65 -o "$T/w/dot-fixed" >/dev/null 2>"$T/err" \
  && [ -s "$T/w/dot-fixed.unity/dot-fixed.raw" ] && ok || bad "infer --size 65 (the fix named) failed: $(cat "$T/err")"
# A world stopped part way (here an output path that is a folder; Ctrl-C
# keeps the same) leaves nothing in place but its work in PREFIX.partial/;
# the same command resumes it and makes the bytes of an uninterrupted run.
mkdir -p "$T/w/r1/x.unity/x.splat1.png"
"$BIN" -q world "$T/w/big.png" --size 1025 --layers --for unity -o "$T/w/r1/x" >/dev/null 2>"$T/err" \
  && bad "world over a folder succeeded" \
  || { grep -q "x.partial: the same command resumes it" "$T/err" && [ -f "$T/w/r1/x.partial/heights.exr" ] \
       && [ ! -e "$T/w/r1/x.height.exr" ] && ok || bad "an interrupted world: $(cat "$T/err")"; }
rmdir "$T/w/r1/x.unity/x.splat1.png"
if "$BIN" world "$T/w/big.png" --size 1025 --layers --for unity -o "$T/w/r1/x" 2>"$T/err" >/dev/null \
   && "$BIN" -q world "$T/w/big.png" --size 1025 --layers --for unity -o "$T/w/r2/x" >/dev/null 2>&1; then
  grep -q "amplified heights resumed" "$T/err" && grep -q "resumed)" "$T/err" && [ ! -e "$T/w/r1/x.partial" ] \
    && (cd "$T/w/r1" && find . -type f ! -name '*.json' | sort | xargs sha256sum) > "$T/w/r1.sha" \
    && (cd "$T/w/r2" && find . -type f ! -name '*.json' | sort | xargs sha256sum) > "$T/w/r2.sha" \
    && cmp -s "$T/w/r1.sha" "$T/w/r2.sha" && ok || bad "a resumed world differs from an uninterrupted one: $(cat "$T/err")"
else bad "world resume: $(cat "$T/err")"; fi
# Resume trusts nothing it finds: a truncated staged file, a corrupt saved
# field and a planted link are made again (the bytes of an uninterrupted
# run); a PREFIX.partial this command did not make is refused, not deleted.
mkdir -p "$T/w/r3/x.unity/x.splat1.png"
"$BIN" -q world "$T/w/big.png" --size 1025 --layers --for unity -o "$T/w/r3/x" >/dev/null 2>&1
rmdir "$T/w/r3/x.unity/x.splat1.png"
if [ -f "$T/w/r3/x.partial/files/x.height.exr" ] && [ -f "$T/w/r3/x.partial/model.exr" ]; then
  truncate -s 1000 "$T/w/r3/x.partial/files/x.height.exr"
  echo garbage > "$T/w/r3/x.partial/model.exr"
  ln -sf /etc/hostname "$T/w/r3/x.partial/files/x.json"
  "$BIN" -q world "$T/w/big.png" --size 1025 --layers --for unity -o "$T/w/r3/x" >/dev/null 2>"$T/err" \
    && (cd "$T/w/r3" && find . -type f ! -name '*.json' | sort | xargs sha256sum) > "$T/w/r3.sha" \
    && cmp -s "$T/w/r2.sha" "$T/w/r3.sha" && [ ! -L "$T/w/r3/x.json" ] && ok \
    || bad "a world resumed over a truncated, corrupt or linked staged file: $(cat "$T/err")"
else bad "the interrupted world left no staged height file or model field"; fi
# Stopped after the Unity bundle was staged, before the GIS bundle's first
# file (folders where its files go): the rerun resumes with the Unity tiles'
# splat maps found staged, not made again (converting the map it skipped
# stopped every such rerun with an OpenCV assertion), and its Unity bundle is
# the bytes of the uninterrupted --for unity run (r2).
mkdir -p "$T/w/r6/x.gis"
for f in x.height.tif x.slope.tif x.flow.tif x.wear.tif x.deposit.tif README.txt; do mkdir -p "$T/w/r6/x.gis/$f"; done
"$BIN" -q world "$T/w/big.png" --size 1025 --layers --for unity,gis -o "$T/w/r6/x" >/dev/null 2>"$T/err" \
  && bad "world over GIS folders succeeded" || grep -q "x.partial: the same command resumes it" "$T/err" || bad "no resume named: $(cat "$T/err")"
rm -rf "$T/w/r6/x.gis"
if "$BIN" -q world "$T/w/big.png" --size 1025 --layers --for unity,gis -o "$T/w/r6/x" >/dev/null 2>"$T/err"; then
  (cd "$T/w/r6/x.unity" && sha256sum ./*) > "$T/w/r6.sha" && (cd "$T/w/r2/x.unity" && sha256sum ./*) > "$T/w/r2u.sha" \
    && cmp -s "$T/w/r6.sha" "$T/w/r2u.sha" && [ -s "$T/w/r6/x.gis/x.height.tif" ] && [ ! -e "$T/w/r6/x.partial" ] && ok \
    || bad "a world resumed after its Unity bundle differs from an uninterrupted one"
else bad "a world stopped after its Unity bundle does not resume: $(cat "$T/err")"; fi
# A checkpoint another build of reefgen left is not resumed: its heights are
# another program's work (the same binary with one byte appended stands for
# it: reefgen-torch, the program `reefgen world` runs).
mkdir -p "$T/w/r5/x.unity/x.splat1.png"
"$BIN" -q world "$T/w/big.png" --size 1025 --layers --for unity -o "$T/w/r5/x" >/dev/null 2>&1
rmdir "$T/w/r5/x.unity/x.splat1.png"
cp "$(dirname "$BIN")/reefgen-torch" "$T/w/reefgen-other" && printf x >> "$T/w/reefgen-other"
if [ -f "$T/w/r5/x.partial/heights.exr" ] \
   && "$T/w/reefgen-other" world "$T/w/big.png" -m "$SHIPPED" --size 1025 --layers --for unity \
        -o "$T/w/r5/x" >/dev/null 2>"$T/err"; then
  grep -q "holds another world's work; starting again" "$T/err" && ! grep -q "resumed" "$T/err" \
    && (cd "$T/w/r5" && find . -type f ! -name '*.json' | sort | xargs sha256sum) > "$T/w/r5.sha" \
    && cmp -s "$T/w/r2.sha" "$T/w/r5.sha" && ok || bad "another build resumed a world's checkpoint: $(cat "$T/err")"
else bad "another build's world run: $(cat "$T/err")"; fi
# Killed between making PREFIX.partial and writing its key (an empty
# folder), and while removing a finished run's checkpoint (renamed to
# .PREFIX.partial.removing first): the rerun starts afresh, exits 0 with an
# uninterrupted run's bytes and leaves neither (a rerun used to stop on
# "cannot read x.partial/key.json").
mkdir -p "$T/w/r8/x.partial" "$T/w/r8/.x.partial.removing/files" && echo old > "$T/w/r8/.x.partial.removing/files/x.raw"
if "$BIN" -q world "$T/w/big.png" --size 1025 --layers --for unity -o "$T/w/r8/x" >/dev/null 2>"$T/err"; then
  (cd "$T/w/r8" && find . -type f ! -name '*.json' | sort | xargs sha256sum) > "$T/w/r8.sha"
  cmp -s "$T/w/r8.sha" "$T/w/r2.sha" && [ ! -e "$T/w/r8/x.partial" ] && [ ! -e "$T/w/r8/.x.partial.removing" ] && ok \
    || bad "a world over an empty checkpoint and a half-removed one: other bytes, or a folder left"
else bad "a world over an empty checkpoint and a half-removed one: $(cat "$T/err")"; fi
mkdir -p "$T/w/r4/x.partial" && echo mine > "$T/w/r4/x.partial/notes.txt"
expect_error "x.partial: exists and is not a checkpoint of" world "$T/w/big.png" --size 1025 -o "$T/w/r4/x"
[ "$(cat "$T/w/r4/x.partial/notes.txt")" = mine ] && ok || bad "world deleted a PREFIX.partial it did not make"
# Two worlds with one -o at once: the second is refused (they removed each
# other's checkpoint), the first finishes, and no lock file is left.
mkdir -p "$T/w/r6"
"$BIN" -q world "$T/w/big.png" --size 2049 -o "$T/w/r6/x" >/dev/null 2>"$T/err6" &
first=$!
for _ in $(seq 200); do [ -e "$T/w/r6/.x.world.lock" ] && break; sleep 0.1; done
if [ -e "$T/w/r6/.x.world.lock" ]; then
  expect_error "another reefgen process is using this world's outputs" world "$T/w/big.png" --size 2049 -o "$T/w/r6/x"
else bad "the first world took no lock"; fi
wait $first && [ -s "$T/w/r6/x.height.exr" ] && [ ! -e "$T/w/r6/.x.world.lock" ] && [ ! -e "$T/w/r6/x.partial" ] && ok \
  || bad "the first of two worlds with one -o: $(cat "$T/err6")"
# Stopped by a signal while amplifying (SIGINT and SIGTERM): the checkpoint
# stays for the rerun, the lock goes with the process, and the rerun ends
# with the uninterrupted run's heights.
for sig in INT TERM; do
  rm -rf "$T/w/r7"; mkdir -p "$T/w/r7"
  "$BIN" -q world "$T/w/big.png" --size 2049 -o "$T/w/r7/x" >/dev/null 2>&1 &
  pid=$!
  for _ in $(seq 300); do [ -e "$T/w/r7/x.partial" ] && break; sleep 0.05; done
  sleep 0.3; kill -s $sig $pid 2>/dev/null; wait $pid
  if [ ! -e "$T/w/r7/x.height.exr" ]; then
    [ ! -e "$T/w/r7/.x.world.lock" ] && ok || bad "a world stopped by SIG$sig left its lock file"
  fi
  "$BIN" -q world "$T/w/big.png" --size 2049 -o "$T/w/r7/x" >/dev/null 2>"$T/err" \
    && cmp -s "$T/w/r7/x.height.exr" "$T/w/r6/x.height.exr" && [ ! -e "$T/w/r7/.x.world.lock" ] && ok \
    || bad "the rerun of a world stopped by SIG$sig: $(cat "$T/err")"
done
expect_error "--for blender: a world past 8192² is written in tiles" world "$T/w/big.png" --size 9000 --for blender -o "$T/e/x"
# A scale the pass cannot take is refused from the numbers, in one line
# naming the fix that works, and leaves no PREFIX.partial behind.
expect_error "a smaller --metres-per-px or --world-size" world "$T/w/big.png" --world-size 1e8 -o "$T/e/x"
expect_error "say the same thing" world "$T/w/big.png" --world-size 9000 --metres-per-px 20 -o "$T/e/x"
[ ! -e "$T/w/x.height.exr" ] && ok || bad "a failed world wrote its output"

finish
