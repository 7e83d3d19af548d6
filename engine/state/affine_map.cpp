#include "engine/state/affine_map.hpp"

#include <cmath>
#include <string>

#include "engine/core/error.hpp"

namespace sparkdem {

namespace {
/// The coordinate axis (0, 1, 2) a unit vector lies along, or -1.
int coordinate_axis(const Vec3& v) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(std::abs(v[k]) - 1.0) <= 1e-12) return k;
  return -1;
}
}  // namespace

void apply_affine_scale(State& s, const Vec3& origin, const Vec3& scale) {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(scale[k]) || !(scale[k] > 0.0))
      throw SetupError("affine: scale component " + std::to_string(k) + " is " + std::to_string(scale[k]) + ", expected a finite number > 0");
  const auto map = [&](const Vec3& x) -> Vec3 { return origin + scale.cwiseProduct(x - origin); };
  for (auto& w : s.walls) {
    if (auto* p = std::get_if<PlaneShape>(&w.shape)) {
      if (coordinate_axis(p->normal) < 0 && !(scale.maxCoeff() == scale.minCoeff()))
        throw SetupError("affine: wall '" + w.name + "' is a plane whose normal is not along a coordinate axis; only an isotropic scale maps it");
      p->point = map(p->point + w.u * p->normal) - w.u * p->normal;
    } else {
      auto& c = std::get<CylinderShape>(w.shape);
      const int a = coordinate_axis(c.axis);
      const int i = (a + 1) % 3, j = (a + 2) % 3;
      if (a < 0 || scale[i] != scale[j])
        throw SetupError("affine: wall '" + w.name + "' is a cylinder; its axis must lie along a coordinate axis and the two scales across it be equal");
      c.base = map(c.base);
      c.radius = scale[i] * (c.radius - w.u) + w.u;
    }
  }
  for (auto& x : s.particles.position) x = map(x);
  s.verlet.mark_built({}, {}, {});
  s.wall_candidates.clear();
  s.marks["neighbors_stale"] = 1.0;
}

}  // namespace sparkdem
