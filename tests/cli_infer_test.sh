#!/usr/bin/env bash
# End-to-end checks, part 2: a tiny model trained (interrupted and resumed),
# inference with it and with the shipped model, exports, eval, floating
# islands, the probes' output rules and the engine bundles.
source "$(dirname "$0")/cli_lib.sh"

# The 12-pair dataset the tiny model trains on (part 1 checks its builds).
cat > "$T/ds.json" <<'JSON'
{"count": 12, "size_px": 32, "levels": 3, "val_fraction": 0.2, "test_fraction": 0.2,
 "p_affine": 0.5, "p_translate": 0.5, "p_paste": 0.5, "paste_scale": 0.5}
JSON
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/d1" --threads 1 >/dev/null || bad "dataset t1"

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
expect_error "finite" generate --preset atoll --ocean-floor-m nan -o "$T/e/x"
expect_error "finite" world "$(dirname "$0")/data/painted/01-young-volcano.png" --ocean-floor-m nan -o "$T/e/x"
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

finish
