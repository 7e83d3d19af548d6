#include "physics/packing/compact.hpp"
#include "physics/thermal/expansion.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace {
}

double lens_volume(double ri, double rj, double d) {
  if (d >= ri + rj) return 0.0;
  if (d <= std::abs(ri - rj)) {
    const double r = std::min(ri, rj);
    return 4.0 / 3.0 * kPi * r * r * r;
  }
  const double h = ri + rj - d;
  return kPi * h * h * (d * d + 2.0 * d * rj - 3.0 * rj * rj + 2.0 * d * ri + 6.0 * ri * rj - 3.0 * ri * ri) / (12.0 * d);
}

Vec3 lens_centre(const Vec3& xi, double ri, const Vec3& xj, double rj) {
  const Vec3 dx = xj - xi;
  const double d = dx.norm();
  if (d <= std::abs(ri - rj)) return ri <= rj ? xi : xj;
  const double a = (d * d + ri * ri - rj * rj) / (2.0 * d);
  return xi + (a / d) * dx;
}

double compact_solid_volume(const std::vector<Vec3>& positions, const std::vector<double>& radii,
                            const std::vector<std::array<Index, 2>>& pairs, const Region& region) {
  // solid_volume_in_region validates the region and the spheres.
  return minus_lenses(solid_volume_in_region(positions, radii, region), positions, radii, pairs, region);
}

double minus_lenses(double v, const std::vector<Vec3>& positions, const std::vector<double>& radii,
                    const std::vector<std::array<Index, 2>>& pairs, const Region& region) {
  for (const auto& [i, j] : pairs) {
    const double d = (positions[j] - positions[i]).norm();
    if (d >= radii[i] + radii[j]) continue;
    if (contains(region, lens_centre(positions[i], radii[i], positions[j], radii[j]))) v -= lens_volume(radii[i], radii[j], d);
  }
  return v;
}

CompactMonitor::CompactMonitor(CompactParams p) : p_(std::move(p)) {
  if (p_.bottom == p_.top) throw ConfigError("/top", "expected a wall other than the bottom punch, found \"" + p_.top + "\"");
}

ParamSpec<CompactParams> compact_spec() {
  using P = CompactParams;
  ParamSpec<P> s("compact", "object",
                 "porosity of a powder compact in a die (stage key): columns porosity = 1 - V_solid / (pi R^2 H) (spheres "
                 "clipped to the die and the punches, sphere-sphere lens volumes subtracted), porosity_interior, porosity_mass (lenses not "
                 "subtracted: mass-conserving, for sintered compacts), "
                 "relative_density, compact_height, envelope_radius, porosity_envelope (by mass in the sample's own envelope), "
                 "die_radius, porosity_mass_interior, envelope_p995_radius (99.5th percentile of axis distance + radius)");
  s.add("die", &P::die).doc("the die: a cylinder wall (its current radius R)");
  s.add("bottom", &P::bottom).doc("lower punch: a plane wall normal to the die axis");
  s.add("top", &P::top).doc("upper punch: a plane wall normal to the die axis, facing the lower one");
  s.add("interior_margin", &P::interior_margin)
      .unit("m")
      .nonnegative()
      .doc("porosity_interior: region this far from every wall (0: one largest particle diameter)");
  s.add("envelope_cell", &P::envelope_cell)
      .unit("1")
      .positive()
      .doc(
          "porosity_envelope: size of the caliper cells (slices along the axis, sectors about it) in mean particle "
          "diameters; a cell must hold a surface particle (a compact filling the die reads 0.99 of its radius at 2, "
          "the die radius at 3)");
  return s;
}

CylinderRegion compact_region(const State& s, const CompactParams& p) {
  auto find = [&](const std::string& name) -> const Wall& {
    for (const auto& w : s.walls)
      if (w.name == name) return w;
    throw SetupError("compact: no wall named '" + name + "' in this stage");
  };
  const Wall& die = find(p.die);
  const Wall& bottom = find(p.bottom);
  const Wall& top = find(p.top);
  if (die.is_plane()) throw SetupError("compact: the die '" + p.die + "' must be a cylinder wall");
  if (!bottom.is_plane() || !top.is_plane())
    throw SetupError("compact: the punches '" + p.bottom + "' and '" + p.top + "' must be plane walls");
  const auto& c = std::get<CylinderShape>(die.shape);
  const auto& pb = std::get<PlaneShape>(bottom.shape);
  const auto& pt = std::get<PlaneShape>(top.shape);
  Vec3 axis = c.axis;
  if (pb.normal.dot(axis) < 0.0) axis = -axis;  // axis from the lower punch to the upper one
  if (pb.normal.dot(axis) < 1.0 - 1e-6 || pt.normal.dot(axis) > -1.0 + 1e-6)
    throw SetupError("compact: the punches '" + p.bottom + "' and '" + p.top +
                     "' must be normal to the die axis with their normals pointing at each other");
  const double zb = (pb.point + bottom.u * pb.normal - c.base).dot(axis);
  const double zt = (pt.point + top.u * pt.normal - c.base).dot(axis);
  const double R = die.cylinder_radius();
  if (!(zt > zb) || !(R > 0.0))
    throw SetupError("compact: empty compact region (height " + std::to_string(zt - zb) + " m, die radius " + std::to_string(R) + " m)");
  return CylinderRegion{c.base + zb * axis, axis, R, zt - zb};
}

std::vector<std::string> CompactMonitor::columns(const State&) const {
  return {"porosity",      "porosity_interior", "relative_density",  "compact_height",        "porosity_mass",
          "envelope_radius", "porosity_envelope", "die_radius", "porosity_mass_interior", "envelope_p995_radius"};
}

namespace {
/// The 99.5th percentile of (distance from the region's axis + radius) over the particles.
double envelope_p995(const std::vector<Vec3>& positions, const std::vector<double>& radii, const CylinderRegion& region) {
  if (positions.empty()) return 0.0;
  std::vector<double> v(positions.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Vec3 d = positions[i] - region.base;
    v[i] = (d - d.dot(region.axis) * region.axis).norm() + radii[i];
  }
  const double at = 0.995 * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(at));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(lo), v.end());
  const double below = v[lo];
  if (lo + 1 >= v.size()) return below;
  const double above = *std::min_element(v.begin() + static_cast<std::ptrdiff_t>(lo) + 1, v.end());
  return below + (at - static_cast<double>(lo)) * (above - below);
}
}  // namespace

double envelope_volume(const std::vector<Vec3>& positions, const std::vector<double>& radii, const CylinderRegion& region,
                       double cell_diameters) {
  const std::size_t n = positions.size();
  if (n == 0) return 0.0;
  double r_mean = 0.0;
  for (double r : radii) r_mean += r / static_cast<double>(n);
  const double cell = cell_diameters * 2.0 * r_mean;
  const int nz = std::max(1, static_cast<int>(std::lround(region.height / cell)));
  const int nt = std::max(4, static_cast<int>(std::lround(2.0 * kPi * region.radius / cell)));
  const Vec3 axis = region.axis.normalized();
  const Vec3 e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
  std::vector<double> extent(static_cast<std::size_t>(nz) * nt, -1.0);  // -1: no particle in the cell
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 d = positions[i] - region.base;
    const double z = d.dot(axis);
    const int iz = std::clamp(static_cast<int>(std::floor(z / region.height * nz)), 0, nz - 1);
    const double angle = std::atan2(d.dot(e2), d.dot(e1)) + kPi;  // [0, 2 pi]
    const int it = std::clamp(static_cast<int>(std::floor(angle / (2.0 * kPi) * nt)), 0, nt - 1);
    double& e = extent[static_cast<std::size_t>(iz) * nt + it];
    e = std::max(e, (d - z * axis).norm() + radii[i]);
  }
  double volume = 0.0;
  for (int iz = 0; iz < nz; ++iz) {
    double sum = 0.0;
    int cells = 0;
    for (int it = 0; it < nt; ++it)
      if (const double e = extent[static_cast<std::size_t>(iz) * nt + it]; e >= 0.0) {
        sum += e;
        ++cells;
      }
    if (cells > 0) volume += kPi * (sum / cells) * (sum / cells) * region.height / nz;
  }
  return volume;
}

namespace {
/// Each particle's radius without the mass-conserving growth; empty when the particles have none
/// (their radii are their free radii).
std::vector<double> free_radii(const ParticleStore& p) {
  if (!p.fields.has(thermal::kRadiusFactorField)) return {};
  std::vector<double> r(p.radius.begin(), p.radius.end());
  const auto& g = p.fields.data(thermal::kRadiusFactorField);
  for (std::size_t i = 0; i < r.size(); ++i)
    if (g[i] > 0.0) r[i] /= g[i];
  return r;
}
}  // namespace

std::vector<double> CompactMonitor::values(const State& s) const {
  const CylinderRegion region = compact_region(s, p_);
  const auto& p = s.particles;
  if (p.size() == 0) return {1.0, 1.0, 0.0, region.height, 1.0, 0.0, 1.0, region.radius, 1.0, 0.0};
  const auto pairs = find_pairs(p.position, p.radius, 0.0);
  // Each region's spheres once; the lenses subtracted for `porosity`, not for the porosities by
  // mass (in sintering DEM the overlap stands for shrinkage; the lens material sits in the neck).
  // The porosities by mass take each particle's free radius: its radius less the mass-conserving
  // growth of its sintered necks (thermal::kRadiusFactorField), which holds no extra matter.
  const std::vector<double> grown_free = free_radii(p);
  const std::vector<double>& r_mass = grown_free.empty() ? p.radius : grown_free;
  const bool grown = !grown_free.empty();
  const double spheres_grown = solid_volume_in_region(p.position, p.radius, region);
  const double spheres = grown ? solid_volume_in_region(p.position, r_mass, region) : spheres_grown;
  const double porosity = 1.0 - minus_lenses(spheres_grown, p.position, p.radius, pairs, region) / region_volume(region);
  const double porosity_mass = 1.0 - spheres / region_volume(region);
  double margin = p_.interior_margin;
  if (margin == 0.0)
    for (double r : p.radius) margin = std::max(margin, 2.0 * r);
  double interior = std::nan(""), interior_mass = std::nan("");
  if (margin < region.radius && 2.0 * margin < region.height) {
    const Region inner = shrink(region, margin);
    const double inner_grown = solid_volume_in_region(p.position, p.radius, inner);
    interior = 1.0 - minus_lenses(inner_grown, p.position, p.radius, pairs, inner) / region_volume(inner);
    interior_mass = 1.0 - (grown ? solid_volume_in_region(p.position, r_mass, inner) : inner_grown) / region_volume(inner);
  }
  // The sample's own envelope (a cooled sample leaves the die wall): its solid by mass (spheres
  // clipped to the punches only) in its profiled envelope volume.
  CylinderRegion all = region;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Vec3 d = p.position[i] - region.base;
    all.radius = std::max(all.radius, (d - d.dot(region.axis) * region.axis).norm() + p.radius[i]);
  }
  const double v_env = envelope_volume(p.position, p.radius, region, p_.envelope_cell);
  const double porosity_envelope = 1.0 - compact_solid_volume(p.position, r_mass, {}, all) / v_env;
  const double r_env = std::sqrt(v_env / (kPi * region.height));
  return {porosity,          interior,      1.0 - porosity, region.height,
          porosity_mass,     r_env,         porosity_envelope, region.radius,
          interior_mass,     envelope_p995(p.position, p.radius, region)};
}

}  // namespace sparkdem::physics
