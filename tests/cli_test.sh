#!/usr/bin/env bash
# End-to-end checks of the reefgen binary: outputs, determinism across thread
# counts, and the error paths (one line, non-zero exit, no partial files).
set -u
BIN="$1"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fail=0; pass=0
PY=/usr/bin/python3; [ -x "$PY" ] || PY=python3
ok() { pass=$((pass+1)); }
bad() { echo "FAIL: $*"; fail=$((fail+1)); }
# Errors: one line on stderr, non-zero exit, nothing written (under $T/e).
expect_error() {  # expect_error NEEDLE ARGS...
  local needle="$1"; shift
  rm -rf "$T/e"; mkdir -p "$T/e"
  if "$BIN" "$@" >/dev/null 2>"$T/err"; then bad "no error for: $*"; return; fi
  [ "$(wc -l < "$T/err")" = 1 ] || bad "not one line for: $* -> $(cat "$T/err")"
  grep -q -- "$needle" "$T/err" || bad "message lacks '$needle' for: $* -> $(cat "$T/err")"
  [ -z "$(ls -A "$T/e")" ] || bad "files left for: $*: $(ls "$T/e")"
  ok
}
skipped=0
skip() { echo "SKIP: $*"; skipped=$((skipped+1)); }

# The CPU class this run is on (bf16 checks run only where oneDNN has bf16
# convolutions: AVX-512; every float32 check runs everywhere).
CPU_JSON=$("$BIN" -q model cpu) || { echo "FAIL: model cpu"; exit 1; }
echo "cpu: $(echo "$CPU_JSON" | "$PY" -c 'import json,sys; print(json.load(sys.stdin)["summary"])')"
HAS_BF16=$(echo "$CPU_JSON" | "$PY" -c 'import json,sys; print(int(json.load(sys.stdin)["bf16_convolutions"]))')

# 1. Every preset generates the four files; the EXR starts with the EXR magic.
for p in $("$BIN" presets | awk '{print $1}'); do
  if "$BIN" generate --preset "$p" --size 64 -o "$T/p/$p" --preview >/dev/null 2>"$T/err"; then
    for s in height.exr label.png preview.png json; do [ -s "$T/p/$p.$s" ] || bad "preset $p: no $s"; done
    [ "$(head -c4 "$T/p/$p.height.exr" | od -An -tx1 | tr -d ' ')" = "762f3101" ] && ok || bad "preset $p: not an EXR"
  else bad "preset $p failed: $(cat "$T/err")"; fi
done

# 1a. Every vector path (REEFGEN_CPU_PATH; a path the CPU lacks is capped to
# the widest it has) gives the same bytes: an eroded random island with
# layers, whose routing and outline look-ups run on the dispatched loops.
for path in sse2 avx2 avx512; do
  REEFGEN_CPU_PATH=$path "$BIN" -q generate --random 1 --seed 3 --size 96 --layers --out "$T/vp/$path" >/dev/null 2>"$T/err" \
    || bad "generate on the $path path: $(cat "$T/err")"
  (cd "$T/vp/$path" && find . -type f ! -name '*.json' | sort | xargs sha256sum) > "$T/vp/$path.sha"
done
[ -s "$T/vp/sse2.sha" ] && cmp -s "$T/vp/sse2.sha" "$T/vp/avx2.sha" && cmp -s "$T/vp/sse2.sha" "$T/vp/avx512.sha" \
  && ok || bad "the vector paths give different bytes: $(diff "$T/vp/sse2.sha" "$T/vp/avx512.sha" | head -3)"
# The network's own loops (the engine's rows, the Winograd transforms) too:
# one dispatch, so REEFGEN_CPU_PATH reaches them.
if [ -x "$(dirname "$BIN")/reefgen-torch" ] && [ -f "$(dirname "$0")/../models/reef-256.pt" ]; then
  for path in sse2 avx2 avx512; do
    REEFGEN_CPU_PATH=$path "$BIN" -q infer "$(dirname "$0")/data/painted/01-young-volcano.png" -o "$T/vp/net-$path" >/dev/null 2>"$T/err" \
      || bad "infer on the $path path: $(cat "$T/err")"
  done
  cmp -s "$T/vp/net-sse2.height.exr" "$T/vp/net-avx2.height.exr" && cmp -s "$T/vp/net-sse2.height.exr" "$T/vp/net-avx512.height.exr" \
    && ok || bad "the network's vector paths give different bytes"
fi
REEFGEN_CPU_PATH=avx3 "$BIN" -q generate --preset atoll --size 32 -o "$T/vp/x" 2>"$T/err" >/dev/null
[ $? -ne 0 ] && grep -q "REEFGEN_CPU_PATH='avx3'" "$T/err" && ok || bad "an unknown REEFGEN_CPU_PATH is not one line"

# 1b. The generator's commands never load LibTorch (docs/DESIGN.md §7): the
# dynamic loader's own list of what it initialised; the network commands do
# (through reefgen-torch, same process).
for cmd in "presets" "generate --preset atoll --size 48 -o $T/nt/atoll" "sketch random --seed 1 --size 64 -o $T/nt/s.png" \
           "realism $T/p/atoll.height.exr"; do
  n=$(LD_DEBUG=libs "$BIN" -q $cmd 2>&1 >/dev/null | grep "calling init" | grep -c torch)
  [ "$n" = 0 ] && ok || bad "'$cmd' loaded $n LibTorch libraries"
done
n=$(LD_DEBUG=libs "$BIN" -q model info 2>&1 >/dev/null | grep "calling init" | grep -c torch)
[ "$n" -gt 0 ] && ok || bad "'model info' did not reach reefgen-torch"
"$BIN" --help 2>&1 | grep -q "infer" && "$BIN" --help 2>&1 | grep -q "generate" && ok || bad "--help does not list every command"

# 2. Same seed, same bytes, whatever the thread count; a rerun resumes (skips).
"$BIN" -q generate --random 3 --levels 2 --seed 11 --size 48 --out "$T/r1" --threads 1 >/dev/null || bad "random t1"
"$BIN" -q generate --random 3 --levels 2 --seed 11 --size 48 --out "$T/r2" --threads 2 >/dev/null || bad "random t2"
[ "$(ls "$T/r1" | wc -l)" = 18 ] && ok || bad "random: expected 18 files, got $(ls "$T/r1" | wc -l)"
diff -r "$T/r1" "$T/r2" >/dev/null && ok || bad "threads 1 vs 2 differ"
"$BIN" -q generate --random 3 --levels 2 --seed 12 --size 48 --out "$T/r3" >/dev/null
cmp -s "$T/r1/island_000000_l0.height.exr" "$T/r3/island_000000_l0.height.exr" && bad "seed has no effect" || ok
rm "$T/r2/island_000001_l1.json" "$T/r2/island_000002_l0.height.exr"  # an interrupted run
"$BIN" generate --random 3 --levels 2 --seed 11 --size 48 --out "$T/r2" --threads 2 >/dev/null 2>"$T/err" || bad "resume failed"
grep -q "wrote 2 islands (4 already there)" "$T/err" && ok || bad "resume did not skip: $(cat "$T/err")"
diff -r "$T/r1" "$T/r2" >/dev/null && ok || bad "resumed run differs"

# 2b. Layers (docs/LAYERS.md): every file, weights summing to 255 at every
# pixel, same bytes whatever the threads (--random), a bad rule refused.
"$BIN" -q generate --preset young-volcano --size 96 --layers -o "$T/lay/yv" >/dev/null || bad "generate --layers"
for s in flow slope wear deposit normal splat0 splat1 materials; do [ -s "$T/lay/yv.$s.png" ] || bad "layers: no $s"; done
"$PY" - "$T/lay/yv" <<'PYEOF' && ok || bad "layers: splat weights or sidecar"
import cv2, json, sys
p = sys.argv[1]
a = cv2.imread(p + ".splat0.png", cv2.IMREAD_UNCHANGED).astype(int)
b = cv2.imread(p + ".splat1.png", cv2.IMREAD_UNCHANGED).astype(int)
assert a.shape == (96, 96, 4) and b.shape == (96, 96, 4), (a.shape, b.shape)
assert ((a.sum(2) + b.sum(2)) == 255).all()
j = json.load(open(p + ".json"))
assert [m["name"] for m in j["layers"]["materials"]][:2] == ["deep_sea_floor", "lagoon_sand"]
assert j["files"]["flow"] == "yv.flow.png" and cv2.imread(p + ".flow.png", cv2.IMREAD_UNCHANGED).dtype.name == "uint16"
PYEOF
"$BIN" -q generate --random 2 --levels 1 --seed 3 --size 48 --layers --out "$T/lay1" --threads 1 >/dev/null || bad "random --layers t1"
"$BIN" -q generate --random 2 --levels 1 --seed 3 --size 48 --layers --out "$T/lay2" --threads 2 >/dev/null || bad "random --layers t2"
diff -r "$T/lay1" "$T/lay2" >/dev/null && ok || bad "layers: threads 1 vs 2 differ"
echo '{"cliff_deg": 95}' > "$T/rules.json"
"$BIN" -q generate --preset atoll --size 48 --layers --layer-rules "$T/rules.json" -o "$T/lay/bad" >/dev/null 2>"$T/err" \
  && bad "layer rules out of range accepted" || { grep -q "rules.json" "$T/err" && ok || bad "layer rules: $(cat "$T/err")"; }
[ -e "$T/lay/bad.height.exr" ] && bad "layer rules: files written" || ok

# 2c. reefgen erode on a heightmap of yours, and the GIS files in GDAL's own
# tools (docs/GIS.md): pixel size and metres in gdalinfo, gdaldem hillshade
# and a 0 m contour unscaled, GeoTIFF heights equal to the EXR.
"$BIN" -q terrain wilbur --seed 5 --size 128 -o "$T/er/w" >/dev/null || bad "terrain wilbur for erode"
"$BIN" -q erode "$T/er/w.height.exr" -o "$T/er/we" --layers --geotiff --png16 --r16 >/dev/null 2>"$T/err" || bad "erode: $(cat "$T/err")"
for s in height.exr height.tif flow.tif slope.tif splat0.png json r16 height.png; do [ -s "$T/er/we.$s" ] || bad "erode: no $s"; done
"$PY" - "$T/er/we" <<'PYEOF' && ok || bad "erode: realism after or sidecar"
import json, sys
j = json.load(open(sys.argv[1] + ".json"))
assert j["realism_after"]["pits"] <= 0.01, j["realism_after"]
assert j["input"]["format"] == "exr" and abs(j["metres_per_pixel"] - 6000 / 128) < 1e-3, j["metres_per_pixel"]
assert j["geotiff"]["files"]["height"] == "we.height.tif"
PYEOF
if command -v gdalinfo >/dev/null && command -v gdaldem >/dev/null && command -v gdal_contour >/dev/null; then
  gdalinfo -json -stats "$T/er/we.height.tif" > "$T/er/info.json" 2>"$T/err" || bad "gdalinfo: $(cat "$T/err")"
  "$PY" - "$T/er" <<'PYEOF' && ok || bad "GeoTIFF: pixel size, units or heights differ from the EXR"
import cv2, json, sys
d = sys.argv[1]
info = json.load(open(d + "/info.json"))
gt = info["geoTransform"]
assert abs(gt[1] - 6000 / 128) < 1e-3 and abs(gt[5] + 6000 / 128) < 1e-3, gt
band = info["bands"][0]
assert band["unit"] == "metre" and band["type"] == "Float32", band
exr = cv2.imread(d + "/we.height.exr", cv2.IMREAD_UNCHANGED)
assert abs(band["minimum"] - exr.min()) < 0.01 and abs(band["maximum"] - exr.max()) < 0.01, (band, exr.min(), exr.max())
PYEOF
  gdaldem hillshade -q "$T/er/we.height.tif" "$T/er/hs.tif" 2>"$T/err" || bad "gdaldem: $(cat "$T/err")"
  # Unscaled metres: the hillshade is not flattened to near-black/near-white (an 800x exaggeration is).
  gdalinfo -stats "$T/er/hs.tif" 2>/dev/null | grep -q "Mean=1[0-9][0-9]" && ok || bad "hillshade mean not mid-grey: $(gdalinfo -stats "$T/er/hs.tif" | grep Mean)"
  gdal_contour -q -fl 0 "$T/er/we.height.tif" "$T/er/c0.csv" -f CSV 2>"$T/err" || bad "gdal_contour: $(cat "$T/err")"
  [ "$(wc -l < "$T/er/c0.csv")" -gt 1 ] && ok || bad "gdal_contour -fl 0 found no coastline"
  # docs/GIS.md's own example, as written: the atoll's coastline (its motu) is found.
  mkdir -p "$T/gis"
  "$BIN" -q generate --preset atoll --size 1025 --layers --geotiff --crs EPSG:32706 --origin 500000,8100000 -o "$T/gis/atoll" >/dev/null 2>"$T/err" \
    && gdal_contour -q -fl 0 "$T/gis/atoll.height.tif" "$T/gis/atoll.coast.gpkg" 2>"$T/err" \
    && [ "$(ogrinfo -so "$T/gis/atoll.coast.gpkg" contour 2>/dev/null | sed -n 's/^Feature Count: //p')" -ge 1 ] \
    && ok || bad "docs/GIS.md's coastline example finds no coastline: $(cat "$T/err")"
  # The 16-bit files get a VRT GDAL reads as metres (Offset/Scale), equal to the EXR within a 16-bit step.
  gdal_translate -q -unscale -ot Float32 "$T/er/we.r16.vrt" "$T/er/r16m.tif" 2>"$T/err" || bad "r16 vrt: $(cat "$T/err")"
  gdalinfo -json -stats "$T/er/r16m.tif" > "$T/er/r16.json" 2>/dev/null
  "$PY" - "$T/er" <<'PYEOF' && ok || bad "R16 VRT not in metres"
import cv2, json, sys
d = sys.argv[1]
b = json.load(open(d + "/r16.json"))["bands"][0]
exr = cv2.imread(d + "/we.height.exr", cv2.IMREAD_UNCHANGED)
step = (exr.max() - exr.min()) / 65535 + 0.01
assert abs(b["minimum"] - exr.min()) < step and abs(b["maximum"] - exr.max()) < step, (b, exr.min(), exr.max())
PYEOF
else
  skip "gdal-bin not installed: GeoTIFF client checks (bash scripts/install-deps.sh)"
fi
# Unity: Flip Vertically said; a size Unity cannot take (128, not 2^n+1) is said, not given Unity steps.
"$PY" - "$T/er/we.json" <<'PYEOF' && ok || bad "unity import numbers"
import json, sys
j = json.load(open(sys.argv[1]))["r16"]
u = j["import"]["unity"]
assert u["flip_vertically"] is True and u["importable"] is False, u
assert "Unity cannot import this file" in j["import_note"] and "Flip Vertically" not in j["import_note"], j["import_note"]
assert abs(u["terrain_width_m"] - 127 * 6000 / 128) < 1e-6, u["terrain_width_m"]
PYEOF
# infer gets the same layers (the sketch's regions) and GeoTIFFs.
"$BIN" -q infer "$(dirname "$0")/../docs/examples/painted-sketch.png" --size 96 --layers --geotiff -o "$T/er/inf" >"$T/out" 2>"$T/err" || bad "infer --layers: $(cat "$T/err")"
for s in splat0.png splat1.png flow.png height.tif slope.tif; do [ -s "$T/er/inf.$s" ] || bad "infer --layers: no $s"; done
# stdout lists every file written, as generate's does (it listed the EXR alone).
[ "$(sort "$T/out")" = "$(find "$T/er" -maxdepth 1 -name 'inf.*' -type f | sort)" ] && ok \
  || bad "infer's stdout is not the files it wrote: $(cat "$T/out")"
# --running-stats on the shipped (instance-norm) model: said to change nothing, and the sidecar agrees.
"$BIN" infer "$(dirname "$0")/../docs/examples/painted-sketch.png" --raw --running-stats -o "$T/er/rs" 2>&1 >/dev/null |
  grep -q "running-stats changes nothing" && grep -q '"batchnorm": "none (the generator uses instance norm)"' "$T/er/rs.json" \
  && ok || bad "--running-stats on an instance-norm model is not said to change nothing"
# Errors: PNG16 and R16 without units, a RAW of the wrong length, not square, over its input.
"$BIN" -q erode "$T/er/we.height.png" -o "$T/er/x" >/dev/null 2>"$T/err" && bad "png16 without --range accepted" || \
  { grep -q "we.height.png.*--range" "$T/err" && ok || bad "png16 no range: $(cat "$T/err")"; }
head -c 1001 /dev/zero > "$T/er/odd.r16"
"$BIN" -q erode "$T/er/odd.r16" --range 0:100 --world-size 1000 -o "$T/er/x" >/dev/null 2>"$T/err" && bad "odd RAW accepted" || \
  { grep -q "odd.r16: 1001 bytes" "$T/err" && ok || bad "odd RAW: $(cat "$T/err")"; }
"$BIN" -q erode "$T/er/we.r16" --range -100:400 --world-size 6000 -o "$T/er/r" >/dev/null 2>"$T/err" && ok || bad "erode r16: $(cat "$T/err")"
"$BIN" -q erode "$T/er/w.height.exr" -o "$T/er/w" >/dev/null 2>"$T/err" && bad "erode over its input accepted" || \
  { grep -q "w.height.exr" "$T/err" && ok || bad "over input: $(cat "$T/err")"; }
# Hostile inputs refused before any work: a PNG16 whose header declares
# 20000² (checked before decoding), degrees read as metres, cell sizes the
# erosion cannot route, a geographic --crs.
"$PY" - "$T/er/we.height.png" "$T/er/liar.png" <<'PYEOF' || bad "could not forge the 20000² PNG"
import struct, sys
b = bytearray(open(sys.argv[1], "rb").read()); b[16:24] = struct.pack(">II", 20000, 20000)
open(sys.argv[2], "wb").write(bytes(b))
PYEOF
expect_error "20000×20000 pixels; at most 8192" erode "$T/er/liar.png" --range 0:100 --world-size 6000 -o "$T/e/x"
expect_error "metres-per-px" erode "$T/er/w.height.exr" --metres-per-px 0.001 -o "$T/e/x"
expect_error "erode takes 0.1 to 1000 m cells" erode "$T/er/w.height.exr" --world-size 1 -o "$T/e/x"
expect_error "a geographic CRS" erode "$T/er/w.height.exr" --geotiff --crs EPSG:4326 -o "$T/e/x"
if command -v gdal_translate >/dev/null; then
  gdal_translate -q -a_srs EPSG:4326 -a_ullr 150 -17 150.01 -17.01 "$T/er/we.height.tif" "$T/er/deg.tif" 2>/dev/null
  expect_error "geographic (degrees" erode "$T/er/deg.tif" -o "$T/e/x"
  gdal_translate -q -a_ullr 0 0 6000 6000 "$T/er/we.height.tif" "$T/er/southup.tif" 2>/dev/null
  expect_error "south-up" erode "$T/er/southup.tif" -o "$T/e/x"
  # The fixes the two refusals name work: the gdalwarp the degrees' refusal
  # prints, run as printed (the place's UTM zone, 56 south here, a square
  # grid), and a north-up copy of the south-up file both erode.
  "$BIN" erode "$T/er/deg.tif" -o "$T/e/x" 2>"$T/deg.err" >/dev/null
  fix=$(sed -n 's/.*metres first: \(gdalwarp .*\)$/\1/p' "$T/deg.err")
  case "$fix" in *"EPSG:32756 "*) ok ;; *) bad "the degrees' refusal names no UTM zone 56 S: $(cat "$T/deg.err")" ;; esac
  (eval "$fix -q") 2>/dev/null && "$BIN" -q erode "$T/er/deg.utm.tif" -o "$T/er/fixed-utm" >/dev/null 2>"$T/err" \
    && [ -s "$T/er/fixed-utm.height.exr" ] && ok || bad "erode after the gdalwarp its refusal names ($fix): $(cat "$T/err")"
  gdal_translate -q -srcwin 0 0 128 100 "$T/er/we.height.tif" "$T/er/wide.tif" 2>/dev/null
  expect_error "crop or pad it to N×N (gdal_translate -srcwin)" erode "$T/er/wide.tif" -o "$T/e/x"
  gdal_translate -q -srcwin 0 0 100 100 "$T/er/wide.tif" "$T/er/cropped.tif" 2>/dev/null \
    && "$BIN" -q erode "$T/er/cropped.tif" -o "$T/er/fixed-crop" >/dev/null 2>"$T/err" && [ -s "$T/er/fixed-crop.height.exr" ] \
    && ok || bad "erode after the gdal_translate -srcwin its refusal names: $(cat "$T/err")"
  gdalwarp -q "$T/er/southup.tif" "$T/er/north-up.tif" 2>/dev/null \
    && "$BIN" -q erode "$T/er/north-up.tif" -o "$T/er/fixed-north" >/dev/null 2>"$T/err" && [ -s "$T/er/fixed-north.height.exr" ] \
    && ok || bad "erode after the gdalwarp its south-up refusal names: $(cat "$T/err")"
fi
# An input inside the bundle folder the run writes (through ../ too) is refused, untouched.
"$BIN" -q erode "$T/er/w.height.exr" -o "$T/er/b" --for gis >/dev/null 2>"$T/err" || bad "erode --for gis: $(cat "$T/err")"
# erode takes its input's size: a Unity note tells to resample the input, not a --size it has not got.
"$BIN" erode "$T/er/w.height.exr" -o "$T/er/u" --for unity 2>&1 >/dev/null | grep "note: --for unity" > "$T/note" || true
grep -q "resample the input to" "$T/note" && ! grep -q -- "--size" "$T/note" && ok || bad "erode's Unity note: $(cat "$T/note")"
sha_before=$(sha256sum < "$T/er/b.gis/b.height.tif")
"$BIN" -q erode "$T/er/b.gis/b.height.tif" -o "$T/er/../er/b" --for gis >/dev/null 2>"$T/err" && bad "erode into its input's bundle accepted" || \
  { grep -q "lies in .*b.gis, which this run writes" "$T/err" && [ "$(sha256sum < "$T/er/b.gis/b.height.tif")" = "$sha_before" ] \
    && ok || bad "input inside the bundle: $(cat "$T/err")"; }
"$BIN" -q erode "$T/er/w.height.exr" -o "$T/er/c" --geotiff --crs EPSG:999999 >/dev/null 2>"$T/err" && bad "unknown CRS accepted" || \
  { grep -q "EPSG:999999" "$T/err" && ok || bad "crs: $(cat "$T/err")"; }
[ -e "$T/er/c.height.exr" ] && bad "unknown CRS: files written" || ok

# 3. Errors: one line on stderr, non-zero exit, nothing written.
echo '{"subsidence": 2}' > "$T/range.json"
echo '{"outlines": [0.3, ' > "$T/broken.json"
echo '{"wind": [], "profle": [0.5, 0.1]}' > "$T/typo.json"
touch "$T/afile"
expect_error "no such file" generate --spec "$T/missing.json" -o "$T/e/x"
expect_error "broken.json: invalid JSON" generate --spec "$T/broken.json" -o "$T/e/x"
expect_error "subsidence = 2 is out of range" generate --spec "$T/range.json" -o "$T/e/x"
expect_error 'unknown key "profle"' generate --spec "$T/typo.json" -o "$T/e/x"
expect_error "unknown preset" generate --preset volcano -o "$T/e/x"
expect_error "subsidence: value 1.5 must be a finite number in \[0, 1\]" generate --preset atoll --subsidence 1.5 -o "$T/e/x"
expect_error "size" generate --preset atoll --size 3 -o "$T/e/x"
expect_error "afile" generate --preset atoll -o "$T/afile/sub/x"
expect_error "needs --out" generate --random 2
echo '{"age_myr": -0.5}' > "$T/age.json"
expect_error "age_myr = -0.5 is out of range" generate --spec "$T/age.json" -o "$T/e/x"
expect_error "age-myr: value 61 must be" generate --preset atoll --age-myr 61 -o "$T/e/x"
expect_error "use them with --preset or --spec, not --random" generate --random 2 --age-myr 3 --out "$T/e/r"
# The amplification's keys are infer's (--erosion), not a spec's: refused there.
echo '{"erosion": {"amplify_roughness": 0.5}}' > "$T/amp_spec.json"
expect_error 'unknown key "erosion.amplify_roughness"' generate --spec "$T/amp_spec.json" -o "$T/e/x"

# 4. Datasets: threads, shards + merge = unsharded, resume, foreign files.
cat > "$T/ds.json" <<'JSON'
{"count": 12, "size_px": 32, "levels": 3, "val_fraction": 0.2, "test_fraction": 0.2,
 "p_affine": 0.5, "p_translate": 0.5, "p_paste": 0.5, "paste_scale": 0.5}
JSON
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/d1" --threads 1 >/dev/null || bad "dataset t1"
[ -z "$(find "$T/d1" -name '.reefgen*.lock')" ] && ok || bad "dataset build left its lock file: $(find "$T/d1" -name '*.lock')"
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/d2" --threads 2 >/dev/null || bad "dataset t2"
diff -r "$T/d1" "$T/d2" >/dev/null && ok || bad "dataset threads 1 vs 2 differ"
[ "$(wc -l < "$T/d1/manifest.jsonl")" = 12 ] && ok || bad "manifest should list 12 pairs"
# No configuration in two splits.
[ "$(sed -E 's/.*"configuration":([0-9]+).*"split":"([a-z]+)".*/\1 \2/' "$T/d1/manifest.jsonl" | sort -u | awk '{print $1}' | uniq -d | wc -l)" = 0 ] && ok || bad "a configuration leaks across splits"
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/d3" --shard 1/2 >/dev/null || bad "shard 1/2"
"$BIN" -q dataset merge "$T/d3" >/dev/null 2>&1 && bad "merge with a missing shard succeeded" || ok
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/d3" --shard 0/2 >/dev/null || bad "shard 0/2"
"$BIN" -q dataset merge "$T/d3" >/dev/null || bad "merge"
cmp -s "$T/d1/manifest.jsonl" "$T/d3/manifest.jsonl" && ok || bad "merged shards differ from the unsharded build"
cp "$T/d3/train/$(ls "$T/d3/train" | head -1)" "$T/d3/train/99999999.label.png"   # a file no manifest lists
if "$BIN" -q dataset merge "$T/d3" >/dev/null 2>"$T/err"; then bad "merge accepted a foreign file"
else grep -q "99999999.label.png" "$T/err" && ok || bad "foreign file not named: $(cat "$T/err")"; fi
cmp -s "$T/d1/manifest.jsonl" "$T/d3/manifest.jsonl" && ok || bad "a failed merge changed manifest.jsonl"
rm "$T/d3/train/99999999.label.png"
f=$(ls "$T/d2/train" | head -1)
rm "$T/d2/train/$f" "$T/d2/manifest.jsonl"   # an interrupted build
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/d2" >/dev/null || bad "dataset resume"
diff -r "$T/d1" "$T/d2" >/dev/null && ok || bad "resumed dataset differs"
g=$(ls "$T/d2/train" | grep label.png | head -1)
cp "$T/d2/train/$(ls "$T/d2/train" | grep label.png | tail -1)" "$T/d2/train/$g"   # a foreign file
if "$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/d2" 2>"$T/err" >/dev/null; then bad "foreign file accepted"
else grep -q "$g is corrupt or from another dataset" "$T/err" && ok || bad "foreign file message: $(cat "$T/err")"; fi
"$BIN" -q dataset build --config "$T/ds.json" --seed 5 --out "$T/d1" 2>"$T/err" >/dev/null && bad "other seed into same folder" || ok
# --layers: each pair's layer files, listed with checksums; sharded and merged equal, threads alike.
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/dl1" --layers --threads 1 >/dev/null || bad "dataset --layers"
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/dl2" --layers --threads 2 --shard 0/2 >/dev/null &&
  "$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/dl2" --layers --threads 2 --shard 1/2 >/dev/null &&
  "$BIN" -q dataset merge "$T/dl2" >/dev/null && cmp -s "$T/dl1/manifest.jsonl" "$T/dl2/manifest.jsonl" && ok ||
  bad "dataset --layers: sharded, 2 threads, merged differs from 1 thread"
"$PY" -c "
import json, sys, os
lines = [json.loads(l) for l in open(sys.argv[1] + '/manifest.jsonl')]
assert len(lines) == 12 and all(len(r['layers']) == 8 and set(r['layers']) == set(r['layers_fnv64']) for r in lines)
assert all(os.path.exists(sys.argv[1] + '/' + f) for r in lines for f in r['layers'].values())
" "$T/dl1" && ok || bad "dataset --layers: manifest does not list eight layer files per pair"
# The layouts for other tools: errors in one line, nothing written.
expect_error "use reefgen, pix2pix, webdataset or imagefolder" dataset build --count 2 --out "$T/e/x" --format tfrecord
expect_error "add --format webdataset" dataset build --count 2 --out "$T/e/x" --format pix2pix --tar-mb 8
expect_error "--shard is for reefgen's layout" dataset build --count 2 --out "$T/e/x" --format webdataset --shard 0/2
expect_error "--tar-mb must be in" dataset build --count 2 --out "$T/e/x" --format webdataset --tar-mb 0
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/dw" --format webdataset >/dev/null || bad "dataset --format webdataset"
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/dw" --format pix2pix >/dev/null 2>"$T/err" && bad "a webdataset resumed as pix2pix" ||
  { grep -q "format" "$T/err" && ok || bad "no word on --format: $(cat "$T/err")"; }
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/dl1" >/dev/null 2>"$T/err" && bad "a --layers dataset resumed without --layers" ||
  { grep -q "layers differ" "$T/err" && ok || bad "no word on --layers: $(cat "$T/err")"; }
# Memory does not grow with --count (docs/DATASET.md): 1e8 pairs of 32 px,
# in reefgen's layout and as WebDataset shards of 1 MB; the peak resident
# size once the first files are out stays under 300 MB (a list of every
# index held 1.2 GB). Ctrl-C then ends the build with 130 and no manifest.
echo '{"count": 100000000, "size_px": 32}' > "$T/ds1e8.json"
for fmt in reefgen webdataset; do
  tar_mb=(); [ "$fmt" = webdataset ] && tar_mb=(--tar-mb 1)
  "$BIN" -q dataset build --config "$T/ds1e8.json" --out "$T/d1e8$fmt" --format "$fmt" "${tar_mb[@]}" --threads 2 >/dev/null 2>"$T/err1e8" &
  pid=$!
  for _ in $(seq 1 1200); do
    [ -n "$(find "$T/d1e8$fmt" \( -name '*.png' -o -name '*.tar' \) 2>/dev/null | head -1)" ] && break
    sleep 0.1
  done
  hwm=$(awk '/VmHWM/ {print $2}' "/proc/$pid/status" 2>/dev/null)
  kill -INT "$pid" 2>/dev/null; wait "$pid"; rc=$?
  [ -n "$hwm" ] && [ "$hwm" -lt 307200 ] && ok || bad "dataset --count 1e8 ($fmt): peak ${hwm:-?} kB (bar 300 MB) or no first file"
  [ "$rc" = 130 ] && [ ! -e "$T/d1e8$fmt/manifest.jsonl" ] && ok || bad "dataset --count 1e8 ($fmt) after Ctrl-C: exit $rc, $(ls "$T/d1e8$fmt")"
done
"$BIN" -q dataset stats "$T/d1" > "$T/stats.json" || bad "dataset stats"
grep -q '"pairs": 12' "$T/stats.json" && ok || bad "stats: pair count"
[ -s "$T/d1/contact_sheet.png" ] && ok || bad "stats: no contact sheet"
# Every shipped dataset config is valid (built at a tiny count and size).
for c in "$(dirname "$0")"/../configs/dataset/*.json; do
  sed -E 's/"count": [0-9]+/"count": 4/; s/"size_px": [0-9]+/"size_px": 32/' "$c" > "$T/c.json"
  "$BIN" -q dataset build --config "$T/c.json" --out "$T/cfg_$(basename "$c" .json)" >/dev/null 2>"$T/err" && ok || bad "config $c: $(cat "$T/err")"
done
echo '{"count": 0}' > "$T/bad_ds.json"
expect_error "count" dataset build --config "$T/bad_ds.json" --out "$T/e"
echo '{"cout": 5}' > "$T/bad_ds.json"
expect_error 'unknown key "cout"' dataset build --config "$T/bad_ds.json" --out "$T/e"

# 5. Training on the 12-pair dataset: a run killed by SIGINT and resumed ends
#    with the same generator, byte for byte, as an uninterrupted run.
TR="--data $T/d1 --ngf 4 --ndf 4 --depth 5 --epochs 4 --epochs-decay 4"
cat > "$T/tr.json" <<'JSON'
{"log_every": 5, "val_every": 20, "checkpoint_every": 1000, "val_samples": 2}
JSON
"$BIN" -q train --config "$T/tr.json" $TR --out "$T/t1" > "$T/out" || bad "train"
[ "$(cat "$T/out")" = "$T/t1/generator.pt" ] && ok || bad "train stdout: $(cat "$T/out")"
for f in run.json log.csv val.csv checkpoint.pt generator.pt; do [ -s "$T/t1/$f" ] || bad "train: no $f"; done
grep -q '"G": [0-9]' "$T/t1/run.json" && ok || bad "run.json has no parameter counts"
[ "$(head -1 "$T/t1/log.csv")" = "step,epoch,lr,G_GAN,G_L1,D_real,D_fake,s_per_iter,allreduce_s" ] && ok || bad "log.csv header"
ls "$T/t1/val/"step-*.png >/dev/null 2>&1 && ok || bad "no validation grid"
# Same run in another process: the same checkpoint, byte for byte (Adam's
# state is stored by parameter position, not by memory address).
"$BIN" -q train --config "$T/tr.json" $TR --out "$T/t1b" > /dev/null || bad "train again"
cmp -s "$T/t1/checkpoint.pt" "$T/t1b/checkpoint.pt" && ok || bad "two identical runs wrote different checkpoint.pt"
"$BIN" -q train --config "$T/tr.json" $TR --out "$T/t2" > /dev/null 2>&1 &
pid=$!
for _ in $(seq 1 200); do [ -s "$T/t2/log.csv" ] && [ "$(wc -l < "$T/t2/log.csv")" -ge 3 ] && break; sleep 0.05; done
kill -INT $pid; wait $pid; rc=$?
if [ "$rc" = 130 ]; then
  ok
  "$BIN" -q train $TR --out "$T/t2" --resume > /dev/null || bad "train --resume"
else
  bad "SIGINT: exit $rc, expected 130 (the run may have finished first)"
fi
cmp -s "$T/t1/generator.pt" "$T/t2/generator.pt" && ok || bad "interrupted + resumed run differs from the uninterrupted one"
diff <(cut -d, -f1-7 "$T/t1/log.csv") <(cut -d, -f1-7 "$T/t2/log.csv") >/dev/null && ok || bad "resumed log.csv differs"
expect_error "--resume" train $TR --out "$T/t1"
expect_error "dataset.json" train --data "$T/e" --out "$T/e/run"
echo '{"lr": -2}' > "$T/bad_tr.json"
expect_error "lr" train --config "$T/bad_tr.json" $TR --out "$T/e/run"
head -c 1000 "$T/t1/checkpoint.pt" > "$T/t3.pt"; mkdir -p "$T/t3"; cp "$T/t1/run.json" "$T/t3/"; mv "$T/t3.pt" "$T/t3/checkpoint.pt"
expect_error "truncated" train $TR --out "$T/t3" --resume
expect_error "no checkpoint.pt to resume" train $TR --out "$T/e/fresh" --resume
# A checkpoint with flipped bytes inside its tensors is refused (its SHA-256), not resumed from.
# The bytes flipped are in the middle of the largest tensor entry's data (the
# file's own middle may be zip padding, which no check covers and no loader reads).
mkdir -p "$T/t4"; cp "$T/t1/run.json" "$T/t1/checkpoint.pt" "$T/t4/"
mid=$("$PY" - "$T/t4/checkpoint.pt" <<'PY'
import struct, sys, zipfile
f = open(sys.argv[1], "rb")
i = max((i for i in zipfile.ZipFile(sys.argv[1]).infolist() if "/data/" in i.filename), key=lambda i: i.file_size)
f.seek(i.header_offset)
h = f.read(30)
name_len, extra_len = struct.unpack("<HH", h[26:30])
print(i.header_offset + 30 + name_len + extra_len + i.compress_size // 2)
PY
)
printf '\x5a\xa5' | dd of="$T/t4/checkpoint.pt" bs=1 seek="$mid" conv=notrunc 2>/dev/null
expect_error "fails its CRC-32 (damaged copy)" train $TR --out "$T/t4" --resume
# Re-zipped with valid CRCs but one weight changed: the SHA-256 of the contents still refuses it.
rezip() {  # rezip SRC DST: flip one bit of the first tensor entry, new zip (valid CRCs)
  "$PY" - "$1" "$2" <<'PY'
import sys, zipfile
zin, zout = zipfile.ZipFile(sys.argv[1]), zipfile.ZipFile(sys.argv[2], "w")
done = False
for i in zin.infolist():
    d = zin.read(i.filename)
    if not done and "/data/" in i.filename and len(d) >= 8:
        d, done = bytes([d[0] ^ 0x40]) + d[1:], True
    zi = zipfile.ZipInfo(i.filename, date_time=i.date_time)
    zi.compress_type = i.compress_type
    zout.writestr(zi, d)
zout.close()
PY
}
mkdir -p "$T/t5"; cp "$T/t1/run.json" "$T/t5/"; rezip "$T/t1/checkpoint.pt" "$T/t5/checkpoint.pt"
expect_error "SHA-256 does not match" train $TR --out "$T/t5" --resume
rezip "$T/t1/generator.pt" "$T/rezipped.pt"
expect_error "SHA-256 does not match" model info "$T/rezipped.pt"

# 6. Sketches -> inference with the model trained above; exports; eval.
M="$T/t1/generator.pt"
"$BIN" sketch random --seed 3 --size 48 -o "$T/s/one.png" >/dev/null || bad "sketch random"
"$BIN" sketch random --seed 4 --size 32 --islands 2 --count 3 -o "$T/s/many" >/dev/null || bad "sketch random --count"
[ "$(ls "$T/s/many" | wc -l)" = 3 ] && ok || bad "sketch --count 3: $(ls "$T/s/many")"
"$BIN" sketch random --seed 3 --size 48 -o "$T/s/again.png" >/dev/null; cmp -s "$T/s/one.png" "$T/s/again.png" && ok || bad "sketch not deterministic"
"$BIN" sketch --from wilbur --seed 2 --size 48 -o "$T/s/wilbur.png" >/dev/null && [ -s "$T/s/wilbur.png" ] && ok || bad "sketch --from wilbur"
"$BIN" generate --preset atoll --size 48 -o "$T/s/atoll" >/dev/null
"$BIN" sketch --from "$T/s/atoll.height.exr" --subsidence 0.5 -o "$T/s/atoll.png" >/dev/null && [ -s "$T/s/atoll.png" ] && ok || bad "sketch --from EXR"
expect_error "mapgen4, wilbur, noise" sketch --from mapgen9 -o "$T/e/x.png"
"$BIN" sketch --from mapgen4 --seed 2 --size 48 -o "$T/s/m4.png" >/dev/null && [ -s "$T/s/m4.png" ] && ok || bad "sketch --from mapgen4"
"$BIN" terrain mapgen4 --seed 2 --size 48 -o "$T/s/m4t" --preview >/dev/null && [ -s "$T/s/m4t.height.exr" ] && [ -s "$T/s/m4t.preview.png" ] && ok || bad "terrain mapgen4"
expect_error "mapgen4 or wilbur" terrain perlin -o "$T/e/x"
"$BIN" terrain wilbur --config "$(dirname "$0")/../configs/terrains/wilbur.json" --size 48 --seed 2 -o "$T/s/wc" >/dev/null && ok || bad "terrain --config"
echo '{"octavs": 3}' > "$T/bad_terrain.json"
expect_error "octavs" terrain wilbur --config "$T/bad_terrain.json" -o "$T/e/x"
"$BIN" sketch --from wilbur --config "$(dirname "$0")/../configs/terrains/wilbur-highlands.json" --size 48 -o "$T/s/hl.png" >/dev/null && [ -s "$T/s/hl.png" ] && ok || bad "sketch --from wilbur --config"
expect_error "octavs" sketch --from wilbur --config "$T/bad_terrain.json" -o "$T/e/x.png"
expect_error "applies to --from mapgen4 or wilbur" sketch --from noise --config "$T/bad_terrain.json" -o "$T/e/x.png"

# 5b. Floating islands: painting → closed GLB + OBJ + sidecar + preview; a
# height field's land; same seed, same bytes; the error paths.
PAINT="$(dirname "$0")/../docs/examples/floating-painting.png"
"$BIN" -q floating --painting "$PAINT" --seed 3 -o "$T/f/a.glb" -o "$T/f/a.obj" --preview "$T/f/a.png" > "$T/f.json" || bad "floating painting"
[ "$(head -c4 "$T/f/a.glb")" = "glTF" ] && [ -s "$T/f/a.png" ] && grep -q '^f ' "$T/f/a.obj" && ok || bad "floating: files"
grep -q '"closed_2_manifold": *true' "$T/f/a.json" && ok || bad "floating: sidecar"
iou=$(grep -o '"silhouette_iou":[0-9.]*' "$T/f.json" | cut -d: -f2)
awk -v v="$iou" 'BEGIN { exit !(v >= 0.95) }' && ok || bad "floating: silhouette IoU $iou < 0.95"
"$BIN" -q floating --painting "$PAINT" --seed 3 -o "$T/f/b.glb" >/dev/null && cmp -s "$T/f/a.glb" "$T/f/b.glb" && ok || bad "floating: not deterministic"
"$BIN" -q floating --painting "$PAINT" --seed 4 -o "$T/f/c.glb" >/dev/null && ! cmp -s "$T/f/a.glb" "$T/f/c.glb" && ok || bad "floating: seed has no effect"
for pr in $("$BIN" floating --presets); do
  "$BIN" -q floating --painting "$PAINT" --preset "$pr" -o "$T/f/$pr.glb" >/dev/null || bad "floating preset $pr"
done
[ "$("$BIN" floating --presets | wc -l)" -ge 4 ] && ok || bad "floating: fewer than 4 presets"
"$BIN" -q floating --height "$T/s/m4t.height.exr" -o "$T/f/m4.glb" >/dev/null && grep -q '"preset": *"terrain-top"' "$T/f/m4.json" && ok || bad "floating --height"
"$BIN" -q floating --painting "$PAINT" --height "$T/s/m4t.height.exr" -o "$T/f/pm.obj" >/dev/null && ok || bad "floating painting + height"
# --max-size shrinks the painting but keeps the island's size: the painted rock depth stays (81 m at 1 m/px).
"$BIN" -q floating --painting "$PAINT" --max-size 128 -o "$T/f/small.glb" > "$T/small.json" || bad "floating --max-size"
d=$(grep -o '"depth_m":[0-9.]*' "$T/small.json" | cut -d: -f2)
awk -v v="$d" 'BEGIN { exit !(v > 78 && v < 84) }' && ok || bad "floating --max-size: depth $d, expected ~81 m"
{ printf 'P6\n16 16\n255\n'; head -c 768 /dev/zero | tr '\0' '\377'; } > "$T/white.ppm"
expect_error "white.ppm: the top colour covers most of the image border" floating --painting "$T/white.ppm" -o "$T/e/x.glb"
expect_error "nope.png: no such file" floating --painting "$T/nope.png" -o "$T/e/x.glb"
expect_error "must end in .glb or .obj" floating --painting "$PAINT" -o "$T/e/x.stl"
expect_error "use one of default" floating --painting "$PAINT" --preset cliffy -o "$T/e/x.glb"
echo '{"alpha_top": 0.2, "rim": 3}' > "$T/bad_floating.json"
expect_error 'unknown key "rim"' floating --painting "$PAINT" --config "$T/bad_floating.json" -o "$T/e/x.glb"
expect_error "metres_per_px" floating --height "$T/s/m4t.height.exr" --metres-per-px 0 -o "$T/e/x.glb"
# The reef report and --ocean-floor-m (docs/REEF.md): the atoll preset's crest
# is awash on most rays, its lagoon a basin, its motu above the sea; the open
# ocean is stretched to the depth asked while the lagoon keeps its depth.
"$BIN" -q generate --preset atoll --size 257 -o "$T/reef/a" >/dev/null
"$BIN" -q generate --preset atoll --size 257 --ocean-floor-m -2000 -o "$T/reef/d" >/dev/null
"$BIN" realism --reef --json "$T/reef/a.height.exr" "$T/reef/d.height.exr" > "$T/reef/r.jsonl" \
  && OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$T/reef" <<'PYEOF' && ok || bad "realism --reef on the atoll, or --ocean-floor-m"
import cv2, json, sys, numpy as np
d = sys.argv[1]
a, b = [json.loads(l)["reef"] for l in open(d + "/r.jsonl")]
assert a["crest_at_sea"] >= 0.7 and a["motu"] >= 1 and a["passes"] >= 1, a
assert -60 <= a["lagoon_median_m"] <= a["crest_median_m"] - 5, a
assert a["flat_floor_share"] <= 0.02 and b["flat_floor_share"] <= 0.02, (a, b)
ha = cv2.imread(d + "/a.height.exr", cv2.IMREAD_UNCHANGED); hb = cv2.imread(d + "/d.height.exr", cv2.IMREAD_UNCHANGED)
assert ha.min() > -100 and abs(hb.min() + 2000) < 1e-3, (ha.min(), hb.min())
assert np.array_equal(ha[ha > -60], hb[ha > -60])  # above the knee nothing moves: lagoon, reef, motu
assert json.load(open(d + "/d.json"))["provenance"]["ocean_floor_m"] == -2000
PYEOF
expect_error "ocean-floor-m" generate --preset atoll --ocean-floor-m -20000 -o "$T/e/x"
# A subsided (dark) sketch through world keeps its abyss deep: the pass is
# padded with the sketch's own subsidence, not a bright frame (which made the
# network answer -47 m for the dark abyss where infer answers -88 m).
"$BIN" -q world "$T/reef/a.label.png" --raw -o "$T/reef/wraw" >/dev/null \
  && OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$T/reef/wraw.height.exr" <<'PYEOF' && ok || bad "world: a dark sketch's abyss is shallow"
import cv2, sys, numpy as np
h = cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED)
b = np.concatenate([h[:8].ravel(), h[-8:].ravel(), h[:, :8].ravel(), h[:, -8:].ravel()])
assert np.median(b) < -80, np.median(b)
PYEOF
# A world deepened as a whole: its lowest cell at the depth asked, nothing above the knee moved.
"$BIN" -q generate --preset young-volcano --size 257 -o "$T/reef/yv" >/dev/null
"$BIN" -q world "$T/reef/yv.label.png" --size 257 -o "$T/reef/wa" >/dev/null
"$BIN" -q world "$T/reef/yv.label.png" --size 257 --ocean-floor-m -2000 -o "$T/reef/wd" >/dev/null \
  && OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$T/reef" <<'PYEOF' && ok || bad "world --ocean-floor-m"
import cv2, json, sys, numpy as np
d = sys.argv[1]
ha = cv2.imread(d + "/wa.height.exr", cv2.IMREAD_UNCHANGED); hb = cv2.imread(d + "/wd.height.exr", cv2.IMREAD_UNCHANGED)
assert ha.min() >= -100 and abs(hb.min() + 2000) < 1e-3, (ha.min(), hb.min())
assert np.array_equal(ha[ha > -60], hb[ha > -60])
assert json.load(open(d + "/wd.json"))["ocean_floor_m"] == -2000
PYEOF
# A sunk reef without motu: all below 0 m (the atoll preset has motu now).
echo '{"subsidence": 0.95, "reef": {"random_motu": 0}}' > "$T/sunk.json"
"$BIN" -q generate --spec "$T/sunk.json" --size 64 -o "$T/p/sunk" >/dev/null
expect_error "no land" floating --height "$T/p/sunk.height.exr" -o "$T/e/x.glb"
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/one" --png16 --r16 --mesh glb --preview > "$T/out" || bad "infer"
for f in height.exr height.png r16 glb preview.png json; do [ -s "$T/i/one.$f" ] || bad "infer: no one.$f"; done
[ "$(stat -c %s "$T/i/one.r16")" = $((48*48*2)) ] && ok || bad "r16 size"
grep -q '"height_range_m"' "$T/i/one.json" && ok || bad "infer sidecar"
"$BIN" -q infer "$T/s/many" -m "$M" -o "$T/i/many" --mesh obj > "$T/out" 2>&1 || bad "infer folder: $(cat "$T/out")"
[ "$(ls "$T/i/many" | grep -c '\.obj$')" = 3 ] && ok || bad "infer folder: $(ls "$T/i/many")"
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/two" > /dev/null
cmp -s "$T/i/one.height.exr" "$T/i/two.height.exr" && ok || bad "infer not deterministic"
# --variations 3: the islands of seeds 4, 5, 6 and their contact sheet; seed 5 alone is the same bytes.
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/var" --seed 4 --variations 3 > "$T/out" || bad "infer --variations"
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/var5" --seed 5 > /dev/null
[ -s "$T/i/var.variations.png" ] && [ -s "$T/i/var.seed6.json" ] && grep -q "var.seed4.height.exr" "$T/out" \
  && cmp -s "$T/i/var.seed5.height.exr" "$T/i/var5.height.exr" && ok || bad "infer --variations: $(ls "$T/i" | grep var)"
expect_error "--variations takes one sketch" infer "$T/s/many" -m "$M" -o "$T/e/x" --variations 2
# (seeds vary the output of deeper models: test_infer.cpp; this depth-5 one has no dropout)
expect_error "no dropout layers" infer "$T/s/one.png" -m "$M" -o "$T/e/x" --stochastic
printf 'not an image' > "$T/s/bad.png"
expect_error "bad.png" infer "$T/s/bad.png" -m "$M" -o "$T/e/x"
expect_error "expected a file exported" infer "$T/s/one.png" -m "$T/t1/checkpoint.pt" -o "$T/e/x"
expect_error "missing.pt" infer "$T/s/one.png" -m "$T/missing.pt" -o "$T/e/x"
expect_error "one.png" infer "$T/s/one.png" -m "$M" -o "$T/s/one.png/sub/x"   # output under a file: unwritable
expect_error "nothere.png" infer "$T/nothere.png" -m "$M" -o "$T/e/x"
convert_grey() { printf 'P5\n8 8\n255\n'; head -c 64 /dev/zero | tr '\0' '\200'; }
convert_grey > "$T/s/grey.pgm"
expect_error "grey.pgm" infer "$T/s/grey.pgm" -m "$M" -o "$T/e/x"
mkdir -p "$T/s/mixed"; cp "$T/s/one.png" "$T/s/mixed/a.png"; convert_grey > "$T/s/mixed/b.png"
expect_error "b.png" infer "$T/s/mixed" -m "$M" -o "$T/e"   # a.png's results removed again
"$BIN" -q eval -m "$M" --data "$T/d1" --split train --max-pairs 3 --out "$T/ev1" > "$T/ev1.json" || bad "eval"
"$BIN" -q eval -m "$M" --data "$T/d1" --split train --max-pairs 3 --out "$T/ev2" > "$T/ev2.json" || bad "eval again"
# A NaN in a true height is refused, naming the file (not null metrics and exit 0).
cp -r "$T/d1" "$T/dnan"
first=$(sed -n 's/.*"height":"\([^"]*\)".*"split":"train".*/\1/p' "$T/dnan/manifest.jsonl" | head -1)
OPENCV_IO_ENABLE_OPENEXR=1 "$PY" -c "import cv2,sys,numpy as np; h=cv2.imread(sys.argv[1],cv2.IMREAD_UNCHANGED); h[3,3]=np.nan; cv2.imwrite(sys.argv[1],h)" "$T/dnan/$first"
expect_error "NaN or infinite" eval -m "$M" --data "$T/dnan" --split train --max-pairs 3 --no-verify
# Verified (the default), the edited pair is named before any inference.
expect_error "00000003.height.exr: its bytes differ" eval -m "$M" --data "$T/dnan" --split train --max-pairs 3
cmp -s "$T/ev1/eval.json" "$T/ev2/eval.json" && ok || bad "eval not reproducible"
for f in eval.json eval.md worst.png; do [ -s "$T/ev1/$f" ] || bad "eval: no $f"; done
grep -q '"jpeg_q50"' "$T/ev1/eval.json" && ok || bad "eval: no perturbed results"
# eval.md: the perturbations in their order, then region 0 by its one name.
[ "$(sed -n 3,7p "$T/ev1/eval.md" | cut -d'|' -f2 | tr -d ' ' | tr '\n' ' ')" = "clean blur_sigma2 jpeg_q50 hue_jitter_15deg brush_noise " ] && ok || bad "eval.md rows: $(cat "$T/ev1/eval.md")"
grep -q '^| island |' "$T/ev1/eval.md" && ok || bad "eval.md: no island row"
# Never overwrite an input; two sketches with one stem refused.
mkdir -p "$T/s/a" "$T/s/b"; cp "$T/s/one.png" "$T/s/a/x.png"; cp "$T/s/one.png" "$T/s/b/x.png"
expect_error "would both write" infer "$T/s/a" "$T/s/b" -m "$M" -o "$T/e"
cp "$T/s/one.png" "$T/s/y.preview.png"; before=$(sha256sum < "$T/s/y.preview.png")
"$BIN" -q infer "$T/s/y.preview.png" -m "$M" -o "$T/s/y" --preview >/dev/null 2>&1 && bad "infer overwrote its input" || ok
[ "$(sha256sum < "$T/s/y.preview.png")" = "$before" ] && [ ! -e "$T/s/y.height.exr" ] && ok || bad "input changed or outputs left"

# 6b. The shipped model (models/): no -m needed; it meets the painted-sketch
# land and abyss bars on tests/data/painted (docs/MODEL.md).
SHIPPED="$(dirname "$0")/../models/reef-256.pt"
if [ -f "$SHIPPED" ]; then
  "$BIN" -q model info > "$T/mi.json" && grep -q '"weights": "float16"' "$T/mi.json" && ok || bad "model info: $(cat "$T/mi.json")"
  "$BIN" -q infer "$(dirname "$0")/data/painted/01-young-volcano.png" -o "$T/i/shipped" --preview >/dev/null && [ -s "$T/i/shipped.height.exr" ] && ok || bad "infer with the shipped model"
  "$BIN" -q eval-sketches "$(dirname "$0")/data/painted" --out "$T/es" > "$T/es.json" || bad "eval-sketches"
  [ -s "$T/es/grid.png" ] && ok || bad "eval-sketches: no grid.png"
  "$PY" - "$T/es.json" <<'PY' && ok || bad "shipped model misses a painted-sketch bar: $(head -c 600 "$T/es.json")"
import json, sys
o = json.load(open(sys.argv[1]))["overall"]
assert o["young_land_above_0"] >= 0.97, o
assert o["young_abyss_below_minus20"] >= 0.97, o
# The 0.5 m was set on smooth cones; the eroded training targets
# themselves score 1.09 m mean (docs/MODEL.md §4), so the bar is that level.
assert o["checkerboard_m_mean"] <= 1.0, o
PY
  # bf16 inference of the shipped model stays within 1 m of fp32 (99th percentile; mean ≤ 0.25 m).
  [ "$HAS_BF16" = 1 ] || skip "bf16 vs fp32 on the shipped model: no bf16 convolutions on this CPU (needs AVX-512)"
  [ "$HAS_BF16" = 1 ] && for s in 01-young-volcano 06-long-arc 12-atoll-dark; do
    "$BIN" -q infer "$(dirname "$0")/data/painted/$s.png" -o "$T/i/p32-$s" --precision fp32 --raw >/dev/null || bad "infer fp32"
    "$BIN" -q infer "$(dirname "$0")/data/painted/$s.png" -o "$T/i/pbf-$s" --precision bf16 --raw >/dev/null || bad "infer bf16"
    OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$T/i/p32-$s.height.exr" "$T/i/pbf-$s.height.exr" <<'PY' && ok || bad "bf16 vs fp32 on $s"
import sys, cv2, numpy as np
a, b = (cv2.imread(f, cv2.IMREAD_UNCHANGED) for f in sys.argv[1:3])
d = np.abs(a - b)
assert d.mean() <= 0.25 and np.percentile(d, 99) <= 1.0 and d.max() > 0, (d.mean(), np.percentile(d, 99), d.max())
PY
  done
  cp "$SHIPPED" "$T/corrupt.pt"; printf '\x55' | dd of="$T/corrupt.pt" bs=1 seek=9000000 conv=notrunc 2>/dev/null
  expect_error "fails its CRC-32 (damaged copy)" infer "$T/s/one.png" -m "$T/corrupt.pt" -o "$T/e/x"
else
  bad "models/reef-256.pt missing"
fi

# 6c. More of the probes: outputs never replace inputs, names honoured,
# bounded threads, one-line errors with the command named.
"$BIN" generate --preset atoll --size 48 -o "$T/s/h" >/dev/null
expect_error "also an input" sketch --from "$T/s/h.height.exr" -o "$T/s/h.height.exr"
expect_error "name the output \*.png" sketch --from "$T/s/h.height.exr" -o "$T/e/x.exr"
expect_error "name the output \*.png" sketch random --seed 1 -o "$T/e/x.jpg"
cp "$PAINT" "$T/s/paint.png"
expect_error "also an input" floating --painting "$T/s/paint.png" -o "$T/e/f.glb" --preview "$T/s/paint.png"
expect_error "named twice" floating --painting "$T/s/paint.png" -o "$T/e/f.glb" --preview "$T/e/f.json"
cp "$(dirname "$0")/../configs/presets/atoll.json" "$T/s/island.json"
expect_error "also an input" generate --spec "$T/s/island.json" -o "$T/s/island"
expect_error "not in range 1 to 256" infer "$T/s/one.png" -m "$M" -o "$T/e/x" --threads 100000
expect_error "not in range 1 to 256" infer "$T/s/one.png" -m "$M" -o "$T/e/x" --threads 0
expect_error "did you mean 'infer'" infr "$T/s/one.png"
expect_error "must be a finite number" generate --preset atoll --subsidence nan -o "$T/e/x"
expect_error "must be a finite number" infer "$T/s/one.png" -m "$M" -o "$T/e/x" --world-size inf
expect_error "bf16 on the torch engine needs a resize-convolution generator" infer "$T/s/one.png" -m "$M" -o "$T/e/x" --precision bf16 --engine torch
expect_error "engine 'gpu'" infer "$T/s/one.png" -m "$M" -o "$T/e/x" --engine gpu
# --erosion: the amplification's params from a file; bad keys and values named, a real change of the output.
echo '{"amplify_rough": 0.5}' > "$T/bad_er.json"
echo '{"amplify_roughness": 3}' > "$T/range_er.json"
expect_error 'bad_er.json: unknown key "erosion.amplify_rough"' infer "$T/s/one.png" -m "$M" -o "$T/e/x" --size 300 --erosion "$T/bad_er.json"
expect_error "range_er.json" infer "$T/s/one.png" -m "$M" -o "$T/e/x" --size 300 --erosion "$T/range_er.json"
expect_error "missing_er.json" infer "$T/s/one.png" -m "$M" -o "$T/e/x" --size 300 --erosion "$T/missing_er.json"
echo '{"amplify_roughness": 0}' > "$T/smooth_er.json"
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/er0" --size 300 >/dev/null || bad "infer --size 300"
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/er1" --size 300 --erosion "$T/smooth_er.json" >/dev/null || bad "infer --erosion"
cmp -s "$T/i/er0.height.exr" "$T/i/er1.height.exr" && bad "--erosion changed nothing" || ok
# reefgen's engine runs pix2pix's transposed generator in bf16 too, and records what ran.
if [ "$HAS_BF16" = 1 ]; then
  "$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/tbf" --precision bf16 >/dev/null \
    && "$PY" -c "import json,sys; m=json.load(open(sys.argv[1]))['mode']; assert m['engine']=='onednn' and m['precision']=='bf16', m" "$T/i/tbf.json" \
    && ok || bad "bf16 on a transposed generator with the onednn engine"
else
  skip "bf16 on a transposed generator: no bf16 convolutions on this CPU (needs AVX-512)"
  expect_error "cannot build a bf16 convolution on this CPU" infer "$T/s/one.png" -m "$M" -o "$T/e/x" --precision bf16
fi
# With the CPU's bf16 hidden (any machine): auto runs float32, an explicit bf16 is one line, nothing written.
REEFGEN_NO_BF16=1 "$BIN" -q model cpu | "$PY" -c 'import json,sys; d=json.load(sys.stdin); assert not d["bf16_convolutions"] and d["auto_precision"]=="fp32" and "bf16" not in d["class"], d' \
  && ok || bad "REEFGEN_NO_BF16 does not hide bf16"
REEFGEN_NO_BF16=1 "$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/nobf" >/dev/null \
  && "$PY" -c "import json,sys; m=json.load(open(sys.argv[1]))['mode']; assert m['precision']=='fp32', m" "$T/i/nobf.json" \
  && ok || bad "auto precision with bf16 hidden"
REEFGEN_NO_BF16=1 expect_error "cannot build a bf16 convolution on this CPU" infer "$T/s/one.png" -m "$M" -o "$T/e/nobf" --precision bf16
[ ! -e "$T/e/nobf.height.exr" ] && ok || bad "a refused bf16 run wrote a file"
# The Winograd decoder's GEMM backend (model cpu names it): forced by name on any CPU, an unknown name is one line.
[ "$(REEFGEN_WINOGRAD_GEMM=sgemm "$BIN" -q model cpu | "$PY" -c 'import json,sys; print(json.load(sys.stdin)["winograd_gemm"])')" = sgemm ] \
  && ok || bad "REEFGEN_WINOGRAD_GEMM=sgemm not honoured"
REEFGEN_WINOGRAD_GEMM=blas expect_error "REEFGEN_WINOGRAD_GEMM='blas'" infer "$T/s/one.png" -m "$M" -o "$T/e/wg"
[ ! -e "$T/e/wg.height.exr" ] && ok || bad "a refused Winograd backend wrote a file"
# --raw: the network's bare answer; the default is cleaned (ponds raised, pits breached) at the model's side too.
"$BIN" -q infer "$(dirname "$0")/data/painted/01-young-volcano.png" -o "$T/i/raw" --raw >/dev/null \
  && "$BIN" -q infer "$(dirname "$0")/data/painted/01-young-volcano.png" -o "$T/i/clean" >/dev/null \
  && ! cmp -s "$T/i/raw.height.exr" "$T/i/clean.height.exr" && ok || bad "--raw gives the same file as the default"
# At the model's own side: above it the amplification's erosion routes water
# by strict comparisons, so a 1e-5 m difference can move a channel.
MS=$("$BIN" -q model info "$M" | "$PY" -c "import json,sys; print(json.load(sys.stdin)['size_px'])")
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/tt" --engine torch --size "$MS" --raw >/dev/null && "$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/to" --engine onednn --size "$MS" --raw >/dev/null \
  && OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$T/i/tt.height.exr" "$T/i/to.height.exr" <<'PY' && ok || bad "onednn vs torch engine"
import sys, cv2, numpy as np
a, b = (cv2.imread(f, cv2.IMREAD_UNCHANGED) for f in sys.argv[1:3])
assert np.abs(a - b).max() <= 0.01, np.abs(a - b).max()
PY

# 6d. A failed re-run leaves every earlier file exactly as it was, and no
# temporary files: outputs are staged and renamed in at the end.
snap() { (cd "$1" && find . -type f | sort | xargs -r md5sum); }
keeps() {  # keeps DIR LABEL ARGS...: the run must fail and DIR must not change
  local dir="$1" label="$2"; shift 2
  snap "$dir" > "$T/before"
  if "$BIN" -q "$@" >/dev/null 2>"$T/err"; then bad "$label: no error"; return; fi
  snap "$dir" > "$T/after"
  cmp -s "$T/before" "$T/after" && ok || bad "$label: earlier files changed: $(diff "$T/before" "$T/after" | head -5)"
  [ -z "$(find "$dir" -name '*.tmp.*')" ] && ok || bad "$label: temporary files left: $(find "$dir" -name '*.tmp.*')"
}
mkdir -p "$T/k"
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/k/x" --preview >/dev/null || bad "keep: first infer"
keeps "$T/k" "infer with a mesh in a missing folder" infer "$T/s/again.png" -m "$M" -o "$T/k/x" --preview --mesh "$T/nonexistent/x.glb"
mkdir -p "$T/k/x.r16"  # an output name taken by a folder
keeps "$T/k" "infer with an output that is a folder" infer "$T/s/again.png" -m "$M" -o "$T/k/x" --preview --r16
grep -q "x.r16: it is a folder" "$T/err" && ok || bad "folder output: message $(cat "$T/err")"
mkdir -p "$T/k/many"; for i in $(seq -w 1 33); do cp "$T/s/one.png" "$T/k/many/s$i.png"; done
"$BIN" -q infer "$T/k/many" -m "$M" -o "$T/k/out" >/dev/null || bad "keep: infer folder"
printf 'not a png' > "$T/k/many/zz-bad.png"  # after the first chunk of 32
keeps "$T/k/out" "infer folder with a bad sketch after the first chunk" infer "$T/k/many" -m "$M" -o "$T/k/out"
"$BIN" -q generate --preset young-volcano --size 48 -o "$T/k/g" >/dev/null || bad "keep: generate"
mkdir -p "$T/k/g.preview.png"
keeps "$T/k" "generate with a folder where the preview goes" generate --preset atoll --size 48 -o "$T/k/g" --preview
"$BIN" -q floating --painting "$PAINT" --seed 3 -o "$T/k/f.glb" >/dev/null || bad "keep: floating"
mkdir -p "$T/k/f.obj"
keeps "$T/k" "floating with an output that is a folder" floating --painting "$PAINT" --seed 5 -o "$T/k/f.glb" -o "$T/k/f.obj"
"$BIN" -q terrain wilbur --size 64 -o "$T/k/w" >/dev/null || bad "keep: terrain"
mkdir -p "$T/k/w.glb"
keeps "$T/k" "terrain with a mesh name taken by a folder" terrain wilbur --size 64 --seed 9 -o "$T/k/w" --preview --mesh glb

# 6e. Integers must be integers in range, named otherwise (no silent coercion).
echo '{"noise": {"seed": -1}}' > "$T/neg.json"; echo '{"noise": {"seed": 1e30}}' > "$T/huge.json"
echo '{"noise": {"octaves": 2.7}}' > "$T/frac.json"; echo '{"count": 2.7, "size_px": 32}' > "$T/dsfrac.json"
echo '{"batch_size": 2.5}' > "$T/trfrac.json"
expect_error "noise.seed = -1 must not be negative" generate --spec "$T/neg.json" -o "$T/e/x"
expect_error "noise.seed = 1e+30 is out of range" generate --spec "$T/huge.json" -o "$T/e/x"
expect_error "noise.octaves = 2.7 must be a whole number" generate --spec "$T/frac.json" -o "$T/e/x"
expect_error "count = 2.7 must be a whole number" dataset build --config "$T/dsfrac.json" --out "$T/e/d"
expect_error "batch_size = 2.5 must be a whole number" train --config "$T/trfrac.json" --data "$T/e" --out "$T/e/r"
expect_error "needs engine = 'onednn'" train --data "$T/e" --out "$T/e/r" --engine torch --precision bf16
expect_error "not in {fp32,bf16,auto}" train --data "$T/e" --out "$T/e/r" --precision fp16
echo '{"depth_m": 1e308}' > "$T/m4deep.json"
expect_error "m4deep.json: depth_m = 1e+308 is out of range; expected (0, 10000]" terrain mapgen4 --config "$T/m4deep.json" -o "$T/e/x"
# A 30000² PNG (its header is enough) is refused before anything is decoded.
"$PY" - "$T/huge.png" <<'PY'
import struct, sys, zlib
ihdr = struct.pack(">IIBBBBB", 30000, 30000, 8, 2, 0, 0, 0)
chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
open(sys.argv[1], "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b""))
PY
expect_error "30000×30000 pixels; sketches may be at most 8192" infer "$T/huge.png" -m "$M" -o "$T/e/x"

# 6f. clig.dev conventions: global flags anywhere, option aliases.
"$BIN" generate --preset atoll --size 32 -o "$T/g/qa" --preview -q 2>"$T/err" >/dev/null && [ ! -s "$T/err" ] && ok || bad "-q after the command: $(cat "$T/err")"
"$BIN" --threads 1 generate --random 1 --levels 1 --size 32 --out "$T/g/thr" -q >/dev/null && ok || bad "--threads before the command"
"$BIN" --threads 2 presets >/dev/null && ok || bad "--threads before a command without threads"
"$BIN" presets --threads 2 >/dev/null && ok || bad "--threads after a command without threads"
expect_error "not in range 1 to 256" presets --threads 0
"$BIN" -q generate --config docs/examples/spec.json --size 32 --output "$T/g/alias" >/dev/null 2>&1 \
  || "$BIN" -q generate --config "$(dirname "$0")/../docs/examples/spec.json" --size 32 --output "$T/g/alias" >/dev/null
[ -s "$T/g/alias.height.exr" ] && ok || bad "--config / --output aliases of generate"
"$BIN" -q infer "$T/s/one.png" -m "$M" --out "$T/i/alias" >/dev/null && [ -s "$T/i/alias.height.exr" ] && ok || bad "--out alias of infer"

# -o with an extension is honoured; floating's --preview works as a switch too.
"$BIN" -q generate --preset atoll --size 32 -o "$T/g/named.exr" --preview >/dev/null \
  && [ -s "$T/g/named.exr" ] && [ -s "$T/g/named.label.png" ] && grep -q '"height": "named.exr"' "$T/g/named.json" && ok || bad "generate -o NAME.exr"
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/i/named.height.exr" --preview >/dev/null \
  && [ -s "$T/i/named.height.exr" ] && [ -s "$T/i/named.preview.png" ] && [ -s "$T/i/named.json" ] && ok || bad "infer -o NAME.height.exr"
"$BIN" -q floating --painting "$PAINT" --seed 3 -o "$T/f/sw.glb" --preview >/dev/null && [ -s "$T/f/sw.preview.png" ] && ok || bad "floating --preview as a switch"

# 6c. bench dataset prints its figure as JSON and leaves no build folder behind.
out=$(TMPDIR="$T/bt" bash -c 'mkdir -p "$TMPDIR" && "$0" -q bench dataset --count 6 --reps 2 --threads 1' "$BIN" 2>"$T/err")
echo "$out" | "$PY" -c 'import json,sys; d=json.load(sys.stdin); assert d["bench"]=="dataset" and len(d["pairs_per_s"])==2 and d["median_pairs_per_s"]>0 and d["p_erosion"]==1' \
  && [ -z "$(ls -A "$T/bt")" ] && ok || bad "bench dataset: $out $(cat "$T/err") left: $(ls "$T/bt")"

# 6d. Long output names: every final name fits 255 bytes (the temporary's
# longer suffix is cut short); one byte-count line when a name cannot fit.
L240=$(printf 'n%.0s' $(seq 1 240))
"$BIN" -q generate --preset atoll --size 32 -o "$T/ln/$L240" >/dev/null 2>"$T/err" && [ "$(ls "$T/ln" | wc -l)" = 3 ] \
  && ok || bad "a 240-byte prefix whose names all fit: $(head -c 300 "$T/err")"
L250=$(printf 'n%.0s' $(seq 1 250))
expect_error "bytes, the filesystem allows 255" generate --preset atoll --size 32 -o "$T/e/$L250"

# 6e. Engine bundles (docs/ENGINES.md), each in PREFIX.<engine>/ with its
# README: Unity's RAW at 2^n+1 (257), Unreal's nearest Landscape size (505)
# with eight weight layers, Terrain3D's maps filling whole regions, Blender's
# GLB and script, GDAL reading the gis one in metres.
if "$BIN" -q generate --preset atoll --size 257 -o "$T/eb/atoll" --for unity,unreal --for godot,blender,gis >/dev/null 2>"$T/err"; then
  for e in unity unreal godot blender gis; do [ -s "$T/eb/atoll.$e/README.txt" ] && ok || bad "bundle $e has no README.txt"; done
  "$PY" -c "import cv2,sys; m=cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED); assert m.shape==(512,512,4), m.shape" \
    "$T/eb/atoll.godot/atoll.color.png" && [ -s "$T/eb/atoll.godot/atoll.control.exr" ] && ok || bad "godot: maps not 512² (two 256 regions)"
  [ -s "$T/eb/atoll.blender/atoll.glb" ] && grep -q "use_clamp = False" "$T/eb/atoll.blender/atoll.displace.py" && ok || bad "blender: no GLB or an unclamped recipe"
  [ "$(stat -c %s "$T/eb/atoll.unity/atoll.raw")" = $((257 * 257 * 2)) ] && ok || bad "unity RAW is not 257²·2 bytes"
  [ "$(ls "$T/eb/atoll.unreal/"atoll_*.png | wc -l)" = 8 ] && ok || bad "unreal: not eight weight layers"
  "$PY" -c "import cv2,sys; m=cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED); assert m.shape==(505,505) and m.dtype.name=='uint16', m.shape" \
    "$T/eb/atoll.unreal/atoll.png" && ok || bad "unreal heightmap is not 505² 16-bit"
  if command -v gdalinfo >/dev/null; then
    gdalinfo "$T/eb/atoll.gis/atoll.height.tif" | grep -q "Pixel Size = (23.34" && ok || bad "gis bundle: pixel size not in metres"
  else skip "gdalinfo missing: the gis bundle is not opened with GDAL"; fi
  "$PY" -c "import json,sys; b=json.load(open(sys.argv[1]))['bundles']; assert set(b)=={'unity','unreal','godot','blender','gis'} and b['unreal']['side_px']==505, b.keys()" \
    "$T/eb/atoll.json" && ok || bad "the sidecar does not list the bundles"
else bad "generate --for: $(cat "$T/err")"; fi
"$BIN" generate --preset atoll --size 300 -o "$T/eb/odd" --for unity 2>&1 >/dev/null | grep -q "note: --for unity: 300² resampled to 257²" \
  && ok || bad "no note that --for unity resampled 300² to 257²"
expect_error "--for cryengine: use unity, unreal, godot, blender or gis" generate --preset atoll --size 64 -o "$T/e/x" --for cryengine
expect_error "--for: one island at a time" generate --random 1 --size 64 --out "$T/e" --for unity

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
expect_error "--for blender: a world past 8192² is written in tiles" world "$T/w/big.png" --size 9000 --for blender -o "$T/e/x"
# Past 8192² the layers come in tiles on the GeoTIFF grid, with the world's
# scales in the sidecar and a VRT mosaic per float layer that GDAL opens.
if "$BIN" -q world "$T/w/sea.png" --size 8200 --layers --geotiff -o "$T/w/wide" >/dev/null 2>"$T/err"; then
  "$PY" - "$T/w/wide.json" "$T/w/wide.layers" <<'PYEOF' && ok || bad "world --size 8200 --layers: tiles, scales or splats wrong"
import cv2, json, sys, os
j = json.load(open(sys.argv[1])); L = j["layers"]
assert j["size_px"] == [8200, 5467], j["size_px"]
assert L["tiles_per_axis"] == [3, 2] and len(L["layer_tiles"]) == 6, L["tiles_per_axis"]
assert L["scales"]["flow_area_m2"] > 1e5 and L["scales"]["wear_m"] > 0, L["scales"]
t = L["layer_tiles"][1]["files"]
a = cv2.imread(os.path.join(sys.argv[2], t["splat0"]), cv2.IMREAD_UNCHANGED).astype(int)
b = cv2.imread(os.path.join(sys.argv[2], t["splat1"]), cv2.IMREAD_UNCHANGED).astype(int)
assert a.shape == (2734, 2734, 4) and ((a.sum(2) + b.sum(2)) == 255).all()
PYEOF
  gdalinfo "$T/w/wide.layers/wide.flow.vrt" | grep -q "Size is 8200, 5467" && ok || bad "world layers: the flow VRT is not the whole world"
else bad "world --size 8200 --layers: $(cat "$T/err")"; fi
# A scale the pass cannot take is refused from the numbers, in one line
# naming the fix that works, and leaves no PREFIX.partial behind.
expect_error "a smaller --metres-per-px or --world-size" world "$T/w/big.png" --world-size 1e8 -o "$T/e/x"
expect_error "say the same thing" world "$T/w/big.png" --world-size 9000 --metres-per-px 20 -o "$T/e/x"
[ ! -e "$T/w/x.height.exr" ] && ok || bad "a failed world wrote its output"

# 7. --version, --help with examples.
"$BIN" --version | grep -q "reefgen [0-9]" && ok || bad "--version"
"$BIN" generate --help | grep -q "Examples" && ok || bad "generate --help has no examples"

echo "$pass passed, $fail failed, $skipped skipped"
[ "$fail" = 0 ]
