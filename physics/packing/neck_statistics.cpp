#include "physics/packing/neck_statistics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sparkdem::physics {

NeckStatistics neck_statistics(std::vector<double> x, std::int64_t bins) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (x.empty()) return {0.0, nan, nan, nan};
  const std::size_t n = x.size(), mid = n / 2;
  std::nth_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(mid), x.end());
  double median = x[mid];
  if (n % 2 == 0) median = 0.5 * (median + *std::max_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(mid)));
  std::vector<double> count(static_cast<std::size_t>(bins), 0.0);
  for (double v : x) {
    const auto b = static_cast<std::int64_t>(std::floor(v * static_cast<double>(bins)));
    count[static_cast<std::size_t>(std::clamp<std::int64_t>(b, 0, bins - 1))] += 1.0;
  }
  const double percent = 100.0 / static_cast<double>(n);
  return {static_cast<double>(n), median, *std::max_element(count.begin(), count.end()) * percent, count.back() * percent};
}

ParamSpec<NeckMonitor::Params> NeckMonitor::spec() {
  ParamSpec<Params> s("necks", "object",
                      "statistics of the sintered necks (stage key; the contact law's neck_radius column, seed 000 Fig. 6): columns "
                      "necks, neck_median_a_over_rmin, neck_max_bin_percent (the fullest of `bins` bins of a / r_min on [0, 1]) and "
                      "neck_last_bin_percent (saturated necks)");
  s.add("bins", &Params::bins).unit("1").range(1.0, 1000.0).doc("histogram bins of a / r_min on [0, 1]");
  return s;
}

std::vector<std::string> NeckMonitor::columns(const State&) const {
  return {"necks", "neck_median_a_over_rmin", "neck_max_bin_percent", "neck_last_bin_percent"};
}

std::vector<double> NeckMonitor::values(const State& s) const {
  const auto& c = s.contacts;
  const int col = c.column("neck_radius");
  std::vector<double> x;
  if (col >= 0) {
    const auto& r = s.particles.radius;
    for (std::size_t row = 0; row < c.size(); ++row)
      if (const double a = c.state(row)[col]; a > 0.0) x.push_back(a / std::min(r[c.i(row)], r[c.j(row)]));
  }
  const NeckStatistics st = neck_statistics(std::move(x), p_.bins);
  return {st.necks, st.median, st.max_bin_percent, st.last_bin_percent};
}

}  // namespace sparkdem::physics
