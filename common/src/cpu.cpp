#include "reefgen/cpu.hpp"

#include <cpuid.h>

#include <cctype>
#include <cstdlib>
#include <cstring>

#include "reefgen/files.hpp"
#include "reefgen/parallel.hpp"

namespace reefgen {

namespace {

bool bit(unsigned reg, int n) { return (reg >> n) & 1u; }

// XCR0: which register states the OS saves on a context switch. A CPU's
// AVX-512 is usable only when the OS saves the opmask and upper-ZMM state too.
unsigned long long xcr0() {
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (!__get_cpuid(1, &a, &b, &c, &d) || !bit(c, 27)) return 0;  // no OSXSAVE
  unsigned lo = 0, hi = 0;
  __asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
  return (static_cast<unsigned long long>(hi) << 32) | lo;
}

CpuFeatures read_features() {
  CpuFeatures f;
  f.model = cpu_model();
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (!__get_cpuid(1, &a, &b, &c, &d)) return f;
  const bool fma = bit(c, 12);
  const unsigned long long x = xcr0();
  const bool os_avx = (x & 0x6) == 0x6;             // XMM and YMM state
  const bool os_avx512 = os_avx && (x & 0xe0) == 0xe0;  // opmask, ZMM0-15 upper, ZMM16-31
  const bool os_amx = (x & 0x60000) == 0x60000;     // XTILECFG, XTILEDATA
  if (!__get_cpuid_count(7, 0, &a, &b, &c, &d)) return f;
  const unsigned max_sub = a;
  f.fma = fma && os_avx;
  f.avx2 = bit(b, 5) && os_avx;
  f.avx512f = bit(b, 16) && os_avx512;
  f.avx512bw = bit(b, 30) && os_avx512;
  f.avx512vl = bit(b, 31) && os_avx512;
  f.amx_bf16 = bit(d, 22) && os_amx;
  unsigned a1 = 0, b1 = 0, c1 = 0, d1 = 0;
  f.avx512_bf16 = max_sub >= 1 && __get_cpuid_count(7, 1, &a1, &b1, &c1, &d1) && bit(a1, 5) && f.avx512f;
  return f;
}

bool env_set(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::strcmp(v, "0") != 0;
}

// DNNL_MAX_CPU_ISA as a level: 0 below AVX2, 1 AVX2, 2 AVX-512, 3 AVX-512
// with bf16, 4 AMX or no cap. One knob caps oneDNN and reefgen's own loops
// alike, so a capped run measures one CPU class throughout.
int dnnl_cap_level() {
  const char* v = std::getenv("DNNL_MAX_CPU_ISA");
  if (!v || !*v) return 4;
  std::string s(v);
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (s == "all" || s.rfind("avx512_core_amx", 0) == 0) return 4;
  if (s == "avx512_core_bf16") return 3;
  if (s.rfind("avx512", 0) == 0) return 2;
  if (s.rfind("avx2", 0) == 0) return 1;
  return 0;
}

}  // namespace

const CpuFeatures& cpu_features() {
  static const CpuFeatures f = read_features();
  return f;
}

bool cpu_bf16_hidden() { return env_set("REEFGEN_NO_BF16"); }

CpuPath cpu_path() {
  const CpuFeatures& f = cpu_features();
  CpuPath best = f.avx512f && f.avx512bw && f.avx512vl && f.avx2 && f.fma ? CpuPath::Avx512
                 : f.avx2 && f.fma                                      ? CpuPath::Avx2
                                                                        : CpuPath::Sse2;
  const int dnnl_cap = dnnl_cap_level();
  if (dnnl_cap < 2 && best == CpuPath::Avx512) best = CpuPath::Avx2;
  if (dnnl_cap < 1) best = CpuPath::Sse2;
  const char* cap = std::getenv("REEFGEN_CPU_PATH");
  if (!cap || !*cap) return best;
  CpuPath want;
  if (!std::strcmp(cap, "sse2")) want = CpuPath::Sse2;
  else if (!std::strcmp(cap, "avx2")) want = CpuPath::Avx2;
  else if (!std::strcmp(cap, "avx512")) want = CpuPath::Avx512;
  else throw Error(std::string("REEFGEN_CPU_PATH='") + cap + "': use sse2, avx2 or avx512 (or unset it)");
  return static_cast<int>(want) < static_cast<int>(best) ? want : best;
}

const char* to_string(CpuPath p) {
  return p == CpuPath::Avx512 ? "avx512" : p == CpuPath::Avx2 ? "avx2" : "sse2";
}

std::string cpu_class() {
  const CpuFeatures& f = cpu_features();
  const CpuPath p = cpu_path();
  if (p == CpuPath::Avx512 && !cpu_bf16_hidden()) {
    if (f.amx_bf16 && dnnl_cap_level() >= 4) return "amx";
    if (f.avx512_bf16 && dnnl_cap_level() >= 3) return "avx512-bf16";
  }
  return to_string(p);
}

std::string cpu_summary() {
  const CpuFeatures& f = cpu_features();
  std::string flags;
  auto add = [&](const char* name, bool on) { flags += std::string(flags.empty() ? "" : " ") + (on ? "" : "-") + name; };
  add("avx2", f.avx2);
  add("fma", f.fma);
  add("avx512f", f.avx512f);
  add("avx512bw", f.avx512bw);
  add("avx512_bf16", f.avx512_bf16);
  add("amx_bf16", f.amx_bf16);
  std::string s = f.model + " | class " + cpu_class() + " | " + flags;
  if (cpu_bf16_hidden()) s += " | REEFGEN_NO_BF16";
  if (const char* p = std::getenv("REEFGEN_CPU_PATH"); p && *p) s += std::string(" | REEFGEN_CPU_PATH=") + p;
  if (const char* p = std::getenv("DNNL_MAX_CPU_ISA"); p && *p) s += std::string(" | DNNL_MAX_CPU_ISA=") + p;
  return s;
}

}  // namespace reefgen
