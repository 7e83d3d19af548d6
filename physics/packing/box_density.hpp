#pragma once
/// Stage key "box_density": the solid fraction of the particles in a fixed axis-aligned box, a
/// monitor for packings that are not a compact in a die (a box fill, a relaxed box, a bed under
/// a punch), e.g. to stop a stage with `until` once the bed reaches a density.
///
///   box_solid_fraction = sum_i V(sphere_i ∩ box) / V_box          (packing_density, [1])
///   box_particles      = number of particle centres inside the box (boundary included)
///
/// V(sphere ∩ box) is exact for spheres cut by box faces normal to one axis and Gauss-Legendre
/// quadrature otherwise (sphere_volume_in_region, physics/packing/packing_metrics.hpp); sphere-sphere
/// overlaps are not subtracted (they are below 1 % of the radius in a valid packing). O(N) per
/// sample. Lengths in [m].
#include <string>
#include <vector>

#include "engine/core/types.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/simulation.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::physics {

/// Registered as the monitor (stage key) "box_density" in physics/register_all.cpp.
class BoxDensityMonitor final : public Monitor {
 public:
  struct Params {
    Vec3 lo = Vec3::Zero();  ///< lower corner [m]
    Vec3 hi = Vec3::Zero();  ///< upper corner [m]
  };
  static ParamSpec<Params> spec();
  /// Throws ConfigError ("/hi") unless hi > lo in every component.
  explicit BoxDensityMonitor(const Params& p);
  std::vector<std::string> columns(const State& s) const override;
  std::vector<double> values(const State& s) const override;

 private:
  Params p_;
};

}  // namespace sparkdem::physics
