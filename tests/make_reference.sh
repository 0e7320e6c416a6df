#!/usr/bin/env bash
# CTest fixture: writes the Python reference outputs into DIR once (they are
# reused while the script is unchanged). Exits 0 without output when Debian's
# python3-torch is absent: the C++ tests then skip, or fail when
# REEFGEN_REQUIRE_REFERENCE is set (.ci/run sets it).
set -euo pipefail
script=$1 dir=$2
py=/usr/bin/python3
[ -x "$py" ] || py=$(command -v python3 || true)
if [ -z "$py" ] || ! "$py" -c 'import torch, numpy' 2>/dev/null; then
  echo "make_reference: no python3 with torch+numpy; equivalence tests will skip" >&2
  exit 0
fi
stamp="$dir/script.sha256"
# The reference depends on the kernels the CPU class runs too (a run capped
# with DNNL_MAX_CPU_ISA=AVX2 rounds differently): rebuilt when either changes.
want="$(sha256sum "$script" | cut -d' ' -f1) isa=${DNNL_MAX_CPU_ISA:-native} $(grep -m1 '^model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
if [ -f "$dir/reference.json" ] && [ "$(cat "$stamp" 2>/dev/null)" = "$want" ]; then exit 0; fi
mkdir -p "$dir"
"$py" "$script" --out "$dir" >/dev/null
echo "$want" > "$stamp"
