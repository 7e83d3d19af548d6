// lanemath::exp_and_expm1 (engine/core/lane_math.hpp, issue 63) against the C library's exp and
// expm1: within 2 units in the last place over the whole range, the limits (0, -1, +inf, NaN)
// exact, and the same bits over SIMD lanes as row by row.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "engine/core/lane_math.hpp"
#include "engine/core/simd.hpp"

namespace test_lane_math {

using namespace sparkdem;

namespace {

/// |a - b| in units in the last place of b (the subnormal spacing below the normal range).
double ulps(double a, double b) {
  if (a == b) return 0.0;
  if (std::isinf(a) || std::isinf(b)) return std::numeric_limits<double>::infinity();
  return std::abs(a - b) / std::ldexp(1.0, std::max(std::ilogb(b), -1022) - 52);
}

/// Arguments over the whole range: uniform in [-750, 712], in [-1, 1], and |x| log-uniform in
/// [1e-40, 100] with either sign (the small arguments where expm1 must not cancel).
std::vector<double> arguments() {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> wide(-750.0, 712.0), unit(-1.0, 1.0), decade(-40.0, 2.0);
  std::vector<double> x;
  for (int k = 0; k < 300000; ++k) {
    x.push_back(wide(rng));
    x.push_back(unit(rng));
    x.push_back(std::copysign(std::pow(10.0, decade(rng)), unit(rng)));
  }
  return x;
}

/// exp_and_expm1 of every argument in a loop over SIMD lanes (compiled per instruction set below).
[[gnu::always_inline]] inline void over_lanes(const std::vector<double>& x, std::vector<double>& e, std::vector<double>& m) {
  const std::size_t n = x.size();
#pragma omp simd
  for (std::size_t k = 0; k < n; ++k) {
    const lanemath::ExpAndExpm1 r = lanemath::exp_and_expm1(x[k]);
    e[k] = r.exp;
    m[k] = r.expm1;
  }
}
[[SPARKDEM_TARGET_AVX512]] void over_lanes_avx512(const std::vector<double>& x, std::vector<double>& e, std::vector<double>& m) {
  over_lanes(x, e, m);
}
[[SPARKDEM_TARGET_AVX2]] void over_lanes_avx2(const std::vector<double>& x, std::vector<double>& e, std::vector<double>& m) {
  over_lanes(x, e, m);
}

}  // namespace

TEST_CASE("lanemath exp and expm1 agree with the C library within 2 ulp", "[lanes]") {
  const std::vector<double> x = arguments();
  double worst_exp = 0.0, worst_expm1 = 0.0;
  for (double v : x) {
    const lanemath::ExpAndExpm1 r = lanemath::exp_and_expm1(v);
    worst_exp = std::max(worst_exp, ulps(r.exp, std::exp(v)));
    worst_expm1 = std::max(worst_expm1, ulps(r.expm1, std::expm1(v)));
  }
  INFO("worst exp " << worst_exp << " ulp, worst expm1 " << worst_expm1 << " ulp over " << x.size() << " arguments");
  CHECK(worst_exp <= 2.0);
  CHECK(worst_expm1 <= 2.0);
}

TEST_CASE("lanemath exp and expm1 at the limits", "[lanes]") {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const auto at = [](double v) { return lanemath::exp_and_expm1(v); };
  CHECK(at(0.0).exp == 1.0);
  CHECK(at(0.0).expm1 == 0.0);
  CHECK(at(1e-300).expm1 == 1e-300);
  CHECK(at(-inf).exp == 0.0);
  CHECK(at(-inf).expm1 == -1.0);
  CHECK(at(-800.0).exp == 0.0);
  CHECK(at(inf).exp == inf);
  CHECK(at(inf).expm1 == inf);
  CHECK(at(710.0).exp == inf);
  CHECK(at(709.7).exp == std::exp(709.7));     // the largest results: no overflow before the end
  CHECK(at(709.7).expm1 == std::expm1(709.7));
  CHECK(at(-745.1).exp == std::exp(-745.1));   // the smallest subnormal
  CHECK(ulps(at(-708.9).exp, std::exp(-708.9)) <= 1.0);  // subnormal, rounded once
  CHECK(std::isnan(at(std::nan("")).exp));
  CHECK(std::isnan(at(std::nan("")).expm1));
}

TEST_CASE("lanemath exp and expm1 give the same bits over SIMD lanes", "[lanes]") {
  const std::vector<double> x = arguments();
  std::vector<double> e(x.size()), m(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    const lanemath::ExpAndExpm1 r = lanemath::exp_and_expm1(x[k]);
    e[k] = r.exp;
    m[k] = r.expm1;
  }
  for (LaneIsa isa : {LaneIsa::avx2, LaneIsa::avx512}) {
    if (static_cast<int>(isa) > static_cast<int>(detected_lane_isa())) continue;
    std::vector<double> le(x.size()), lm(x.size());
    if (isa == LaneIsa::avx512)
      over_lanes_avx512(x, le, lm);
    else
      over_lanes_avx2(x, le, lm);
    INFO("lanes " << lane_isa_name(isa));
    CHECK(std::memcmp(le.data(), e.data(), e.size() * sizeof(double)) == 0);
    CHECK(std::memcmp(lm.data(), m.data(), m.size() * sizeof(double)) == 0);
  }
}

}  // namespace test_lane_math
