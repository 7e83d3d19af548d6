#pragma once
/// Velocity-Verlet for translation and rotation of spheres (isotropic inertia).
///   v(n+1/2) = v(n) + dt/2 F(n)/m,  x(n+1) = x(n) + dt v(n+1/2),  v(n+1) = v(n+1/2) + dt/2 F(n+1)/m
///   w likewise with T/I; the orientation is advanced by the exact rotation of angle |w| dt
///   about w: q(n+1) = exp(dt w(n+1/2) / 2) q(n), renormalised.
#include <cmath>

#include "engine/state/particle_store.hpp"
#include "engine/core/parallel.hpp"

namespace sparkdem {

inline void verlet_first_half(ParticleStore& p, double dt) {
  const std::int64_t n = static_cast<std::int64_t>(p.size());
#pragma omp parallel for schedule(static) if (par::worth(n, par::kLight))
  for (std::int64_t i = 0; i < n; ++i) {
    if (p.fixed[i]) {  // prescribed velocity (zero = frozen): moved, not integrated
      if (p.fixed[i] == 1) p.position[i] += dt * p.velocity[i];  // 2: a rotating set, moved by the simulation
      continue;
    }
    p.velocity[i] += 0.5 * dt / p.mass[i] * p.force[i];
    p.position[i] += dt * p.velocity[i];
    p.omega[i] += 0.5 * dt / p.inertia[i] * p.torque[i];
    const double w2 = p.omega[i].squaredNorm();
    if (w2 > 0.0) {  // most spheres of a settling bed do not spin: no square root for them
      const double w = std::sqrt(w2);
      const double angle = w * dt;
      if (angle > 0.0) {
        const Quat dq(Eigen::AngleAxisd(angle, p.omega[i] / w));
        p.orientation[i] = (dq * p.orientation[i]).normalized();
      }
    }
  }
}

inline void verlet_second_half(ParticleStore& p, double dt) {
  const std::int64_t n = static_cast<std::int64_t>(p.size());
#pragma omp parallel for schedule(static) if (par::worth(n, par::kLight))
  for (std::int64_t i = 0; i < n; ++i) {
    if (p.fixed[i]) continue;
    p.velocity[i] += 0.5 * dt / p.mass[i] * p.force[i];
    p.omega[i] += 0.5 * dt / p.inertia[i] * p.torque[i];
  }
}

}  // namespace sparkdem
