# Shared by the end-to-end scripts (cli_test.sh, cli_infer_test.sh, cli_infer_models_test.sh,
# cli_world_test.sh, cli_world_tiles_test.sh), which ctest runs side by side: BIN, a temporary
# folder T removed on exit, the python with cv2, the pass/fail counters, the
# one-line-error check and the CPU class. Sourced, with the binary as "$1".
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

# The counts, and the exit status: 0 when nothing failed.
finish() {
  echo "$pass passed, $fail failed, $skipped skipped"
  [ "$fail" = 0 ]
}

# The tiny model and its dataset into $T (d1/, t1/, ds.json, tr.json): from
# ctest's tiny_model fixture (REEFGEN_TINY_MODEL, cli_tiny_model.sh), or
# trained here when a script runs on its own. Copies: the checks may not
# touch the fixture another part reads.
tiny_model() {
  local dir="${REEFGEN_TINY_MODEL:-}"
  if [ -z "$dir" ] || [ ! -s "$dir/t1/generator.pt" ]; then
    dir="$T/tiny"
    bash "$(dirname "${BASH_SOURCE[0]}")/cli_tiny_model.sh" "$BIN" "$dir" || { echo "FAIL: the tiny model"; exit 1; }
  fi
  cp -r "$dir/d1" "$dir/t1" "$dir/ds.json" "$dir/tr.json" "$T/"
}
