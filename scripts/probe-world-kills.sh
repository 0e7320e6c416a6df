#!/usr/bin/env bash
# The world's kill matrix: `reefgen world SKETCH --size N --layers --for A,B`
# stopped right after a file first appears (in PREFIX.partial/ while it is
# staged, or in the output folder while it is published), by kill -9 and by
# SIGINT, and cut short by a full disk (a file-size limit: writes past it fail
# with EFBIG, as on a full disk); each time the same command is run again.
# What must hold: every rerun exits 0 with the bytes of an uninterrupted run,
# leaves no PREFIX.partial, and no message of it starts with another
# library's text. FAIL lines and exit 1 otherwise; one line per point.
#   bash scripts/probe-world-kills.sh build/cli/reefgen              # 2049², unity,gis, 12 points
#   bash scripts/probe-world-kills.sh build/cli/reefgen --for unity,unreal --points 16
# Minutes: each point is a stopped run and a full one (2049²: ~30 s on 2 cores).
set -uo pipefail
BIN=$(realpath "${1:?usage: probe-world-kills.sh REEFGEN [--size N] [--for A,B] [--points K]}")
shift
SIZE=2049 FOR=unity,gis POINTS=12
while [ $# -gt 0 ]; do
  case $1 in
    --size) SIZE=$2; shift 2 ;;
    --for) FOR=$2; shift 2 ;;
    --points) POINTS=$2; shift 2 ;;
    *) echo "probe-world-kills: unknown argument $1" >&2; exit 2 ;;
  esac
done
T=$(mktemp -d /tmp/reefgen-world-kills.XXXXXX)
trap 'rm -rf "$T"' EXIT
pass=0 fail=0
ok() { pass=$((pass+1)); }
bad() { echo "FAIL: $*"; fail=$((fail+1)); }
"$BIN" -q sketch random --size 256x256 --islands 6 --seed 5 -o "$T/sea.png" >/dev/null || { echo "no sketch" >&2; exit 1; }
# The command under test, writing DIR/w.* (its paths on stdout dropped);
# world_bg starts it in the background, so that $! is reefgen itself.
world() { "$BIN" -q world "$T/sea.png" --size "$SIZE" --layers --for "$FOR" -o "$1/w" >/dev/null; }
world_bg() { "$BIN" -q world "$T/sea.png" --size "$SIZE" --layers --for "$FOR" -o "$1/w" >/dev/null 2>"$2" & }
# Every output's hash, by its path under DIR.
hashes() { (cd "$1" && find . -type f -print0 | sort -z | xargs -0 sha256sum); }
# Files as they first appear under DIR (staged or published), in order, until PID ends.
watch_files() {  # watch_files DIR PID OUT
  : > "$3"
  while kill -0 "$2" 2>/dev/null; do
    (cd "$1" 2>/dev/null && find . -type f ! -name '*.tmp*' ! -name '.*' 2>/dev/null) | while read -r f; do
      grep -qxF "$f" "$3" || echo "$f" >> "$3"
    done
    sleep 0.02
  done
}
# A rerun's stderr: a reefgen message, never another library's raw text.
foreign_text() { grep -E "OpenCV\(|std::|basic_string|json\.exception|filesystem error|terminate called" "$1"; }

mkdir -p "$T/ref"
world_bg "$T/ref" "$T/ref.err"
watch_files "$T/ref" $! "$T/order"
wait $! || { echo "probe-world-kills: the uninterrupted run failed: $(cat "$T/ref.err")" >&2; exit 1; }
hashes "$T/ref" > "$T/ref.sha"
mkdir -p "$T/ref2" && world "$T/ref2" 2>/dev/null && hashes "$T/ref2" > "$T/ref2.sha"
cmp -s "$T/ref.sha" "$T/ref2.sha" && ok || bad "two uninterrupted runs differ (the matrix below would mean nothing)"
n=$(wc -l < "$T/order")
echo "world $SIZE² --layers --for $FOR: $n files seen in order; stopping at $POINTS points × kill -9 and SIGINT"
# Points spread over the run: every stage's files, staged and published.
for k in $(seq 0 $((POINTS - 1))); do
  file=$(sed -n "$(( k * (n - 1) / (POINTS > 1 ? POINTS - 1 : 1) + 1 ))p" "$T/order")
  for sig in KILL INT; do
    d="$T/run.$k.$sig"
    mkdir -p "$d"
    world_bg "$d" "$d.err1"
    pid=$!
    for _ in $(seq 3000); do [ -e "$d/$file" ] && break; kill -0 $pid 2>/dev/null || break; sleep 0.01; done
    kill -s $sig $pid 2>/dev/null
    wait $pid 2>/dev/null
    rc1=$?
    world "$d" 2>"$d.err2"
    rc2=$?
    what="stopped by SIG$sig when $file appeared (first run exit $rc1)"
    if [ $rc2 -ne 0 ]; then bad "$what: the rerun failed ($rc2): $(head -c 300 "$d.err2")"; continue; fi
    [ -e "$d/w.partial" ] && { bad "$what: the rerun left w.partial"; continue; }
    foreign_text "$d.err1" "$d.err2" >/dev/null && { bad "$what: another library's text: $(foreign_text "$d.err1" "$d.err2" | head -1)"; continue; }
    hashes "$d" > "$d.sha"
    if cmp -s "$T/ref.sha" "$d.sha"; then ok; echo "ok: $what"; else bad "$what: the rerun's bytes differ: $(diff "$T/ref.sha" "$d.sha" | head -4 | tr '\n' ' ')"; fi
    rm -rf "$d"
  done
done
# A full disk at a few points of the run: the run fails with one line, the rerun finishes.
total_kb=$(du -sk "$T/ref" | cut -f1)
for share in 5 30 60 90; do
  d="$T/full.$share"
  mkdir -p "$d"
  limit=$(( total_kb * share / 100 / 4 + 64 ))  # ulimit -f counts 1 KiB blocks per file
  (trap '' XFSZ; ulimit -f $limit; world "$d") 2>"$d.err1"
  rc1=$?
  world "$d" 2>"$d.err2"
  rc2=$?
  what="a file-size limit of $limit KiB (first run exit $rc1)"
  if [ $rc2 -ne 0 ]; then bad "$what: the rerun failed: $(head -c 300 "$d.err2")"; continue; fi
  foreign_text "$d.err1" "$d.err2" >/dev/null && { bad "$what: another library's text: $(foreign_text "$d.err1" "$d.err2" | head -1)"; continue; }
  [ $rc1 -ne 0 ] && [ "$(wc -l < "$d.err1")" -gt 1 ] && { bad "$what: more than one line: $(head -c 300 "$d.err1")"; continue; }
  hashes "$d" > "$d.sha"
  cmp -s "$T/ref.sha" "$d.sha" && { ok; echo "ok: $what"; } || bad "$what: the rerun's bytes differ"
  rm -rf "$d"
done
echo "probe-world-kills: $pass passed, $fail failed"
[ $fail -eq 0 ]
