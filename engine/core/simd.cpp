#include "engine/core/simd.hpp"

#include <atomic>
#include <cstdlib>
#include <string_view>

namespace sparkdem {

namespace {

LaneIsa from_cpu() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl")) return LaneIsa::avx512;
  if (__builtin_cpu_supports("avx2")) return LaneIsa::avx2;
  return LaneIsa::scalar;
#else
  return LaneIsa::scalar;
#endif
}

LaneIsa from_environment(LaneIsa detected) {
  const char* v = std::getenv("SPARKDEM_LANES");
  if (!v) return detected;
  const std::string_view s(v);
  LaneIsa want = detected;
  if (s == "scalar") want = LaneIsa::scalar;
  else if (s == "avx2") want = LaneIsa::avx2;
  else if (s == "avx512") want = LaneIsa::avx512;
  return static_cast<int>(want) <= static_cast<int>(detected) ? want : detected;
}

std::atomic<int>& chosen() {
  static std::atomic<int> isa{static_cast<int>(from_environment(detected_lane_isa()))};
  return isa;
}

}  // namespace

LaneIsa detected_lane_isa() {
  static const LaneIsa isa = from_cpu();
  return isa;
}

LaneIsa lane_isa() { return static_cast<LaneIsa>(chosen().load(std::memory_order_relaxed)); }

void set_lane_isa(LaneIsa isa) {
  const LaneIsa top = detected_lane_isa();
  chosen().store(static_cast<int>(static_cast<int>(isa) <= static_cast<int>(top) ? isa : top), std::memory_order_relaxed);
}

std::string lane_isa_name(LaneIsa isa) {
  switch (isa) {
    case LaneIsa::scalar: return "scalar";
    case LaneIsa::avx2: return "avx2";
    case LaneIsa::avx512: return "avx512";
  }
  return "scalar";
}

}  // namespace sparkdem
