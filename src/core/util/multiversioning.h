/// \file multiversioning.h
/// \brief Hot loops compiled twice, for baseline x86-64 and for x86-64-v3 (internal).
///
/// A function marked DW_TARGET_V3 is compiled for x86-64-v3 (AVX2, FMA, BMI2); its caller picks it
/// where the CPU has it (cpuHasX86_64V3()) and a baseline twin elsewhere, so a package built for the
/// baseline still runs the wider code on the CPUs most users have. Users: the 3D kernel's insertion
/// (100k points on one thread ran 11 % fewer instructions) and the graph assembly's ranking of a
/// neighbourhood (vector compares of 64-bit keys, which baseline SSE2 lacks). The predicates' error
/// bounds still hold: the core is compiled with -ffp-contract=off, so no product is fused into an add.
/// By hand rather than with GCC's target_clones: an exception thrown inside a target_clones function
/// (a repeated point, std::bad_alloc) ends in std::terminate with GCC 12, as the call through its
/// ifunc is taken not to throw. Only with GCC on x86-64 (Clang 14 cannot test for "x86-64-v3");
/// elsewhere, or with DW_NO_MULTIVERSIONING (CMake: DW_MULTIVERSIONING=OFF), one baseline version.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(DW_NO_MULTIVERSIONING)
#define DW_X86_64_V3 1
#define DW_TARGET_V3 __attribute__((target("arch=x86-64-v3")))
#else
#define DW_X86_64_V3 0
#define DW_TARGET_V3
#endif

namespace dw {
namespace detail {

/// Whether this CPU runs x86-64-v3 code; false where no such version is compiled.
inline bool cpuHasX86_64V3() {
#if DW_X86_64_V3
  // Tested once: the callers are hot loops' wrappers, and a static's guard costs only a load.
  static const bool has = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("x86-64-v3") != 0;
  }();
  return has;
#else
  return false;
#endif
}

}  // namespace detail
}  // namespace dw
