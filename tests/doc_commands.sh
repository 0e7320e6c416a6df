#!/usr/bin/env bash
# Every reefgen command shown in README.md and docs/*.md parses:
# each line of a code block that starts with `reefgen` or `build/cli/reefgen`
# is run with REEFGEN_PARSE_ONLY=1 — the real command line parser, options and
# validators, without doing the work. A renamed flag or a typo in the docs
# fails here.
set -u
BIN="$1"; ROOT="$(cd "$(dirname "$0")/.." && pwd)"
fail=0; n=0
while IFS=$'\t' read -r file line; do
  cmd="${line#build/cli/}"
  cmd="${cmd%%  #*}"; cmd="${cmd%% # *}"          # trailing comments
  cmd="${cmd#reefgen}"
  n=$((n+1))
  if ! out=$(cd "$ROOT" && eval "REEFGEN_PARSE_ONLY=1 \"$BIN\" $cmd" 2>&1 </dev/null); then
    echo "FAIL: $file: reefgen$cmd -> $out"; fail=$((fail+1))
  fi
done < <(cd "$ROOT" && awk '
  FNR == 1 { inblock = 0 }
  /^```/ { inblock = !inblock; next }
  inblock && /^(build\/cli\/)?reefgen / && !/[|]|&&|\\$|<|>|\$\(/ { print FILENAME "\t" $0 }
' README.md docs/*.md)
echo "$n documented commands, $fail failed"
[ "$n" -gt 20 ] && [ "$fail" = 0 ]
