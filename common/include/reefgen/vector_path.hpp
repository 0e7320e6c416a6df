#pragma once
// Run-time dispatch of the hot loops (docs/BENCHMARKS.md, "Vector paths").
//
// The build has no -march flag, so a loop is compiled three times: once for
// the baseline (SSE2), once with REEFGEN_AVX2 and once with REEFGEN_AVX512,
// each a thin wrapper that inlines the same always-inline body; pick_path()
// chooses one by cpu_path() (REEFGEN_CPU_PATH forces a smaller one). FMA is
// left out of every target and the build passes -ffp-contract=off, so each
// path rounds every operation as the scalar code does: the paths give the
// same bytes, which tests check by hashing outputs under each path.
#include "reefgen/cpu.hpp"

#define REEFGEN_INLINE_BODY [[gnu::always_inline]] inline
#define REEFGEN_AVX2 [[gnu::target("avx2")]]
#define REEFGEN_AVX512 [[gnu::target("avx2,avx512f,avx512vl,avx512bw,avx512dq")]]

namespace reefgen {

// One of three versions of a function, for the path this process runs on.
template <class Fn>
Fn pick_path(Fn sse2, Fn avx2, Fn avx512) {
  switch (cpu_path()) {
    case CpuPath::Avx512: return avx512;
    case CpuPath::Avx2: return avx2;
    default: return sse2;
  }
}

}  // namespace reefgen

// NAME's three compiled paths from NAME_body (a REEFGEN_INLINE_BODY function
// of the same parameters) and NAME itself, which calls the one pick_path
// chooses for this process (so REEFGEN_CPU_PATH caps it like every loop),
// looked up once. PARAMS and ARGS in parentheses:
//   REEFGEN_DISPATCHED(void, add_rows, (const float* a, float* o, int64_t n), (a, o, n))
#define REEFGEN_DISPATCHED(ret, name, params, args)                                          \
  ret name##_sse2 params { return name##_body args; }                                        \
  REEFGEN_AVX2 ret name##_avx2 params { return name##_body args; }                           \
  REEFGEN_AVX512 ret name##_avx512 params { return name##_body args; }                       \
  ret name params {                                                                          \
    static const auto path = ::reefgen::pick_path(&name##_sse2, &name##_avx2, &name##_avx512); \
    return path args;                                                                        \
  }
