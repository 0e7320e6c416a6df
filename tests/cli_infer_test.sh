#!/usr/bin/env bash
# End-to-end checks, part 2: training (interrupted and resumed), inference
# with the tiny model, exports, eval and floating islands. Part 2b
# (cli_infer_models_test.sh): the shipped model, the probes' output rules and
# the engine bundles.
source "$(dirname "$0")/cli_lib.sh"
source "$(dirname "$0")/cli_tiny_args.sh"
tiny_model  # $T/d1, $T/t1: ctest's tiny_model fixture, or trained here

# 5. Training on the 12-pair dataset: a run killed by SIGINT and resumed ends
#    with the same generator, byte for byte, as an uninterrupted run.
#    The fixture's run is $T/t1; the same flags again here are $T/t1b.
TR="--data $T/d1 $TINY_TRAIN"
for f in run.json log.csv val.csv checkpoint.pt generator.pt; do [ -s "$T/t1/$f" ] || bad "train: no $f"; done
grep -q '"G": [0-9]' "$T/t1/run.json" && ok || bad "run.json has no parameter counts"
[ "$(head -1 "$T/t1/log.csv")" = "step,epoch,lr,G_GAN,G_L1,D_real,D_fake,s_per_iter,allreduce_s" ] && ok || bad "log.csv header"
ls "$T/t1/val/"step-*.png >/dev/null 2>&1 && ok || bad "no validation grid"
# Same run in another process: the same checkpoint, byte for byte (Adam's
# state is stored by parameter position, not by memory address).
"$BIN" -q train --config "$T/tr.json" $TR --out "$T/t1b" > "$T/out" || bad "train again"
[ "$(cat "$T/out")" = "$T/t1b/generator.pt" ] && ok || bad "train stdout: $(cat "$T/out")"
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
# ocean sinks with its distance from the reef (kilometres deep at the 6 km
# canvas's corners, no step steeper than 5 m per metre there) while the
# lagoon keeps its depth.
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
assert ha.min() > -100 and -2000 <= hb.min() < -800, (ha.min(), hb.min())
assert np.array_equal(ha[ha > -60], hb[ha > -60])  # above the knee nothing moves: lagoon, reef, motu
mpp = 6000 / 257
ocean = ha < -60
for dy, dx in ((0, 1), (1, 0)):
    a, b = hb[:hb.shape[0] - dy, :hb.shape[1] - dx], hb[dy:, dx:]
    m = ocean[:hb.shape[0] - dy, :hb.shape[1] - dx] & ocean[dy:, dx:]
    assert np.abs(a - b)[m].max() / mpp <= 5, np.abs(a - b)[m].max() / mpp
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
# A world deepened as a whole: its flank kilometres deep, nothing above the knee moved.
"$BIN" -q generate --preset young-volcano --size 257 -o "$T/reef/yv" >/dev/null
"$BIN" -q world "$T/reef/yv.label.png" --size 257 -o "$T/reef/wa" >/dev/null
"$BIN" -q world "$T/reef/yv.label.png" --size 257 --ocean-floor-m -2000 -o "$T/reef/wd" >/dev/null \
  && OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$T/reef" <<'PYEOF' && ok || bad "world --ocean-floor-m"
import cv2, json, sys, numpy as np
d = sys.argv[1]
ha = cv2.imread(d + "/wa.height.exr", cv2.IMREAD_UNCHANGED); hb = cv2.imread(d + "/wd.height.exr", cv2.IMREAD_UNCHANGED)
assert ha.min() >= -100 and -2000 <= hb.min() < -500, (ha.min(), hb.min())
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

# A large island names its stages on stderr as they end (seconds each, and
# half a minute at 8192²); -q keeps stderr empty; the data stays on stdout.
"$BIN" infer "$T/s/one.png" -m "$M" -o "$T/s/big" --size 2049 >"$T/big.out" 2>"$T/big.err" \
  && grep -q "^infer: amplified in" "$T/big.err" && grep -q "^infer: files staged in" "$T/big.err" \
  && grep -q "big.height.exr" "$T/big.out" && ! grep -q "infer:" "$T/big.out" && ok \
  || bad "no stage lines for a 2049² infer: $(cat "$T/big.err")"
"$BIN" -q infer "$T/s/one.png" -m "$M" -o "$T/s/bigq" --size 2049 >/dev/null 2>"$T/bigq.err" && [ ! -s "$T/bigq.err" ] && ok \
  || bad "-q infer wrote on stderr: $(cat "$T/bigq.err")"

finish
