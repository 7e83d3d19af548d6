#include "physics/thermal/expansion.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "engine/core/error.hpp"
#include "engine/core/parallel.hpp"

namespace sparkdem::physics::thermal {

void declare_expansion(Declarations& d) {
  d.particle_fields.push_back({"radius_ref", 1, "m", 0.0, true});
  d.particle_fields.push_back({"radius_ref_temperature", 1, "K", 0.0, false});
  d.reads.push_back("mass");
  d.writes.insert(d.writes.end(), {"radius", "inertia"});
}

void capture_reference_radii(State& s, double t0_K, const std::string& module) {
  auto& p = s.particles;
  auto& rr = p.fields.data("radius_ref");
  auto& tr = p.fields.data("radius_ref_temperature");
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (rr[i] > 0.0) {
      if (tr[i] != t0_K) {
        std::ostringstream os;
        os.precision(10);
        os << module << ": the reference radii were captured at T_0 = " << tr[i] << " K (particle id " << p.id[i]
           << "), but this stage gives reference_temperature = " << t0_K << " K; keep it the same in every stage";
        throw SetupError(os.str());
      }
      continue;
    }
    rr[i] = p.radius[i];  // captured once: the current radius is the radius at T_0
    tr[i] = t0_K;
  }
}

namespace {
template <class TempOf>
void apply(State& s, double alpha, double t0, TempOf temp) {
  auto& p = s.particles;
  const auto& rr = p.fields.data("radius_ref");
  const double* g = p.fields.has(kRadiusFactorField) ? p.fields.data(kRadiusFactorField).data() : nullptr;
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  par::for_each(n, par::kLight, [&](std::int64_t i) {
    p.radius[i] = expanded_radius(rr[i], alpha, temp(i), t0) * (g && g[i] > 0.0 ? g[i] : 1.0);
    p.inertia[i] = 0.4 * p.mass[i] * p.radius[i] * p.radius[i];
  });
  // A non-finite or non-positive radius (from a non-finite temperature or reference radius)
  // stops the run here, before the neighbour search meets it.
  for (std::size_t i = 0; i < p.size(); ++i)
    if (!(p.radius[i] > 0.0) || !std::isfinite(p.radius[i]))
      throw PhysicsError(s.step, {p.id[i]}, "radius",
                         "thermal expansion gives radius " + std::to_string(p.radius[i]) + " m from the reference radius " +
                             std::to_string(rr[i]) + " m at temperature " + std::to_string(temp(static_cast<std::int64_t>(i))) + " K");
}
}  // namespace

void apply_expansion(State& s, double alpha_per_K, double t0_K, const std::vector<double>& T) {
  apply(s, alpha_per_K, t0_K, [&](std::int64_t i) { return T[static_cast<std::size_t>(i)]; });
}
void apply_expansion(State& s, double alpha_per_K, double t0_K, double T) {
  apply(s, alpha_per_K, t0_K, [T](std::int64_t) { return T; });
}

}  // namespace sparkdem::physics::thermal
