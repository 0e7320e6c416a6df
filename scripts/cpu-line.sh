# Sourced by the benchmark scripts: cpu_line BIN prints the one line every
# figure is written next to — CPU model, class (amx, avx512-bf16, avx512,
# avx2, sse2), the flags that matter, any REEFGEN_NO_BF16 / REEFGEN_CPU_PATH /
# DNNL_MAX_CPU_ISA cap — plus the core count and the date. Never fails: a
# missing binary falls back to /proc/cpuinfo.
cpu_line() {
  local bin=${1:-build/cli/reefgen} py=/usr/bin/python3 s=""
  [ -x "$py" ] || py=python3
  s=$("$bin" -q model cpu 2>/dev/null | "$py" -c 'import json,sys; print(json.load(sys.stdin)["summary"])' 2>/dev/null) || s=""
  if [ -z "$s" ]; then
    s="$(sed -n 's/^model name\s*: //p' /proc/cpuinfo | head -1) | flags: $(grep -o -w -E 'avx2|fma|avx512f|avx512bw|avx512_bf16|amx_bf16' /proc/cpuinfo | sort -u | tr '\n' ' ' || true)"
  fi
  echo "cpu: $s | $(nproc) cores | $(date -u +%F)"
}
