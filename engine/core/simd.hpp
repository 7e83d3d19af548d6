#pragma once
/// SIMD lane paths chosen at run time (issue 63): the build stays on the x86-64 baseline, and the
/// loops of the lane paths (the contact laws, engine/contact/lanes.hpp; the Verlet kick and drift,
/// engine/integrate/velocity_verlet.hpp) are compiled once more per instruction set, in functions
/// with these target attributes, and picked by lane_isa().
#include <string>

/// The instruction sets of the lane paths, as function attributes (`[[SPARKDEM_TARGET_AVX512]]`);
/// empty off x86-64, where lane_isa() is always scalar. GCC is also told to use the full 512-bit
/// registers (clang has no such target option and uses them for AVX-512 code by default).
#if defined(__x86_64__) && defined(__clang__)
#define SPARKDEM_TARGET_AVX512 gnu::target("avx512f,avx512dq,avx512vl")
#define SPARKDEM_TARGET_AVX2 gnu::target("avx2")
#elif defined(__x86_64__) && defined(__GNUC__)
#define SPARKDEM_TARGET_AVX512 gnu::target("avx512f,avx512dq,avx512vl,prefer-vector-width=512")
#define SPARKDEM_TARGET_AVX2 gnu::target("avx2")
#else
#define SPARKDEM_TARGET_AVX512
#define SPARKDEM_TARGET_AVX2
#endif

namespace sparkdem {

/// The widest lane path the processor runs: chosen once per process from the CPU's features, or
/// from the environment variable SPARKDEM_LANES (scalar, avx2, avx512; an unsupported or unknown
/// value falls back to the detected one). `scalar` is the row-by-row path of the laws' operator():
/// the reference every lane path is tested against (tests/unit/test_contact_lanes.cpp), and the path
/// of a processor without AVX2 (two lanes of SSE2 measured slower than it).
enum class LaneIsa { scalar, avx2, avx512 };
LaneIsa lane_isa();
/// The detected width without the environment override (the widest the CPU supports).
LaneIsa detected_lane_isa();
/// For tests and benchmarks: the path of every later pass (never above what the CPU supports).
void set_lane_isa(LaneIsa isa);
std::string lane_isa_name(LaneIsa isa);

}  // namespace sparkdem
