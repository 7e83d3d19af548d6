#include "physics/packing/microstructure.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "physics/electrical/conductance_kernels.hpp"

namespace sparkdem::physics {

namespace {
/// Distance [m] from a point inside the region to its boundary (negative outside).
double distance_to_boundary(const Region& region, const Vec3& x) {
  if (const auto* b = std::get_if<BoxRegion>(&region)) {
    double d = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) d = std::min({d, x[k] - b->lo[k], b->hi[k] - x[k]});
    return d;
  }
  const auto& c = std::get<CylinderRegion>(region);
  const Vec3 rel = x - c.base;
  const double h = rel.dot(c.axis);
  const double rho = (rel - h * c.axis).norm();
  return std::min({c.radius - rho, h, c.height - h});
}
}  // namespace

NeighbourStats neighbour_stats(const std::vector<Vec3>& positions, const std::vector<double>& radii, double gap_relative,
                               const Region& region, double e_face) {
  if (positions.size() != radii.size())
    throw ConfigError("",
                      "neighbour_stats: " + std::to_string(positions.size()) + " positions but " + std::to_string(radii.size()) + " radii");
  if (!(gap_relative >= 0.0) || !std::isfinite(gap_relative))
    throw ConfigError("", "neighbour_stats: gap tolerance must be >= 0 (fraction of the mean radius)");
  if (!(e_face > 0.0)) throw ConfigError("", "neighbour_stats: eccentricity threshold must be > 0");
  validate(region);
  NeighbourStats st;
  st.gap_relative = gap_relative;
  const std::size_t n = positions.size();
  if (n == 0) return st;
  double rsum = 0.0;
  for (double r : radii) rsum += r;
  const double r_mean = rsum / static_cast<double>(n), gap = gap_relative * r_mean;
  std::vector<Index> a, b;
  for (const auto& p : find_pairs(positions, radii, gap)) {
    const double d = (positions[p[1]] - positions[p[0]]).norm();
    if (d - radii[p[0]] - radii[p[1]] <= gap) {
      a.push_back(p[0]);
      b.push_back(p[1]);
    }
  }
  std::vector<int> count(n, 0);
  for (std::size_t k = 0; k < a.size(); ++k) ++count[a[k]], ++count[b[k]];
  const std::vector<double> e = electrical::eccentricities(positions, radii, a, b);
  const int top = *std::max_element(count.begin(), count.end());
  st.histogram.assign(static_cast<std::size_t>(top) + 1, 0.0);
  st.eccentricity_histogram.assign(15, 0.0);
  std::size_t ecc = 0, interior = 0, ecc_interior = 0, core = 0;
  double core_sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    st.histogram[count[i]] += 1.0;
    st.mean += count[i];
    const bool eccentric = e[i] >= e_face - 1e-9;  // the tolerance of TransmissionSurfaceModel::platonic
    ecc += eccentric;
    st.eccentricity_histogram[std::min<std::size_t>(14, static_cast<std::size_t>(e[i] / 0.1))] += 1.0 / static_cast<double>(n);
    const double depth = distance_to_boundary(region, positions[i]);
    if (depth > radii[i] + 2.0 * r_mean) {
      ++interior;
      ecc_interior += eccentric;
    }
    if (depth > 8.0 * r_mean) {
      ++core;
      core_sum += count[i];
    }
  }
  st.mean_core = core > 0 ? core_sum / static_cast<double>(core) : std::numeric_limits<double>::quiet_NaN();
  st.mean /= static_cast<double>(n);
  st.eccentric_share = static_cast<double>(ecc) / static_cast<double>(n);
  st.interior_share = static_cast<double>(interior) / static_cast<double>(n);
  st.eccentric_share_interior = interior > 0 ? static_cast<double>(ecc_interior) / static_cast<double>(interior)
                                             : std::numeric_limits<double>::quiet_NaN();
  return st;
}

DensityProfile wall_density_profile(const std::vector<Vec3>& positions, const std::vector<double>& radii, const Region& region,
                                    double bin_width, double end_margin, double interior_margin) {
  if (!(bin_width > 0.0) || !(end_margin >= 0.0) || !(interior_margin >= 0.0))
    throw ConfigError("", "wall_density_profile: bin width must be > 0 and margins >= 0 [m]");
  validate(region);
  DensityProfile out;
  out.bin_width = bin_width;
  // The body the layers are cut from, and the same body shrunk by a distance t from the wall.
  Region body = region;
  double depth = 0.0;  // how far from the wall layers can go
  if (const auto* c = std::get_if<CylinderRegion>(&region)) {
    if (!(c->height > 2.0 * end_margin)) return out;
    body = CylinderRegion{c->base + end_margin * c->axis, c->axis, c->radius, c->height - 2.0 * end_margin};
    depth = c->radius;
  } else {
    const auto& bx = std::get<BoxRegion>(region);
    depth = 0.5 * (bx.hi - bx.lo).minCoeff();
  }
  auto inner = [&](double t) -> Region {
    if (const auto* c = std::get_if<CylinderRegion>(&body)) return CylinderRegion{c->base, c->axis, c->radius - t, c->height};
    return shrink(body, t);
  };
  auto solid = [&](const Region& r) { return solid_volume_in_region(positions, radii, r); };
  double v_out = region_volume(body), s_out = solid(body);
  for (double t = bin_width; t < depth - 1e-12 * depth; t += bin_width) {
    const Region in = inner(t);
    const double v_in = region_volume(in), s_in = solid(in);
    out.density.push_back((s_out - s_in) / (v_out - v_in));
    v_out = v_in;
    s_out = s_in;
  }
  if (interior_margin < depth) {
    const Region core = inner(interior_margin);
    out.interior = solid(core) / region_volume(core);
    for (std::size_t k = 0; k < out.density.size(); ++k)
      if (static_cast<double>(k) * bin_width >= interior_margin - 1e-12 * bin_width)
        out.max_deviation_beyond = std::max(out.max_deviation_beyond, std::abs(out.density[k] - out.interior));
  } else {
    out.interior = std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

}  // namespace sparkdem::physics
