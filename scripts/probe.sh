#!/usr/bin/env bash
# Replays the hostile probes against a reefgen binary: crashes,
# lost or stray files, validation and messages. Each probe states what must
# hold; any that does not is printed as FAIL and the exit code is 1.
#   bash scripts/probe.sh build/cli/reefgen          # everything but the full disk
#   bash scripts/probe.sh build/cli/reefgen --full-disk
# --full-disk runs the full-disk probes on a 2 MB tmpfs (needs root and
# mount), or, where mounting is not allowed, with a 2 MB file-size limit
# (ulimit -f: writes past it fail with EFBIG, as on a full disk).
# The studio's probes (points 8-12) run as API tests: ctest -R Studio.
set -u
R=$(realpath "$1"); shift
MODE=${1:-}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
T=$(mktemp -d)
FULL=""
cleanup() { [ -n "$FULL" ] && mountpoint -q "$FULL" && umount "$FULL"; rm -rf "$T"; }
trap cleanup EXIT
fail=0; pass=0
ok() { pass=$((pass+1)); }
bad() { echo "FAIL: $*"; fail=$((fail+1)); }
PY=/usr/bin/python3; [ -x "$PY" ] || PY=python3
cd "$T"

# refuses NEEDLE ARGS...: non-zero exit (not a signal), one line on stderr naming NEEDLE.
refuses() {
  local needle="$1"; shift
  "$R" "$@" >"$T/out" 2>"$T/err"; local rc=$?
  if [ $rc = 0 ]; then bad "accepted: $* ($(head -c 200 "$T/out"))"; return; fi
  [ $rc -ge 128 ] && { bad "signal $((rc-128)) for: $*: $(head -3 "$T/err")"; return; }
  [ "$(wc -l < "$T/err")" = 1 ] || { bad "not one line for: $* -> $(head -5 "$T/err")"; return; }
  grep -q -- "$needle" "$T/err" || { bad "message lacks '$needle' for: $* -> $(cat "$T/err")"; return; }
  grep -qi "json.exception\|OpenCV(\|libpng\|stoi\|stol\|what()\|c10::" "$T/err" && { bad "library text for: $* -> $(cat "$T/err")"; return; }
  ok
}
no_temps() {  # no_temps DIR LABEL
  local left; left=$(find "$1" -name '*.tmp*' 2>/dev/null | head -3)
  [ -z "$left" ] && ok || bad "$2: temporary files left: $left"
}

"$R" -q dataset build --count 20 --seed 3 --out d20 >/dev/null || bad "dataset d20"
"$R" -q dataset build --count 6 --seed 4 --config <(echo '{"size_px": 128, "val_fraction": 0.2}') --out d128 >/dev/null || bad "dataset d128"

if [ "$MODE" = "--full-disk" ]; then
  # 1, 2 and the other writers on a full disk: no abort, no temp files, one line.
  FULL="$T/full"; mkdir -p "$FULL"
  if [ -z "${PROBE_NO_MOUNT:-}" ] && mount -t tmpfs -o size=2m tmpfs "$FULL" 2>/dev/null; then
    LIMIT=""; echo "full disk: 2 MB tmpfs"
  else
    FULL=""; mkdir -p "$T/fsz"; LIMIT="ulimit -f 2048;"; echo "full disk: no mount here, 2 MB file-size limit instead"
  fi
  D=${FULL:-$T/fsz}
  full() {  # full LABEL NEEDLE ARGS...: fails cleanly on the full disk
    local label="$1" needle="$2"; shift 2
    (trap '' XFSZ; eval "$LIMIT" exec "$R" "$@") >/dev/null 2>"$T/err"; local rc=$?
    if [ $rc = 0 ]; then bad "$label: succeeded on a full disk?"; fi
    [ $rc -ge 128 ] && bad "$label: killed by signal $((rc-128)): $(head -2 "$T/err")"
    [ "$(wc -l < "$T/err")" -le 2 ] || bad "$label: more than a line or two: $(head -5 "$T/err")"
    grep -q -- "$needle" "$T/err" || bad "$label: message lacks '$needle': $(cat "$T/err")"
    grep -q "terminate called\|c10::Error" "$T/err" && bad "$label: abort text: $(head -2 "$T/err")"
    no_temps "$D" "$label"
    ok
  }
  [ -n "$FULL" ] && head -c 1500000 /dev/zero > "$FULL/filler"  # leave ~0.5 MB
  full "train" "cannot write" train --data d20 --out "$D/run" --max-steps 1 --ngf 8 --ndf 8
  full "model pack" "g16.pt" model pack "$ROOT/models/reef-256.pt" -o "$D/g16.pt"
  full "generate" "$D/big" generate --preset atoll --size 1024 -o "$D/big"
  full "infer" "$D/inf" infer "$ROOT/tests/data/painted/01-young-volcano.png" --size 1024 -o "$D/inf"
  # A dataset's files are each far below 2 MB: only a real full disk stops it.
  if [ -n "$FULL" ]; then full "dataset" "$D/ds" dataset build --count 40 --out "$D/ds"
  else echo "full disk: dataset probe skipped (needs the tmpfs)"; fi
  # A GeoTIFF on a full disk names the full disk (libtiff said "TIFFAppendToStrip:
  # Write error at scanline 0"): the disk is filled so that the EXR, label and
  # sidecar of the same island fit, with 32 KiB to spare, and its GeoTIFF does not.
  if [ -n "$FULL" ]; then
    rm -f "$FULL/filler"
    "$R" -q generate --preset young-volcano --size 256 -o "$T/gtref" >/dev/null || bad "geotiff reference"
    need=$(( $(cat "$T/gtref.height.exr" "$T/gtref.label.png" "$T/gtref.json" | wc -c) / 1024 + 32 ))
    free=$(df -k --output=avail "$FULL" | tail -1)
    [ "$free" -gt "$need" ] && head -c $(( (free - need) * 1024 )) /dev/zero > "$FULL/filler"
    full "geotiff" "the disk is full" generate --preset young-volcano --size 256 --geotiff -o "$D/gt"
  fi
  rm -rf "${D:?}"/*
fi

# 3. eval-sketches never overwrites an input named like its outputs.
mkdir -p e && cp "$ROOT/tests/data/painted/01-young-volcano.png" e/grid.png && cp e/grid.png grid.orig
refuses "also an input" eval-sketches e --out e
cmp -s e/grid.png grid.orig && ok || bad "3: the input grid.png was changed"

# 4. A folder that is not a dataset is refused unless empty; the user's file stays.
mkdir -p u && echo notes > u/manifest.jsonl
refuses "not a reefgen dataset" dataset build --count 8 --out u
[ "$(cat u/manifest.jsonl)" = notes ] && ok || bad "4: u/manifest.jsonl was replaced"

# 5. Temporaries of a killed run are gone after the rerun (also the nested
#    NAME.tmp.PID.N.tmp.PID.M of a staged EXR).
mkdir -p g
touch g/island_000000_l0.height.exr.tmp.999999.0.tmp.999999.1 g/island_000000_l0.json.tmp.999999.3
"$R" -q generate --random 2 --levels 2 --size 64 --out g >/dev/null 2>&1 &
pid=$!; sleep 0.3; kill -9 $pid 2>/dev/null; wait $pid 2>/dev/null
"$R" -q generate --random 2 --levels 2 --size 64 --out g >/dev/null || bad "5: rerun failed"
no_temps g "5: generate after kill -9"

# 6, 7. Train: the run folder is not the dataset; a resume reads its own dataset.
refuses "overlaps it" train --data d20 --out d20 --max-steps 1 --ngf 8 --ndf 8
refuses "overlaps it" train --data d20 --out d20/run --max-steps 1 --ngf 8 --ndf 8
[ ! -e d20/run ] && [ ! -e d20/run.json ] && [ ! -e d20/log.csv ] && ok || bad "6: training wrote into its dataset"
"$R" -q train --data d20 --out run --max-steps 1 --ngf 8 --ndf 8 --depth 5 >/dev/null 2>&1 || bad "7: first run"
cp run/run.json run.json.orig
refuses "not the dataset this run was started with" train --data d128 --out run --resume
cmp -s run/run.json run.json.orig && ok || bad "7: run.json rewritten by a refused resume"
# Same size and count but other pairs (another seed): the manifest differs.
"$R" -q dataset build --count 20 --seed 4 --out d20b >/dev/null || bad "dataset d20b"
refuses "manifest_fnv64" train --data d20b --out run --resume
# The same dataset moved elsewhere resumes.
mv d20 d20moved && "$R" -q train --data d20moved --out run --resume --max-steps 2 >/dev/null 2>&1 && ok || bad "7: a moved dataset did not resume"
mv d20moved d20

# 13. Values out of range are refused, never replaced by a default.
refuses "count" dataset build --count 0 --out c0
refuses "count" dataset build --count -4 --out c0
[ ! -e c0/dataset.json ] && ok || bad "13: --count 0 started a build"
refuses "max-steps" train --data d20 --out r2 --max-steps -5
refuses "0 steps" train --data d20 --out r3 --epochs 0 --epochs-decay 1e-300 --ngf 8 --ndf 8
[ ! -e r3/generator.pt ] && ok || bad "13: an untrained generator.pt was written"
refuses "seed" generate --preset atoll --seed -1 -o s1
refuses "seed" generate --preset atoll --seed 18446744073709551616 -o s1
refuses "epochs" train --data d20 --out r4 --epochs nan
# A spec's seed of 2^64 (a JSON double that rounds to uint64's max + 1) was seed 0.
echo '{"noise": {"seed": 18446744073709551616}}' > s64.json
refuses "noise.seed" generate --spec s64.json --size 64 -o s2
# Variations whose seeds pass 2^64 - 1 wrapped to PREFIX.seed0.*.
refuses "seeds pass" infer "$ROOT/tests/data/painted/01-young-volcano.png" --variations 3 --seed 18446744073709551614 -o v1
ls v1.seed0.* >/dev/null 2>&1 && bad "13: a wrapped variation was written" || ok
# An ocean floor above the flank's knee stretched nothing and was recorded.
refuses "-60" generate --preset atoll --size 64 --ocean-floor-m -59 -o of1
# Every error exits 1, CLI11's own validation errors (105) included.
"$R" -q generate --preset atoll --size 0 -o z1 >/dev/null 2>&1; rc=$?
[ $rc = 1 ] && ok || bad "13: a validation error exited $rc, not 1"
"$R" -q generat -o z1 >/dev/null 2>&1; rc=$?
[ $rc = 1 ] && ok || bad "13: an unknown command exited $rc, not 1"

# 14. A truncated image is refused (JPEG and PNG).
"$PY" -c "import cv2; cv2.imwrite('$T/p.jpg', cv2.imread('$ROOT/tests/data/painted/01-young-volcano.png'))"
head -c 4000 p.jpg > cut.jpg
head -c 3000 "$ROOT/tests/data/painted/01-young-volcano.png" > cut.png
refuses "truncated JPEG" infer cut.jpg -o i1
refuses "truncated PNG" infer cut.png -o i1
[ ! -e i1.height.exr ] && ok || bad "14: output written for a truncated sketch"

# 15. Config reads are bounded; a folder is not "invalid JSON".
timeout 20 "$R" generate --spec /dev/zero -o z >/dev/null 2>"$T/err"; rc=$?
[ $rc != 0 ] && [ $rc != 124 ] && grep -q "larger than" "$T/err" && ok || bad "15: /dev/zero spec: rc $rc $(head -c 200 "$T/err")"
mkdir -p specdir
refuses "is a folder" generate --spec specdir -o z

# 16. floating: inputs that would break the mesher are refused up front.
echo '{"rim_m": 1e-300}' > rim.json
refuses "rim_m" floating --painting "$ROOT/docs/examples/floating-painting.png" --config rim.json -o f.glb
refuses "metres_per_px" floating --painting "$ROOT/docs/examples/floating-painting.png" --metres-per-px 1e-30 -o f.glb

# 17. Messages: one line naming the file or the field, no library text.
echo '{"lr": "fast"}' > lr.json
refuses "lr" train --config lr.json --data d20 --out r5
refuses "shard" dataset build --count 4 --out sh --shard 0/999999999999
refuses "bench infer\|--size" bench infer --size 1048576
refuses "number of islands must be in 1..10000000" generate --random 0
echo '{"wind_substeps": 1e30}' > ws.json
refuses "\[1, 100\]" generate --spec ws.json -o w
cp -r d20 dtrunc && head -c 100 d20/manifest.jsonl > dtrunc/manifest.jsonl
refuses "manifest.jsonl:1" train --data dtrunc --out r6 --max-steps 1 --ngf 8 --ndf 8
refuses "manifest.jsonl:1" dataset stats dtrunc
cp -r d20 dsize && lab=$(ls dsize/train/*.label.png | head -1) && \
  "$PY" -c "import cv2; cv2.imwrite('$lab', cv2.resize(cv2.imread('$lab'), (48, 48)))"
refuses "$(basename "$lab")" eval -m "$ROOT/models/reef-256.pt" --data dsize --split train

# An invalid UTF-8 file name: its sidecar is still written (the name's bad
# bytes replaced), not "invalid UTF-8 byte" from the JSON library.
cp "$ROOT/tests/data/painted/01-young-volcano.png" "$T/bad"$'\xff'".png"
"$R" -q infer "$T/bad"$'\xff'".png" -o utf >/dev/null 2>"$T/err" && [ -s utf.json ] && ok || bad "17: invalid UTF-8 name: $(cat "$T/err")"

# 18. No hidden files from "-o dir/"; a folder of one sketch gives a folder.
mkdir -p gen
refuses "not a file prefix" generate --preset atoll -o gen/
refuses "not a file prefix" terrain mapgen4 -o te/x/
[ -z "$(ls -A gen)" ] && ok || bad "18: files in gen/: $(ls -A gen)"
mkdir -p one && cp "$ROOT/tests/data/painted/01-young-volcano.png" one/
"$R" -q infer one -o oneout >/dev/null || bad "18: infer on a folder of one"
[ -f oneout/01-young-volcano.height.exr ] && ok || bad "18: -o was not treated as a folder: $(ls)"
cp -r d20 dnan && h=$(ls dnan/train/*.height.exr | head -1)
OPENCV_IO_ENABLE_OPENEXR=1 "$PY" - "$h" <<'EOF' || bad "18: could not make a NaN pair"
import sys, cv2, numpy as np
a = cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED)
sys.exit(0 if cv2.imwrite(sys.argv[1], np.full(a.shape[:2], np.nan, np.float32)) else 1)
EOF
refuses "NaN" dataset stats dnan --no-verify
refuses "its bytes differ" dataset stats dnan

# 19. A FIFO nobody writes to is refused at once (open() used to
# block forever); a shell's <(...) pipe is still read, once.
mkfifo fifo1
fifo_refused() {  # fifo_refused ARGS...: one line naming the FIFO within 20 s
  timeout 20 "$R" "$@" >/dev/null 2>"$T/err"; local rc=$?
  [ $rc = 124 ] && { bad "19: hung on a FIFO: $*"; return; }
  [ $rc != 0 ] && [ $rc -lt 128 ] && grep -q "fifo1" "$T/err" && [ "$(wc -l < "$T/err")" = 1 ] && ok \
    || bad "19: FIFO not refused in one line: $* -> rc $rc $(cat "$T/err")"
}
fifo_refused generate --spec fifo1 -o fifo-out
fifo_refused infer fifo1 -o fifo-out
fifo_refused dataset build --config fifo1 --out fifo-ds
timeout 20 "$R" -q generate --spec <(cat "$ROOT/configs/presets/atoll.json") --size 48 -o piped >/dev/null && [ -s piped.height.exr ] \
  && ok || bad "19: --spec <(...) no longer read"
timeout 60 "$R" -q infer <(cat "$ROOT/tests/data/painted/01-young-volcano.png") -o piped-sketch >/dev/null && [ -s piped-sketch.height.exr ] \
  && ok || bad "19: a sketch from <(...) no longer read"

# 20. Datasets are checked before they are trusted.
cp -r d20 dswap && a=$(ls dswap/train/*.label.png | head -1) && b=$(ls dswap/train/*.label.png | sed -n 2p) && cp "$b" "$a"
refuses "its bytes differ" train --data dswap --out swaprun --max-steps 1 --ngf 8 --ndf 8
refuses "its bytes differ" dataset stats dswap
[ ! -e swaprun ] && ok || bad "20: a refused dataset left a run folder"
"$R" -q dataset stats dswap --no-verify >/dev/null && ok || bad "20: --no-verify does not read a swapped dataset"
cp -r d20 descape && sed -i '1s#"label":"[^"]*"#"label":"../../../../etc/passwd"#' descape/manifest.jsonl
refuses "outside the dataset folder" train --data descape --out escrun --max-steps 1 --no-verify
refuses "outside the dataset folder" dataset stats descape --no-verify
cp -r d20 ddup && head -1 d20/manifest.jsonl >> ddup/manifest.jsonl
refuses "listed again" train --data ddup --out duprun --max-steps 1

# 21. A number beyond a double names the file, not the JSON library.
echo '{"subsidence": 1e400}' > huge.json
refuses "huge.json: '1e400' is beyond the range" generate --spec huge.json -o huge
refuses "huge.json: '1e400' is beyond the range" dataset build --config huge.json --out huge-ds

# 22. A resume remakes an island whose file was cut short since
# (it counted it as done: "wrote 0 islands").
"$R" -q generate --random 2 --levels 1 --seed 3 --size 64 --out trunc >/dev/null
cp trunc/island_000000_l0.height.exr whole.exr
truncate -s 100 trunc/island_000000_l0.height.exr
"$R" generate --random 2 --levels 1 --seed 3 --size 64 --out trunc 2>"$T/err" >/dev/null
grep -q "wrote 1 islands (1 already there)" "$T/err" && cmp -s whole.exr trunc/island_000000_l0.height.exr \
  && ok || bad "22: a truncated island was kept on resume: $(cat "$T/err")"

# 23. A reader finishes a commit cut short before it reads (the new set,
# never a mix of two runs), and obeys no journal a user could plant.
"$R" -q generate --preset atoll --size 64 -o cut/x >/dev/null && "$R" -q generate --preset young-volcano --size 64 -o cutnew/x >/dev/null
dead=$(sh -c 'echo $$')
{ echo "reefgen-commit-journal 1"
  for f in height.exr label.png json; do cp "cutnew/x.$f" "cut/x.$f.tmp.$dead.$f"; printf '%s\t%s\n' "$PWD/cut/x.$f.tmp.$dead.$f" "$PWD/cut/x.$f"; done
} > "cut/.reefgen.commit.$dead.0"
echo mine > cut/notes.txt; echo precious > cut/thesis.txt
printf 'reefgen-commit-journal 1\n%s\t%s\n' "$PWD/cut/notes.txt" "$PWD/cut/thesis.txt" > "cut/.reefgen.commit.$dead.1"
"$R" realism cut/x.height.exr --json > cut.stats 2>"$T/err" || bad "23: realism over a cut commit: $(cat "$T/err")"
"$R" realism cutnew/x.height.exr --json > new.stats
cmp -s cut/x.json cutnew/x.json && cmp -s cut/x.height.exr cutnew/x.height.exr && [ "$(cut -d, -f2- cut.stats)" = "$(cut -d, -f2- new.stats)" ] \
  && ok || bad "23: realism did not read the finished new set"
[ -z "$(ls -A cut | grep -E 'reefgen.commit|\.tmp\.')" ] && ok || bad "23: journal or staged copies left: $(ls -A cut)"
[ "$(cat cut/notes.txt)" = mine ] && [ "$(cat cut/thesis.txt)" = precious ] && ok || bad "23: a planted journal moved a user's file"

# 24. erode refuses a heightmap too large from its header, before allocating:
# an EXR declaring 30000² (3.6 GB of floats) and a PNG16 declaring 20000².
rss_of() {  # rss_of ARGS...: peak RSS in MB of "$R ARGS..." (its exit status ignored)
  "$PY" -c 'import resource, subprocess, sys
subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss // 1024)' "$R" "$@"
}
"$R" -q generate --preset atoll --size 64 -o big/a >/dev/null
"$PY" - big/a.height.exr big/huge.exr <<'PY'
import struct, sys
b = bytearray(open(sys.argv[1], "rb").read())
at = b.find(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
b[at:at + 16] = struct.pack("<4i", 0, 0, 29999, 29999)
open(sys.argv[2], "wb").write(b)
PY
refuses "30000×30000 pixels; at most 8192" erode big/huge.exr --world-size 6000 -o big/e
[ "$(rss_of erode big/huge.exr --world-size 6000 -o big/e)" -le 200 ] && ok || bad "24: erode's refusal of a 30000² EXR took > 200 MB"
"$PY" - big/liar.png <<'PY'
import struct, sys, zlib
chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
ihdr = struct.pack(">IIBBBBB", 20000, 20000, 16, 0, 0, 0, 0)
open(sys.argv[1], "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", bytes(777000)) + chunk(b"IEND", b""))
PY
refuses "20000×20000 pixels; at most 8192" erode big/liar.png --range 0:100 --world-size 6000 -o big/e
[ "$(rss_of erode big/liar.png --range 0:100 --world-size 6000 -o big/e)" -le 200 ] && ok || bad "24: erode's refusal of a 20000² PNG16 took > 200 MB"

echo "probe: $pass passed, $fail failed"
[ $fail = 0 ]
