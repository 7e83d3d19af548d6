#pragma once
/// Pieces shared by the packing generators: the size-distribution parameters, random
/// sequential insertion, the container region seen by the walls, the bed height, the packing
/// report and the packing monitor.
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "engine/model/param_spec.hpp"
#include "engine/simulation.hpp"
#include "engine/state/state.hpp"
#include "physics/packing/packing_metrics.hpp"
#include "physics/packing/size_distribution.hpp"

namespace sparkdem::physics {

/// JSON-facing parameters of a size distribution (nested object "size_distribution").
struct SizeDistributionParams {
  std::string type = "lognormal";           ///< lognormal | table | uniform
  double d50 = 4.2e-6;                      ///< [m] lognormal median (number basis)
  double sigma = 0.43;                      ///< [1] sigma of ln d
  double d_min = 1.5e-6;                    ///< [m] truncation / uniform lower bound
  double d_max = 20e-6;                     ///< [m] truncation / uniform upper bound
  std::vector<double> diameters;            ///< [m] table diameters
  std::vector<double> cumulative_fraction;  ///< [1] table cumulative fractions
  std::string basis = "number";             ///< number | volume (table)
  std::string csv;                          ///< CSV file "diameter_m,cumulative_fraction" (replaces the inline table)
};

/// optional = true: `type` also takes "none" (the default): no distribution, the owner's own
/// radii (relax: uniform spread).
ParamSpec<SizeDistributionParams> size_distribution_spec(bool optional = false);
/// The default of an optional distribution: type "none".
inline SizeDistributionParams no_size_distribution() {
  SizeDistributionParams p;
  p.type = "none";
  return p;
}

/// Builds the distribution (reading the CSV if given). Throws ConfigError with paths relative
/// to the size_distribution object.
SizeDistribution make_distribution(const SizeDistributionParams& p);

/// Random sequential insertion of spheres (largest first) without overlap inside a region.
/// Returns false if some sphere found no place after max_attempts tries.
bool insert_random(State& s, const std::vector<double>& radii, const Region& region, double density, std::int32_t material,
                   std::size_t max_attempts = 20000);

/// Container of the walls: the first cylinder with the planes normal to its axis, or the box of
/// the axis-aligned planes. An open top is closed at the bed height (see bed_height()).
Region container_region(const State& s);

/// Height of the free surface above `floor` along `axis` [m]: the cross-section is cut into
/// square columns of two mean diameters; in each column the highest particle top (x.axis + r);
/// the bed height is the mean over occupied columns (the plain maximum would overstate a rough
/// surface by about one large particle).
double bed_height(const State& s, const Vec3& floor_point, const Vec3& axis);

/// N, density (overall and interior: one largest diameter away from every face), mean
/// coordination (overall and interior), rattlers, largest overlap / smaller radius (pairs and
/// walls).
/// With neighbour_gap_relative >= 0 also seed 001's microstructure figures (microstructure.hpp):
/// neighbours_mean, eccentric_share, eccentric_share_interior, interior_share at that gap
/// tolerance [fraction of r_mean], and the wall profile's bin width (half a mean diameter),
/// interior value (4 mean diameters from the wall) and largest deviation beyond it.
std::map<std::string, double> packing_report(const State& s, double neighbour_gap_relative = -1.0);
std::vector<int> packing_histogram(const State& s);
/// neighbour_histogram, eccentricity_histogram (shares in bins of 0.1) and density_profile
/// (bins of half a mean diameter from the wall) of packing_report's microstructure figures.
std::map<std::string, std::vector<double>> packing_arrays(const State& s, double neighbour_gap_relative);

/// Time-series columns packing_density, packing_density_interior, coordination_interior.
class PackingMonitor final : public Monitor {
 public:
  std::vector<std::string> columns(const State& s) const override;
  std::vector<double> values(const State& s) const override;
};

}  // namespace sparkdem::physics
