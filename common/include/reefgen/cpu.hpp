#pragma once
// What the CPU can do, read once with cpuid (and xgetbv for the OS's part),
// so that every fast path is chosen at run time and every figure and test
// log names the CPU class it ran on (docs/BENCHMARKS.md).
//
// Environment, for tests and benchmarks on any machine:
//   REEFGEN_NO_BF16=1      hides avx512_bf16 / AMX-bf16: bf16 is treated as
//                          unavailable, auto picks float32, an explicit
//                          --precision bf16 is refused as on a CPU without it;
//   REEFGEN_CPU_PATH=P     caps the vectorised loops' code path at P (sse2,
//                          avx2 or avx512);
//   DNNL_MAX_CPU_ISA=ISA   oneDNN's own cap (AVX2, AVX512_CORE, ...) caps
//                          reefgen's class and vector path too, so one
//                          variable makes an AVX-512 machine an AVX2 one.
#include <string>

namespace reefgen {

struct CpuFeatures {
  std::string model;  // /proc/cpuinfo's model name
  bool fma = false, avx2 = false;
  bool avx512f = false, avx512bw = false, avx512vl = false;
  bool avx512_bf16 = false, amx_bf16 = false;  // as the CPU reports them, before REEFGEN_NO_BF16
};

// Read once per process (cpuid does not change under us).
const CpuFeatures& cpu_features();

// REEFGEN_NO_BF16 set to anything but "" or "0".
bool cpu_bf16_hidden();

// The class the docs' tables are written per: "amx", "avx512-bf16",
// "avx512", "avx2" or "sse2", after REEFGEN_NO_BF16 and REEFGEN_CPU_PATH.
std::string cpu_class();

// One line for logs and benchmark output: model, class and the flags that
// matter, e.g. "AMD EPYC | class avx512-bf16 | avx2 fma avx512f avx512bw
// avx512_bf16 -amx_bf16".
std::string cpu_summary();

// The widest path the vectorised loops may take: 0 sse2, 1 avx2 (+fma),
// 2 avx512 (f+bw+vl); what the CPU and the OS support, capped by
// REEFGEN_CPU_PATH (an unknown value is an error naming the variable).
enum class CpuPath { Sse2 = 0, Avx2 = 1, Avx512 = 2 };
CpuPath cpu_path();
const char* to_string(CpuPath p);

}  // namespace reefgen
