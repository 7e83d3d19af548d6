#pragma once
/// Small helpers for stating tolerances in tests: relative errors and zero crossings.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace sparkdem::test {

/// |value - reference| / |reference| (absolute error when the reference is 0).
inline double relative_error(double value, double reference) {
  const double d = std::abs(value - reference);
  return reference != 0.0 ? d / std::abs(reference) : d;
}

/// First time t* > t_from at which the sampled signal y(t) crosses zero in the given direction
/// (rising: y <= 0 -> y > 0; falling: y > 0 -> y <= 0), linearly interpolated between the two
/// samples that bracket it. NaN if there is no such crossing.
inline double zero_crossing(const std::vector<double>& t, const std::vector<double>& y, bool rising,
                            double t_from = -std::numeric_limits<double>::infinity()) {
  for (std::size_t k = 1; k < t.size(); ++k) {
    if (t[k] <= t_from) continue;
    const bool cross = rising ? (y[k - 1] <= 0.0 && y[k] > 0.0) : (y[k - 1] > 0.0 && y[k] <= 0.0);
    if (!cross) continue;
    const double s = y[k - 1] / (y[k - 1] - y[k]);
    return t[k - 1] + s * (t[k] - t[k - 1]);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace sparkdem::test
