#pragma once
/// Packing metrics: solid volume and packing density in a region, coordination numbers and
/// overlap statistics. Pure functions on arrays; lengths in [m].
///
/// Inputs: `positions` (sphere centres [m]) and `radii` [m] of equal length; `pairs` is a list of
/// CANDIDATE pairs (i, j), e.g. from a neighbour list: pairs that do not touch are allowed, the
/// functions test distances themselves. Each unordered pair must appear at most once (a duplicate
/// is counted twice). Invalid arguments throw ConfigError with an empty path.
#include <array>
#include <cstddef>
#include <variant>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/core/types.hpp"

namespace sparkdem::physics {

/// Axis-aligned box [lo, hi] [m].
struct BoxRegion {
  Vec3 lo = Vec3::Zero();  ///< lower corner [m]
  Vec3 hi = Vec3::Zero();  ///< upper corner [m]
};

/// Finite circular cylinder: points x with 0 <= (x - base).axis <= height and distance to the
/// axis <= radius.
struct CylinderRegion {
  Vec3 base = Vec3::Zero();   ///< point on the axis at the bottom face [m]
  Vec3 axis = Vec3::UnitZ();  ///< unit vector from bottom to top [-] (|axis| = 1 within 1e-6)
  double radius = 0.0;        ///< [m]
  double height = 0.0;        ///< [m]
};

using Region = std::variant<BoxRegion, CylinderRegion>;

/// Throws ConfigError unless the region is non-degenerate (hi > lo in every component; radius,
/// height > 0; unit axis).
void validate(const Region& region);

/// Region volume [m^3]: box prod(hi - lo); cylinder pi R^2 H.
double region_volume(const Region& region);

/// Interior region `margin` [m] (>= 0) away from every face: box lo + m, hi - m; cylinder base
/// moved by m along the axis, radius - m, height - 2m. Throws ConfigError if nothing is left.
Region shrink(const Region& region, double margin);

/// True if `point` [m] lies inside the region or on its boundary.
bool contains(const Region& region, const Vec3& point);

/// Volume [m^3] of the part of one sphere (centre [m], radius [m]) inside the region.
/// Spheres cut only by parallel planes (box faces normal to a single axis, or the cylinder end
/// faces with the sphere clear of the curved wall) use the exact slab formula; other cut spheres
/// use piecewise Gauss-Legendre quadrature over slices (see the .cpp); error against closed forms
/// and independent integrals in the tests ~1e-15 .. 1e-11 of the sphere volume.
double sphere_volume_in_region(const Vec3& centre, double radius, const Region& region);

/// Solid volume [m^3] inside the region: sum over spheres of sphere_volume_in_region. Sphere-sphere
/// overlaps are NOT subtracted (they are < 1 % of the radius in a valid packing, so the lens
/// volumes are a negligible correction).
double solid_volume_in_region(const std::vector<Vec3>& positions, const std::vector<double>& radii, const Region& region);

/// Packing density [-] = solid_volume_in_region / region_volume.
double packing_density(const std::vector<Vec3>& positions, const std::vector<double>& radii, const Region& region);

/// Contact-number statistics.
struct CoordinationStats {
  double mean = 0.0;           ///< mean contacts per counted particle [-] (0 if none counted)
  std::vector<int> histogram;  ///< histogram[z] = number of counted particles with z contacts
  std::size_t rattlers = 0;    ///< counted particles with 0 contacts
};

/// Coordination of all particles. Pair (i, j) is a contact if
///   |x_i - x_j| <= (r_i + r_j) (1 + gap_tolerance_relative).
CoordinationStats coordination(const std::vector<Vec3>& positions, const std::vector<double>& radii,
                               const std::vector<std::array<Index, 2>>& pairs, double gap_tolerance_relative);

/// As coordination(), but statistics only over particles whose centre is inside `region` (their
/// contacts with particles outside still count); use a shrunk region to exclude wall-affected
/// particles.
CoordinationStats coordination_in_region(const std::vector<Vec3>& positions, const std::vector<double>& radii,
                                         const std::vector<std::array<Index, 2>>& pairs, double gap_tolerance_relative, const Region& region);

/// Overlap statistics over the overlapping pairs, overlap delta = r_i + r_j - |x_i - x_j| > 0.
struct OverlapStats {
  double max_relative = 0.0;      ///< max over pairs of delta / min(r_i, r_j) [-] (0 if none)
  Index i = -1, j = -1;           ///< the pair reaching max_relative (-1 if none)
  double mean_relative = 0.0;     ///< mean of delta / min(r_i, r_j) over OVERLAPPING pairs only [-]
  std::size_t n_overlapping = 0;  ///< number of overlapping pairs
};

OverlapStats overlap_stats(const std::vector<Vec3>& positions, const std::vector<double>& radii,
                           const std::vector<std::array<Index, 2>>& pairs);

}  // namespace sparkdem::physics
