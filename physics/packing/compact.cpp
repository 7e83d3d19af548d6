#include "physics/packing/compact.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"

namespace sparkdem::physics {

namespace {
constexpr double kPi = std::numbers::pi;
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
  double v = solid_volume_in_region(positions, radii, region);  // validates the region and the spheres
  for (const auto& [i, j] : pairs) {
    const double d = (positions[j] - positions[i]).norm();
    if (d >= radii[i] + radii[j]) continue;
    if (contains(region, lens_centre(positions[i], radii[i], positions[j], radii[j])))
      v -= lens_volume(radii[i], radii[j], d);
  }
  return v;
}

ParamSpec<CompactParams> compact_spec() {
  using P = CompactParams;
  ParamSpec<P> s("compact", "object",
                 "porosity of a powder compact in a die (stage key): columns porosity = 1 - V_solid / (pi R^2 H) (spheres "
                 "clipped to the die and the punches, sphere-sphere lens volumes subtracted), porosity_interior, porosity_mass (lenses not subtracted: mass-conserving, for sintered compacts), "
                 "relative_density, compact_height");
  s.add("die", &P::die).doc("the die: a cylinder wall (its current radius R)");
  s.add("bottom", &P::bottom).doc("lower punch: a plane wall normal to the die axis");
  s.add("top", &P::top).doc("upper punch: a plane wall normal to the die axis, facing the lower one");
  s.add("interior_margin", &P::interior_margin).unit("m").nonnegative()
      .doc("porosity_interior: region this far from every wall (0: one largest particle diameter)");
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
    throw SetupError("compact: empty compact region (height " + std::to_string(zt - zb) + " m, die radius " +
                     std::to_string(R) + " m)");
  return CylinderRegion{c.base + zb * axis, axis, R, zt - zb};
}

std::vector<std::string> CompactMonitor::columns(const State&) const {
  return {"porosity", "porosity_interior", "relative_density", "compact_height", "porosity_mass"};
}

std::vector<double> CompactMonitor::values(const State& s) const {
  const CylinderRegion region = compact_region(s, p_);
  const auto& p = s.particles;
  if (p.size() == 0) return {1.0, 1.0, 0.0, region.height, 1.0};
  const auto pairs = find_pairs(p.position, p.radius, 0.0);
  const double porosity = 1.0 - compact_solid_volume(p.position, p.radius, pairs, region) / region_volume(region);
  double margin = p_.interior_margin;
  if (margin == 0.0)
    for (double r : p.radius) margin = std::max(margin, 2.0 * r);
  double interior = std::nan("");
  if (margin < region.radius && 2.0 * margin < region.height) {
    const Region inner = shrink(region, margin);
    interior = 1.0 - compact_solid_volume(p.position, p.radius, pairs, inner) / region_volume(inner);
  }
  // Mass-conserving porosity: the spheres' volume without subtracting the lenses (in sintering
  // DEM the overlap stands for shrinkage; the lens material sits in the neck).
  const double porosity_mass = 1.0 - compact_solid_volume(p.position, p.radius, {}, region) / region_volume(region);
  return {porosity, interior, 1.0 - porosity, region.height, porosity_mass};
}

}  // namespace sparkdem::physics
