#!/usr/bin/env bash
# End-to-end checks of the reefgen binary, part 1: the generator's commands
# (presets, vector paths, threads, layers, erode and GIS, errors, datasets)
# and --help. Part 2 (train, infer, floating islands, probes, bundles):
# cli_infer_test.sh; part 3 (worlds): cli_world_test.sh.
source "$(dirname "$0")/cli_lib.sh"

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
# The rain the erosion read (docs/LAYERS.md "Rain"): with wind, PREFIX.rain.exr
# in mm/yr, named in the sidecar, wetter on land than the sea upwind's
# background somewhere and never below the floor; without wind, no file.
[ ! -e "$T/lay/yv.rain.exr" ] && ok || bad "rain layer without wind"
"$BIN" -q generate --preset windswept --size 96 --layers -o "$T/lay/ws" >/dev/null || bad "generate windswept --layers"
OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$T/lay/ws" <<'PYEOF' && ok || bad "rain layer"
import cv2, json, sys
p = sys.argv[1]
j = json.load(open(p + ".json"))
assert j["files"]["rain"] == "ws.rain.exr", j["files"]
r = cv2.imread(p + ".rain.exr", cv2.IMREAD_UNCHANGED)
h = cv2.imread(p + ".height.exr", cv2.IMREAD_UNCHANGED)
rain = j["spec"]["rain"]
assert r.shape == h.shape and r.dtype.name == "float32", (r.shape, r.dtype)
assert r.min() >= rain["floor_share"] * rain["background_mm_yr"] - 1e-3, r.min()
assert r[h > 0].max() > rain["background_mm_yr"] * 1.05, r[h > 0].max()
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
# --ocean-floor-m on a heightmap of yours: the flank continued by its
# distance from the land (docs/REEF.md), never below the floor, recorded.
"$BIN" -q erode "$T/er/w.height.exr" -o "$T/er/deep" --ocean-floor-m -1500 >/dev/null 2>"$T/err" || bad "erode --ocean-floor-m: $(cat "$T/err")"
OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$T/er" <<'PYEOF' && ok || bad "erode --ocean-floor-m"
import cv2, json, sys
d = sys.argv[1]
a, b = (cv2.imread(d + f, cv2.IMREAD_UNCHANGED) for f in ("/we.height.exr", "/deep.height.exr"))
assert -1500 <= b.min() < a.min() - 200, (a.min(), b.min())
assert json.load(open(d + "/deep.json"))["ocean_floor_m"] == -1500
PYEOF
# The drainage report's valley depth, and with a wind the windward side's
# against the lee's: the two bearings see the same halves swapped.
for b in 90 270; do "$BIN" realism --json --drainage --wind-from $b "$T/er/we.height.exr" > "$T/er/d$b.json" || bad "realism --wind-from $b"; done
"$PY" - "$T/er" <<'PYEOF' && ok || bad "realism --drainage --wind-from"
import json, sys
e, w = (json.load(open(sys.argv[1] + "/d%d.json" % b))["drainage"] for b in (90, 270))
assert e["valley_depth_p90_m"] > 0 and e["valley_depth_p90_m"] == w["valley_depth_p90_m"], (e, w)
assert e["windward_depth_ratio"] > 0 and abs(e["windward_depth_ratio"] * w["windward_depth_ratio"] - 1) < 0.1, (e, w)
PYEOF
"$BIN" realism --drainage --wind-from 400 "$T/er/we.height.exr" >/dev/null 2>&1 && bad "realism --wind-from 400 accepted" || ok
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
# erode --wind-from: rain from that bearing erodes the island (not as calm),
# the rain layer with --layers, and a wind from the west against one from
# the east wets opposite halves (the rain's sign of west minus east flips).
[ ! -e "$T/er/we.rain.exr" ] && ok || bad "erode: a rain layer without wind"
"$BIN" -q erode "$T/er/w.height.exr" -o "$T/er/west" --wind-from 270 --layers >/dev/null 2>"$T/err" || bad "erode --wind-from: $(cat "$T/err")"
"$BIN" -q erode "$T/er/w.height.exr" -o "$T/er/east" --wind-from 90 --layers >/dev/null 2>"$T/err" || bad "erode --wind-from 90: $(cat "$T/err")"
OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$T/er" <<'PYEOF' && ok || bad "erode --wind-from: rain or heights"
import cv2, json, sys
d = sys.argv[1]
calm, west, east = (cv2.imread(f"{d}/{n}.height.exr", cv2.IMREAD_UNCHANGED) for n in ("we", "west", "east"))
assert abs(west - calm).max() > 0.01 and abs(east - calm).max() > 0.01, "the wind changed nothing"
rw, re_ = (cv2.imread(f"{d}/{n}.rain.exr", cv2.IMREAD_UNCHANGED) for n in ("west", "east"))
land = calm > 0
half = land.shape[1] // 2
def lean(r):  # mean rain on the western land half minus the eastern
    return r[:, :half][land[:, :half]].mean() - r[:, half:][land[:, half:]].mean()
assert lean(rw) * lean(re_) < 0, (lean(rw), lean(re_))
assert json.load(open(f"{d}/west.json"))["wind_from_deg"] == 270
assert json.load(open(f"{d}/west.json"))["files"]["rain"] == "west.rain.exr"
PYEOF
# The rain file is an output like the others: never written over an input.
cp "$T/er/west.rain.exr" "$T/er/in.rain.exr"
"$BIN" -q erode "$T/er/in.rain.exr" -o "$T/er/in" --wind-from 60 --layers --metres-per-px 20 >/dev/null 2>"$T/err" && bad "erode over its rain input accepted" || \
  { grep -q "also an input" "$T/err" && cmp -s "$T/er/west.rain.exr" "$T/er/in.rain.exr" && ok || bad "erode over its rain input: $(cat "$T/err")"; }
"$BIN" -q erode "$T/er/w.height.exr" -o "$T/er/x" --wind-from 361 >/dev/null 2>"$T/err" && bad "--wind-from 361 accepted" || \
  { grep -q "wind-from" "$T/err" && ok || bad "--wind-from 361: $(cat "$T/err")"; }
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
# pix2pix's own reader (PIL, convert("RGB") keeps each channel's high byte):
# the 8-bit decode documented in dataset.json and docs/DATASET.md lands
# within 1.3 m of the 16-bit heights (half a 2.58 m step, plus the 1 cm grain).
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/dp" --format pix2pix >/dev/null || bad "dataset --format pix2pix"
"$PY" - "$T/dp" <<'PY' && ok || bad "pix2pix: the documented 8-bit decode is off by more than 1.3 m"
import cv2, glob, json, sys
import numpy as np
from PIL import Image
d = json.load(open(sys.argv[1] + "/dataset.json"))
lay = d
r = lay["range"]; lo, hi = r["floor_m"], r["peak_m"]
assert "256 * B8 + 127.5" in lay["heights"], lay["heights"]
worst = 0
for f in sorted(glob.glob(sys.argv[1] + "/*/*.png"))[:6]:
    b16 = cv2.imread(f, cv2.IMREAD_UNCHANGED)[:, :, 0].astype(np.float64)
    w = b16.shape[1] // 2
    m16 = lo + b16[:, w:] / 65535 * (hi - lo)
    b8 = np.asarray(Image.open(f).convert("RGB"))[:, w:, 0].astype(np.float64)
    m8 = lo + (256 * b8 + 127.5) / 65535 * (hi - lo)
    worst = max(worst, np.abs(m8 - m16).max())
assert 0 < worst <= 1.3, worst
PY
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


# 7. --version, --help with examples.
"$BIN" --version | grep -q "reefgen [0-9]" && ok || bad "--version"
"$BIN" generate --help | grep -q "Examples" && ok || bad "generate --help has no examples"

finish
