#pragma once
/// Stage key "necks": statistics of the sintered necks of the current state, the quantities of
/// seed 000's Fig. 6 (physics notes sintering-electrical.md §2.8, §5.2): for every contact row
/// whose law state column `neck_radius` is positive, x = a / r_min (r_min the smaller radius of
/// the pair, x in [0, 1] for a neck capped at r_min), and the histogram of x in `bins` equal bins
/// on [0, 1] (x = 1 in the last bin), in percent of the necks:
///
///   necks                    number of necks [1]
///   neck_median_a_over_rmin  median of x (mean of the two middle values for an even count) [1]
///   neck_max_bin_percent     the fullest bin [%] (Fig. 6's axis ends at 25 %)
///   neck_last_bin_percent    the bin [1 - 1/bins, 1]: saturated necks [%]
///
/// A law without a neck_radius column, or no neck: necks 0 and the others NaN. One of issue 36's
/// quasi-static gates of a hot press (no bin above 25 %, the median rising with density). O(N log N)
/// per sample (the median's partial sort).
#include <string>
#include <vector>

#include "engine/model/param_spec.hpp"
#include "engine/simulation.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::physics {

struct NeckStatistics {
  double necks = 0.0;
  double median = 0.0;            ///< median a / r_min [1] (NaN without necks)
  double max_bin_percent = 0.0;   ///< [%] (NaN without necks)
  double last_bin_percent = 0.0;  ///< [%] (NaN without necks)
};
/// The statistics of the ratios x = a / r_min (taken by value: sorted in place) in `bins` bins.
NeckStatistics neck_statistics(std::vector<double> ratios, std::int64_t bins);

/// Registered as the monitor (stage key) "necks" in physics/register_all.cpp.
class NeckMonitor final : public Monitor {
 public:
  struct Params {
    std::int64_t bins = 10;  ///< histogram bins on [0, 1] (seed 000 Fig. 6: 10)
  };
  static ParamSpec<Params> spec();
  explicit NeckMonitor(const Params& p) : p_(p) {}
  std::vector<std::string> columns(const State& s) const override;
  std::vector<double> values(const State& s) const override;

 private:
  Params p_;
};

}  // namespace sparkdem::physics
