#pragma once
/// Microstructure figures of a packing as seed 001 reports them (Figs. 2 and 4) and the wall
/// layer: neighbour counts at a gap tolerance, eccentricities (Eq. 2), and the solid fraction in
/// layers parallel to the container wall. Pure functions on arrays; lengths in [m].
#include <vector>

#include "engine/core/types.hpp"
#include "physics/packing/packing_metrics.hpp"

namespace sparkdem::physics {

/// Neighbour and eccentricity statistics.
struct NeighbourStats {
  double gap_relative = 0.0;              ///< tolerance used: neighbours have gap <= gap_relative * r_mean [1]
  double mean = 0.0;                      ///< mean neighbour count [-]
  std::vector<double> histogram;          ///< histogram[n] = elements with n neighbours
  double eccentric_share = 0.0;           ///< share of elements with e >= e_face [-]
  double eccentric_share_interior = 0.0;  ///< the same over interior elements (NaN if none)
  double interior_share = 0.0;            ///< interior elements / all [-]
  double mean_core = 0.0;                 ///< mean neighbour count of the elements centred more than 4 mean diameters from every face (NaN if none)
  /// Shares of e in bins of 0.1 from 0 to 1.5 (the last bin also holds e >= 1.5), as Fig. 4.
  std::vector<double> eccentricity_histogram;
};

/// Neighbours of i: every j with |x_i - x_j| - r_i - r_j <= gap_relative * r_mean (overlapping
/// pairs included); e_i = |(1/n_i) sum_j x_j - x_i| / r_i (seed 001 Eq. 2; 0 without
/// neighbours); eccentric: e >= e_face - 1e-9 (0.4, the face element of the cubic lattice, with f = 2
/// of Eq. 3 from there on). Core (mean_core): centres more than 4 mean diameters from every face.
/// Interior: the element's surface more than one mean diameter from
/// every face of `region` (centre farther than r_i + 2 r_mean). Throws ConfigError on invalid
/// arguments (mismatched sizes, gap_relative < 0, e_face <= 0).
NeighbourStats neighbour_stats(const std::vector<Vec3>& positions, const std::vector<double>& radii, double gap_relative,
                               const Region& region, double e_face = 0.4);

/// Solid fraction in layers of width `bin_width` [m] at increasing distance from the wall:
/// a cylinder in annuli from its curved wall inward, over the height left after `end_margin` [m]
/// at each end (the end faces excluded); a box in shells between box shrinks (distance to the
/// nearest face). `interior` is the solid fraction of the region shrunk by `interior_margin` [m]
/// (cylinder: radially, still without the end margins; box: every face). Layers end where the
/// region is used up. Exact sphere-region volumes (sphere_volume_in_region), overlaps not
/// subtracted.
struct DensityProfile {
  double bin_width = 0.0;             ///< [m]
  std::vector<double> density;        ///< [-] per layer, first = at the wall
  double interior = 0.0;              ///< [-]
  double max_deviation_beyond = 0.0;  ///< max |density - interior| over layers starting >= interior_margin [-]
};
DensityProfile wall_density_profile(const std::vector<Vec3>& positions, const std::vector<double>& radii, const Region& region,
                                    double bin_width, double end_margin, double interior_margin);

}  // namespace sparkdem::physics
