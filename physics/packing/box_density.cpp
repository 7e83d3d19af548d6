#include "physics/packing/box_density.hpp"

#include "engine/core/error.hpp"
#include "physics/packing/packing_metrics.hpp"

namespace sparkdem::physics {

ParamSpec<BoxDensityMonitor::Params> BoxDensityMonitor::spec() {
  ParamSpec<Params> s("box_density", "object",
                      "solid fraction of the particles in a fixed box (stage key): columns box_solid_fraction = "
                      "sum of the spheres' volumes inside the box / box volume (overlaps not subtracted) and "
                      "box_particles (centres inside the box)");
  s.add_vec3("lo", &Params::lo).unit("m").doc("lower corner of the box");
  s.add_vec3("hi", &Params::hi).unit("m").doc("upper corner of the box (> lo in every component)");
  return s;
}

BoxDensityMonitor::BoxDensityMonitor(const Params& p) : p_(p) {
  for (int d = 0; d < 3; ++d)
    if (!(p_.hi[d] > p_.lo[d]))
      throw ConfigError("/hi", "expected hi > lo in every component [m], found hi[" + std::to_string(d) +
                                   "] = " + std::to_string(p_.hi[d]) + " <= lo[" + std::to_string(d) + "] = " + std::to_string(p_.lo[d]));
}

std::vector<std::string> BoxDensityMonitor::columns(const State&) const { return {"box_solid_fraction", "box_particles"}; }

std::vector<double> BoxDensityMonitor::values(const State& s) const {
  const Region box = BoxRegion{p_.lo, p_.hi};
  const auto& p = s.particles;
  double inside = 0.0;
  for (const Vec3& x : p.position) inside += contains(box, x) ? 1.0 : 0.0;
  return {packing_density(p.position, p.radius, box), inside};
}

}  // namespace sparkdem::physics
