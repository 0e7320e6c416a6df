#!/usr/bin/env bash
# libFuzzer on reefgen's untrusted inputs: the sketch decoder, every
# JSON config, the generator-file loader, the studio's requests, erode's
# heightmaps. Builds with clang + ASan + UBSan in
# build-fuzz/, fuzzes each TARGET for SECONDS, then merges what raised the
# coverage into tests/fuzz/corpus/TARGET (replayed by ctest fuzz_corpus_*).
#   bash scripts/fuzz.sh [sketch|config|generator|studio|heightmap|all] [SECONDS=600]
# Findings (crash-*, leak-*, oom-*, timeout-*) land in $FUZZ_OUT (default
# /tmp/reefgen-fuzz/TARGET) and make the script exit non-zero.
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:-all}; secs=${2:-600}
out=${FUZZ_OUT:-/tmp/reefgen-fuzz}
command -v clang++ >/dev/null || { echo "fuzz: clang++ missing (apt-get install clang libclang-rt-14-dev)" >&2; exit 1; }
targets=(sketch config generator studio heightmap); [ "$what" = all ] || targets=("$what")
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DREEFGEN_FUZZ=ON >/dev/null
ninja -C build-fuzz $(printf 'tests/fuzz_%s ' "${targets[@]}") >/dev/null
status=0
# ASan's allocator limit stands in for "a hostile file must not make us allocate GBs";
# LibTorch's own leak on corrupt zips is suppressed (tests/fuzz/lsan.supp).
export ASAN_OPTIONS=allocator_may_return_null=1:detect_leaks=1
export LSAN_OPTIONS=suppressions=$PWD/tests/fuzz/lsan.supp
for t in "${targets[@]}"; do
  work="$out/$t"; mkdir -p "$work/corpus" "$work/findings"
  corpus="tests/fuzz/corpus/$t"
  echo "fuzz: $t for ${secs}s (corpus $corpus, findings $work/findings)" >&2
  # The generator loader: LibTorch's unpickler allocates what a (corrupt)
  # file claims, e.g. a 25 GB storage. A release build gets std::bad_alloc and
  # refuses the file in one line (tests/fuzz/corpus/generator/regression-*);
  # ASan's operator new aborts instead, so that target fuzzes in fork mode,
  # which counts such out-of-memory inputs and goes on.
  extra=(); [ "$t" = generator ] && extra=(-fork=1 -ignore_ooms=1 -ignore_timeouts=0)
  build-fuzz/tests/fuzz_$t "$work/corpus" "$corpus" -max_total_time="$secs" -rss_limit_mb=4096 -timeout=20 "${extra[@]}" \
    -artifact_prefix="$work/findings/" -print_final_stats=1 2>"$work/log.txt" || status=1
  grep -E "^stat::number_of_executed_units|^#[0-9]+.*DONE" "$work/log.txt" | tail -2 >&2 || true
  # Keep only inputs that add coverage, and of those only small ones (≤ 32 KiB):
  # the repo's corpus stays small.
  mkdir -p "$work/merged"
  build-fuzz/tests/fuzz_$t -merge=1 -artifact_prefix="$work/findings/" "$work/merged" "$corpus" "$work/corpus" >/dev/null 2>&1 || true
  for f in "$work/merged"/*; do
    [ -e "$corpus/$(basename "$f")" ] || [ "$(stat -c %s "$f")" -gt 32768 ] || cp "$f" "$corpus/"
  done
  # Out-of-memory inputs of the generator target are expected (see above): listed, not failures.
  ls "$work/findings" | grep -v '^oom-' | grep -q . && { echo "fuzz: $t FOUND: $(ls "$work/findings")" >&2; status=1; }
  ls "$work/findings" | grep -q '^oom-' && echo "fuzz: $t: $(ls "$work/findings" | grep -c '^oom-') out-of-memory input(s) (LibTorch allocating what a corrupt file claims)" >&2
done
exit $status
